"""calib-pin: kinematic calibration of robot arms from drawstring readings, on Pinocchio."""

from .calibration import CalibrationResult, calibrate
from .errors import CableModel, CalibrationProblem, Drawstring
from .estimators import ESTIMATORS, EstimateResult, get_estimator, run_estimator
from .exceptions import CalibPinError, DataError, EstimatorError, RobotError
from .export import write_calibrated_urdf
from .measurements import MeasurementSet, read_measurements, write_measurements
from .metrics import Metrics, split_rows
from .model import Chain, Kinematics, load_chain
from .parameters import DHModel, ParameterModel, PlacementModel, parameter_model
from .robots import DHTable, RobotDescription, resolve_robot
from .simulate import Truth, random_poses, simulate

__version__ = "0.1.0"

__all__ = [
    "CableModel",
    "CalibPinError",
    "CalibrationProblem",
    "CalibrationResult",
    "Chain",
    "DHModel",
    "DHTable",
    "DataError",
    "Drawstring",
    "ESTIMATORS",
    "EstimateResult",
    "EstimatorError",
    "Kinematics",
    "MeasurementSet",
    "Metrics",
    "ParameterModel",
    "PlacementModel",
    "RobotDescription",
    "RobotError",
    "Truth",
    "__version__",
    "calibrate",
    "get_estimator",
    "load_chain",
    "parameter_model",
    "random_poses",
    "read_measurements",
    "resolve_robot",
    "run_estimator",
    "simulate",
    "split_rows",
    "write_calibrated_urdf",
    "write_measurements",
]

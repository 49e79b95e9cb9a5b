"""calib-pin: kinematic calibration of robot arms from drawstring readings or marker
positions, on Pinocchio.

Figures of a comparison (matplotlib) are in :mod:`calib_pin.figures`, imported on demand.
"""

from .calibration import CalibrationResult, CalibrationSetup, calibrate, prepare
from .collect import Session, collect, open_session, read_pose_list
from .comparison import PAPER_TABLE1, Comparison, compare
from .drawstring import SensorFault, SensorProfile, StableReading, open_reader, read_stable
from .errors import CABLE_EXTRAS, CableModel, CalibrationProblem, Drawstring
from .estimators import ESTIMATORS, LOSSES, PAPER_LABELS, EstimateResult, get_estimator, run_estimator
from .exceptions import CalibPinError, DataError, EstimatorError, RobotError
from .export import write_calibrated_urdf
from .measurements import MeasurementSet, read_measurements, write_measurements, write_poses
from .metrics import Metrics, split_rows
from .model import Chain, Kinematics, load_chain
from .identifiability import Identifiability, analyze
from .parameters import MODELS, DHModel, HayatiModel, ParameterModel, PlacementModel, parameter_model
from .position import PositionDevice, PositionModel, fit_device
from .robots import DHTable, RobotDescription, resolve_robot
from .simulate import NOISE_KINDS, Truth, random_poses, simulate, simulate_positions

__version__ = "0.1.0"

__all__ = [
    "CABLE_EXTRAS",
    "CableModel",
    "CalibPinError",
    "CalibrationProblem",
    "CalibrationResult",
    "CalibrationSetup",
    "Chain",
    "Comparison",
    "DHModel",
    "DHTable",
    "DataError",
    "Drawstring",
    "ESTIMATORS",
    "EstimateResult",
    "EstimatorError",
    "HayatiModel",
    "Identifiability",
    "Kinematics",
    "LOSSES",
    "MODELS",
    "MeasurementSet",
    "Metrics",
    "NOISE_KINDS",
    "PAPER_LABELS",
    "PAPER_TABLE1",
    "ParameterModel",
    "PlacementModel",
    "PositionDevice",
    "PositionModel",
    "RobotDescription",
    "RobotError",
    "SensorFault",
    "SensorProfile",
    "Session",
    "StableReading",
    "Truth",
    "analyze",
    "calibrate",
    "collect",
    "compare",
    "fit_device",
    "get_estimator",
    "load_chain",
    "open_reader",
    "open_session",
    "parameter_model",
    "prepare",
    "random_poses",
    "read_measurements",
    "read_pose_list",
    "read_stable",
    "resolve_robot",
    "run_estimator",
    "simulate",
    "simulate_positions",
    "split_rows",
    "write_calibrated_urdf",
    "write_measurements",
    "write_poses",
    "__version__",
]

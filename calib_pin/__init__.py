"""calib-pin: kinematic calibration of robot arms from drawstring readings or marker
positions, on Pinocchio.

The public API is below; each name is imported from its module on first use, so
``import calib_pin`` is quick and pulls in no optional dependency. Figures
(matplotlib) are in :mod:`calib_pin.studies.comparison_figures`, the sensor hardware in
:mod:`calib_pin.hardware`.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any


def _version() -> str:
    """The installed distribution's version; read on first use of ``__version__``
    (importlib.metadata costs a command ~25 ms at start-up)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("calib-pin")
    except PackageNotFoundError:  # a source tree that was not installed
        return "0+unknown"

#: Public name -> the module that defines it.
_API = {
    "calibrate": "calibration.pipeline", "prepare": "calibration.pipeline", "CalibrationSetup": "calibration.pipeline",
    "CalibrationResult": "calibration.result",
    "load_calibration": "export.calibration_file", "CalibratedRobot": "export.compensation",
    "write_outputs": "report.bundle", "WrittenOutputs": "report.bundle", "OutputError": "util.outputs",
    "compare": "studies.comparison", "Comparison": "studies.comparison",
    "analyze": "analysis.identifiability",
    "CalibrationProblem": "estimators.problem", "StackedProblem": "calibration.problem", "FitSet": "calibration.multiset", "SetResult": "calibration.multiset",
    "Chain": "robot", "Kinematics": "robot", "load_chain": "robot", "Compliance": "robot.deflection",
    "DHModel": "parameters", "HayatiModel": "parameters", "PlacementModel": "parameters",
    "parameter_model": "parameters",
    "CableModel": "sensors", "Drawstring": "sensors", "PositionModel": "sensors", "PositionDevice": "sensors",
    "CableSetup": "sensors", "PositionSetup": "sensors",
    "PoseModel": "sensors", "PoseRig": "sensors", "PoseSetup": "sensors",
    "ContactModel": "sensors", "ContactSetup": "sensors", "Fixtures": "sensors",
    "MeasurementSet": "measurements", "read_measurements": "measurements", "write_measurements": "measurements",
    "check_measurements": "measurements.checks",
    "simulate": "simulation.simulate", "simulate_positions": "simulation.simulate", "simulate_sessions": "simulation.simulate",
    "Truth": "simulation.simulate",
    "ESTIMATORS": "estimators", "EstimateResult": "estimators", "run_estimator": "estimators",
    "ArgumentError": "exceptions", "CalibPinError": "exceptions", "DataError": "exceptions", "EstimatorError": "exceptions",
    "RobotError": "exceptions",
}

__all__ = [
    "ArgumentError",
    "CableModel",
    "CableSetup",
    "CalibPinError",
    "CalibrationProblem",
    "CalibrationResult",
    "CalibrationSetup",
    "CalibratedRobot",
    "Chain",
    "Comparison",
    "Compliance",
    "ContactModel",
    "ContactSetup",
    "DHModel",
    "DataError",
    "Drawstring",
    "ESTIMATORS",
    "EstimateResult",
    "EstimatorError",
    "FitSet",
    "Fixtures",
    "HayatiModel",
    "Kinematics",
    "MeasurementSet",
    "OutputError",
    "PlacementModel",
    "PoseModel",
    "PoseRig",
    "PoseSetup",
    "PositionDevice",
    "PositionModel",
    "PositionSetup",
    "RobotError",
    "SetResult",
    "StackedProblem",
    "Truth",
    "WrittenOutputs",
    "analyze",
    "calibrate",
    "check_measurements",
    "compare",
    "load_calibration",
    "load_chain",
    "parameter_model",
    "prepare",
    "read_measurements",
    "run_estimator",
    "simulate",
    "simulate_positions",
    "simulate_sessions",
    "write_measurements",
    "write_outputs",
    "__version__",
]


def __getattr__(name: str) -> Any:
    if name == "__version__":
        globals()[name] = value = _version()
        return value
    if name in _API:
        value = getattr(importlib.import_module(f".{_API[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'calib_pin' has no attribute {name!r}")


def __dir__() -> list[str]:
    return __all__


if TYPE_CHECKING:
    __version__: str
    from .analysis.identifiability import analyze
    from .calibration.multiset import FitSet, SetResult
    from .calibration.pipeline import CalibrationSetup, calibrate, prepare
    from .calibration.problem import StackedProblem
    from .calibration.result import CalibrationResult
    from .estimators import ESTIMATORS, EstimateResult, run_estimator
    from .estimators.problem import CalibrationProblem
    from .exceptions import ArgumentError, CalibPinError, DataError, EstimatorError, RobotError
    from .export.calibration_file import load_calibration
    from .export.compensation import CalibratedRobot
    from .measurements import MeasurementSet, read_measurements, write_measurements
    from .measurements.checks import check_measurements
    from .parameters import DHModel, HayatiModel, PlacementModel, parameter_model
    from .report.bundle import WrittenOutputs, write_outputs
    from .robot import Chain, Kinematics, load_chain
    from .robot.deflection import Compliance
    from .sensors import CableModel, CableSetup, Drawstring, PositionDevice, PositionModel, PositionSetup
    from .sensors.contact import ContactModel, ContactSetup, Fixtures
    from .sensors.pose import PoseModel, PoseRig, PoseSetup
    from .simulation.simulate import Truth, simulate, simulate_positions, simulate_sessions
    from .studies.comparison import Comparison, compare
    from .util.outputs import OutputError

"""calib-pin: kinematic calibration of robot arms from drawstring readings or marker
positions, on Pinocchio.

The public API is below; each name is imported from its module on first use, so
``import calib_pin`` is quick and pulls in no optional dependency. Figures
(matplotlib) are in :mod:`calib_pin.report.comparison_figures`, the sensor hardware in
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
    "calibrate": "pipeline", "prepare": "pipeline", "CalibrationSetup": "pipeline",
    "CalibrationResult": "result",
    "load_calibration": "export.calibration_file", "CalibratedRobot": "compensation",
    "write_outputs": "export.bundle", "WrittenOutputs": "export.bundle", "OutputError": "export.outputs",
    "compare": "studies.comparison", "Comparison": "studies.comparison",
    "analyze": "analysis.identifiability",
    "CalibrationProblem": "problem", "StackedProblem": "stacked", "FitSet": "multiset", "SetResult": "multiset",
    "Chain": "robot", "Kinematics": "robot", "load_chain": "robot", "Compliance": "robot.deflection",
    "DHModel": "parameters", "HayatiModel": "parameters", "PlacementModel": "parameters",
    "parameter_model": "parameters",
    "CableModel": "sensors", "Drawstring": "sensors", "PositionModel": "sensors", "PositionDevice": "sensors",
    "CableSetup": "sensors", "PositionSetup": "sensors",
    "PoseModel": "sensors", "PoseRig": "sensors", "PoseSetup": "sensors",
    "ContactModel": "sensors", "ContactSetup": "sensors", "Fixtures": "sensors",
    "MeasurementSet": "measurements", "read_measurements": "measurements", "write_measurements": "measurements",
    "check_measurements": "measurements.checks",
    "simulate": "simulation", "simulate_positions": "simulation", "simulate_sessions": "simulation",
    "Truth": "simulation",
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
    from .compensation import CalibratedRobot
    from .estimators import ESTIMATORS, EstimateResult, run_estimator
    from .exceptions import ArgumentError, CalibPinError, DataError, EstimatorError, RobotError
    from .export.bundle import WrittenOutputs, write_outputs
    from .export.calibration_file import load_calibration
    from .export.outputs import OutputError
    from .measurements import MeasurementSet, read_measurements, write_measurements
    from .measurements.checks import check_measurements
    from .multiset import FitSet, SetResult
    from .parameters import DHModel, HayatiModel, PlacementModel, parameter_model
    from .pipeline import CalibrationSetup, calibrate, prepare
    from .problem import CalibrationProblem
    from .result import CalibrationResult
    from .robot import Chain, Kinematics, load_chain
    from .robot.deflection import Compliance
    from .sensors import CableModel, CableSetup, Drawstring, PositionDevice, PositionModel, PositionSetup
    from .sensors.contact import ContactModel, ContactSetup, Fixtures
    from .sensors.pose import PoseModel, PoseRig, PoseSetup
    from .simulation import Truth, simulate, simulate_positions, simulate_sessions
    from .stacked import StackedProblem
    from .studies.comparison import Comparison, compare

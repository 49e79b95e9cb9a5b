"""calib-pin: kinematic calibration of robot arms on Pinocchio.

It calibrates from cables, trackers, 6-D poses or contacts.

A calibration is one robot and a list of measurement sets (one set is a list of one):
:func:`prepare` checks them once, :func:`solve` fits any method and scores the rows held
out, :func:`calibrate` is the two together. Each public name below is imported from its
module on first use, so ``import calib_pin`` is quick and pulls in no optional dependency.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings
from typing import TYPE_CHECKING, Any

#: Public name -> the module that defines it.
_API = {
    "calibrate": "calibration.solve", "solve": "calibration.solve",
    "prepare": "calibration.prepare", "Calibration": "calibration.prepare",
    "FitSet": "calibration.sets", "Fraction": "calibration.holdout", "Folds": "calibration.holdout",
    "TestSet": "calibration.holdout",
    "Problem": "calibration.problem", "SetProblem": "sensors.problem",
    "CalibrationResult": "calibration.result", "SetResult": "calibration.result",
    "load_calibration": "export.calibration_file", "CalibratedRobot": "export.compensation",
    "write_outputs": "report.bundle", "WrittenOutputs": "report.bundle", "OutputError": "util.outputs",
    "compare": "studies.comparison", "Comparison": "studies.comparison",
    "analyze": "analysis.identifiability",
    "Chain": "robot", "Kinematics": "robot", "load_chain": "robot", "Compliance": "robot.deflection",
    "DHModel": "parameters", "HayatiModel": "parameters", "PlacementModel": "parameters",
    "parameter_model": "parameters", "Prior": "parameters.prior",
    "CableModel": "sensors", "Drawstring": "sensors", "PositionModel": "sensors", "PositionDevice": "sensors",
    "CableSetup": "sensors", "PositionSetup": "sensors",
    "PoseModel": "sensors", "PoseRig": "sensors", "PoseSetup": "sensors",
    "ContactModel": "sensors", "ContactSetup": "sensors", "Fixtures": "sensors",
    "MeasurementSet": "measurements", "read_measurements": "measurements", "write_measurements": "measurements",
    "check_measurements": "measurements.checks",
    "simulate": "simulation", "simulate_positions": "simulation", "simulate_sessions": "simulation",
    "Truth": "simulation",
    "ESTIMATORS": "estimators", "EstimateResult": "estimators", "run_estimator": "estimators",
    "ArgumentError": "exceptions", "CalibPinError": "exceptions", "DataError": "exceptions",
    "EstimatorError": "exceptions", "RobotError": "exceptions",
}

#: Deprecated public names -> (the name to use, its module); each warns once.
_RENAMED = {
    "CalibrationSetup": ("Calibration", "calibration.prepare"),
    "CalibrationProblem": ("SetProblem", "sensors.problem"),
    "StackedProblem": ("Problem", "calibration.problem"),
}

#: Deprecated module paths -> the module that holds their contents, and their names that moved
#: elsewhere or were renamed (old name -> ``"new.module:new_name"``, in calib_pin). An import
#: of the old path warns once; an old name warns naming its replacement.
_MOVED_MODULES: dict[str, tuple[str, dict[str, str]]] = {
    "arguments": ("util.arguments", {
        "as_angles_rad": "robot.chain:as_angles_rad", "as_chain": "robot.chain:as_chain",
        "as_parameter_model": "parameters.base:as_parameter_model", "as_robot": "robot.description:as_robot"}),
    "units": ("util.units", {}), "progress": ("util.progress", {}), "atomic": ("util.atomic", {}),
    "input_files": ("util.input_files", {}), "optional": ("util.optional", {}), "sanity": ("parameters.sanity", {}),
    "compensation": ("export.compensation", {}),
    "problem": ("estimators.problem", {"CalibrationProblem": "sensors.problem:SetProblem"}),
    "stacked": ("calibration.problem", {"StackedProblem": "calibration.problem:Problem",
                                        "StackedModel": "calibration.problem:ProblemModel"}),
    "result": ("calibration.result", {}),
    "validation": ("calibration.validation", {"as_test_set": "calibration.holdout:TestSet"}),
    "multiset": ("calibration.sets", {
        "StackedSetup": "calibration.prepare:Calibration", "SetResult": "calibration.result:SetResult",
        "fit_sets": "calibration.prepare:_fit_sets", "MAX_FILTER_NOISE_M": "calibration.noise:MAX_FILTER_NOISE_M",
        "MAX_VCE_FITS": "calibration.noise:MAX_FITS", "VCE_TOLERANCE": "calibration.noise:TOLERANCE"}),
    "pipeline": ("calibration.solve", {"CalibrationSetup": "calibration.prepare:Calibration"}),
    "export.bundle": ("report.bundle", {}),
    "export.outputs": ("util.outputs", {"robot_file": "robot.description:robot_file",
                                        "robot_inputs": "robot.description:robot_inputs"}),
    "export.json_text": ("report.json_text", {}), "report.comparison_figures": ("studies.comparison_figures", {}),
    "parameters.start": ("calibration.start", {}), "parameters.held": ("calibration.held", {}),
    "analysis.subspace": ("estimators.subspace", {}), "analysis.noise": ("calibration.noise", {}),
    "studies.cross_validation": ("calibration.solve", {}),
}

#: What a deprecated name is to be replaced with, where the warning says more than its new path.
_ADVICE = {
    "fit_sets": "calib_pin.prepare takes a list of sets (a FitSet each)",
    "as_test_set": "calib_pin.TestSet(test_data)",
}

__all__ = [
    "ArgumentError",
    "CableModel",
    "CableSetup",
    "CalibPinError",
    "CalibratedRobot",
    "Calibration",
    "CalibrationResult",
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
    "Folds",
    "Fraction",
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
    "Prior",
    "Problem",
    "RobotError",
    "SetProblem",
    "SetResult",
    "TestSet",
    "Truth",
    "WrittenOutputs",
    "__version__",
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
    "solve",
    "write_measurements",
    "write_outputs",
]


def __getattr__(name: str) -> Any:
    if name == "__version__":
        from .util.version import package_version

        globals()[name] = value = package_version()
        return value
    if name in _API:
        value = getattr(importlib.import_module(f".{_API[name]}", __name__), name)
        globals()[name] = value
        return value
    if name in _RENAMED:
        new, module = _RENAMED[name]
        warnings.warn(f"calib_pin.{name} is deprecated: use calib_pin.{new}", DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module(f".{module}", __name__), new)
    raise AttributeError(f"module 'calib_pin' has no attribute {name!r}")


def __dir__() -> list[str]:
    return __all__


class _MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports of a deprecated module path give a module of its own that re-exports its contents.

    The alias holds the public names of the module that has its contents now, and gives the
    old names that moved elsewhere or were renamed on first use, each with a
    DeprecationWarning naming its replacement; the real modules are left as they are. Kept
    for one release.
    """

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> Any:
        old = fullname.removeprefix(f"{__name__}.")
        if old == fullname or old not in _MOVED_MODULES:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec: Any) -> Any:
        new = f"{__name__}.{_MOVED_MODULES[spec.name.removeprefix(f'{__name__}.')][0]}"
        warnings.warn(f"{spec.name} is deprecated: its contents are in {new}", DeprecationWarning, stacklevel=2)
        return None  # a plain module of the old name

    def exec_module(self, module: Any) -> None:
        target, moved = _MOVED_MODULES[module.__name__.removeprefix(f"{__name__}.")]
        real = importlib.import_module(f"{__name__}.{target}")
        module.__dict__.update({k: v for k, v in vars(real).items() if not k.startswith("__")})
        module.__all__ = sorted({k for k in vars(real) if not k.startswith("_")} | set(moved))

        from .util.deprecation import moved_names

        module.__getattr__ = moved_names(module.__name__, {k: f"{__name__}.{v}" for k, v in moved.items()}, _ADVICE)


sys.meta_path.append(_MovedModules())


if TYPE_CHECKING:
    __version__: str
    from .analysis.identifiability import analyze
    from .calibration.holdout import Folds, Fraction, TestSet
    from .calibration.prepare import Calibration, prepare
    from .calibration.problem import Problem
    from .calibration.result import CalibrationResult, SetResult
    from .calibration.sets import FitSet
    from .calibration.solve import calibrate, solve
    from .estimators import ESTIMATORS, EstimateResult, run_estimator
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
    from .sensors.problem import SetProblem
    from .simulation import Truth, simulate, simulate_positions, simulate_sessions
    from .studies.comparison import Comparison, compare
    from .util.outputs import OutputError

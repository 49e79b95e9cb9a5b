"""The calibration file: everything needed to reproduce a calibrated robot.

A calibration is more than a URDF: the URDF holds the geometry only, not the joints'
compliance nor what it was measured with. ``<robot>_calibration.json``, written beside
the URDF by :func:`write_calibration`, holds

- the robot (name, URDF path and its SHA-256) and the end frame;
- the parameter model and the robot's deviations (SI, and in mm/deg for people);
- the joint compliances with their spec (joints, payload, cable tension and the cable's
  hook and anchor the torques used);
- the sensor's calibrated geometry (for positions the device frame), the method and
  the data source, the metrics;
- the versions of calib-pin, Pinocchio and NumPy.

:func:`load_calibration` reads it back as a :class:`~calib_pin.compensation.CalibratedRobot`
(``.model``, ``.forward(q)``, ``.compensate(q)``).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from .compensation import CalibratedRobot
from .exceptions import CalibPinError, DataError, RobotError
from .input_files import check_regular
from .parameters import parameter_model
from .robot.chain import Chain, load_chain
from .robot.deflection import ComplianceSpec, stiffness
from .robot.description import resolve_robot
from .units import for_humans

if TYPE_CHECKING:
    from .result import CalibrationResult

#: What the file says it is, and its layout's version.
FORMAT = "calib-pin calibration"
FORMAT_VERSION = 1


def calibration_path(folder: str | Path, robot: str) -> Path:
    """``folder/<robot>_calibration.json``."""
    return Path(folder) / f"{robot}_calibration.json"


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _compliance(result: CalibrationResult) -> dict[str, Any] | None:
    model = result.problem.model
    spec, soft = model.compliance_spec, model.deflection
    if spec is None or soft is None:
        return None
    c = model.compliance(result.x)
    cable = soft.torque.cable
    return {
        **spec.to_dict(),
        "compliance_rad_per_Nm": dict(zip(spec.joints, c.tolist(), strict=True)),
        "stiffness_Nm_per_rad": {j: (k if np.isfinite(k) else None)
                                 for j, k in zip(spec.joints, stiffness(c).tolist(), strict=True)},
        "cable_pull": None if cable is None else {"hook_mm": (cable.hook_m * 1e3).tolist(),
                                                  "anchor_mm": (cable.anchor_m * 1e3).tolist()},
        "model": "q_link = q - c tau(q), tau the static joint torque at the commanded q",
    }


def calibration_document(result: CalibrationResult) -> dict[str, Any]:
    """The calibration file's content (JSON-ready)."""
    from . import __version__

    model, chain = result.problem.model, result.chain
    robot_x = model.robot(result.x)
    sensor_names = model.names[model.sensor_start:]
    return {
        "format": FORMAT, "format_version": FORMAT_VERSION,
        "robot": chain.name,
        "urdf": str(chain.description.urdf),
        "urdf_sha256": _sha256(Path(chain.description.urdf)),
        "end_frame": chain.end_frame,
        "joints": list(chain.joint_names),
        "parameter_model": result.model_name,
        "deviations_si": dict(zip(result.params.names, robot_x.tolist(), strict=True)),
        "deviation_units": dict(zip(result.params.names, result.params.units, strict=True)),
        "deviations": for_humans(robot_x, result.params.names, result.params.units),
        "compliance": _compliance(result),
        "sensor": {"kind": result.data.kind, "description": model.describe(),
                   "unknowns_si": dict(zip(sensor_names, model.sensor_part(result.x).tolist(), strict=True)),
                   **model.geometry_report(result.x)},
        "calibration": {"method": result.method, "loss": result.loss, "seed": result.seed,
                        "data": result.data.source, "test_data": result.test_source or None,
                        "train_rows": len(result.train), "test_rows": len(result.test),
                        "metrics_mm": {split: {stage: m.as_dict() for stage, m in stages.items()}
                                       for split, stages in result.metrics.items()}},
        "versions": {"calib_pin": __version__, "pinocchio": pin.__version__, "numpy": np.__version__},
        "note": "the URDF beside this file holds the geometry only; the joint compliances are here",
    }


def write_calibration(result: CalibrationResult, path: str | Path) -> Path:
    """Write the calibration file of ``result`` to ``path``.

    Raises:
        CalibPinError: the method estimates no kinematic parameters (``rbf``), or a
            compliance is negative (or NaN).
    """
    if not result.kinematic:
        raise CalibPinError(f"method '{result.method}' estimates no kinematic parameters: no calibration file")
    model = result.problem.model
    negative = [model.names[i] for i in model.nonnegative if not result.x[i] >= 0]
    if negative:  # compensate would use it blindly
        raise CalibPinError(f"{negative[0]} is negative (a compliance is >= 0): no calibration file written")
    path = Path(path)
    path.write_text(json.dumps(calibration_document(result), indent=2, allow_nan=False) + "\n", encoding="utf-8")
    return path


def find_calibration(path: Path) -> Path:
    """The calibration file ``path``, or the one ``*_calibration.json`` of folder ``path``.

    Raises:
        CalibPinError: no such file, or not exactly one in the folder.
    """
    check_regular(path)
    if path.is_dir():
        found = sorted(path.glob("*_calibration.json"))
        if len(found) != 1:
            raise CalibPinError(f"{path}: {'no' if not found else 'more than one'} *_calibration.json in this folder")
        return found[0]
    if not path.is_file():
        raise CalibPinError(f"{path}: no such calibration file")
    return path


def _chain(doc: dict[str, Any], robot: str | None, source: Path) -> Chain:
    """The nominal chain the calibration was made on: by name, else by the URDF path;
    its URDF must be the one calibrated (same SHA-256)."""
    if robot is not None and resolve_robot(robot).name != doc["robot"]:
        raise CalibPinError(f"{source} is a calibration of robot '{doc['robot']}', not '{resolve_robot(robot).name}'")
    candidates = [robot] if robot is not None else [doc["robot"], doc["urdf"]]
    for candidate in candidates:
        try:
            description = resolve_robot(candidate)
        except RobotError:
            continue
        if _sha256(Path(description.urdf)) == doc["urdf_sha256"]:
            return load_chain(description, doc["end_frame"])
    raise CalibPinError(f"{source}: the URDF of robot '{doc['robot']}' is not the one calibrated "
                        f"({doc['urdf']}, SHA-256 {doc['urdf_sha256'][:12]}...): calibrate again")


def _robot(doc: dict[str, Any], chain: Chain, source: Path, cable: bool) -> CalibratedRobot:
    if doc["parameter_model"] != "placement" and chain.description.dh is None:  # a URDF path has no DH table
        raise CalibPinError(f"{source} is a {doc['parameter_model']} calibration, which needs the DH table of "
                            f"robot '{doc['robot']}': give the robot by its name '{doc['robot']}', not as a URDF path")
    params = parameter_model(chain, doc["parameter_model"])
    stored = doc["deviations_si"]
    if list(stored) != list(params.names):
        raise DataError(str(source), f"deviations do not match the {params.name} model of '{chain.name}'",
                        None, "deviations_si")
    x = np.array([float(stored[name]) for name in params.names])
    soft, values, pull = doc.get("compliance"), None, None
    spec = None
    if soft:
        spec = ComplianceSpec.from_dict(soft)
        values = np.array([float(soft["compliance_rad_per_Nm"][j]) for j in spec.joints])
        if cable and soft.get("cable_pull"):
            pull = (np.asarray(soft["cable_pull"]["hook_mm"], float) * 1e-3,
                    np.asarray(soft["cable_pull"]["anchor_mm"], float) * 1e-3)
    return CalibratedRobot(chain, params, x, spec, values, pull)


def load_calibration(path: str | Path, robot: str | None = None, *, cable: bool = False) -> CalibratedRobot:
    """Read a calibration file (or the one ``*_calibration.json`` of a folder).

    Args:
        path: The file, or its folder.
        robot: The robot it must be for (a name or URDF path); default the file's.
        cable: Keep a drawstring's pull in the deflection (the arm as it was measured);
            default False: the arm in use, without the sensor's cable.

    Returns:
        The calibrated robot: ``.model`` (geometry), ``.forward(q)``, ``.compensate(q)``.

    Raises:
        CalibPinError: a missing or unreadable file, another robot, or a URDF that is
            not the one calibrated.
    """
    source = find_calibration(Path(path))
    try:
        doc = json.loads(source.read_text(encoding="utf-8"))
        if doc.get("format") != FORMAT:
            raise DataError(str(source), f"not a {FORMAT} file", None, "format")
        if int(doc.get("format_version", 0)) > FORMAT_VERSION:
            raise DataError(str(source), f"format version {doc['format_version']} is newer than this calib-pin "
                            f"reads ({FORMAT_VERSION}): update calib-pin", None, "format_version")
        return _robot(doc, _chain(doc, robot, source), source, cable)
    except OSError as e:
        raise DataError(str(source), f"cannot read: {e.strerror or e}") from None
    except (ValueError, KeyError, TypeError, AttributeError) as e:
        raise DataError(str(source), f"not a calib-pin calibration file ({type(e).__name__}: {e})") from None

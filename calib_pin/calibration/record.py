"""The calibration file of a calibration: its JSON document, written beside the URDF.

The layout is :mod:`calib_pin.export.calibration_file`'s, which reads the file back as a
:class:`~calib_pin.export.compensation.CalibratedRobot`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..exceptions import CalibPinError
from ..export.calibration_file import FORMAT, FORMAT_VERSION, file_sha256
from ..robot.deflection import ComplianceSpec, stiffness
from ..util.atomic import write_text
from ..util.units import for_humans
from ..util.version import package_version
from .result import CalibrationResult


def _compliance(result: CalibrationResult) -> dict[str, Any] | None:
    model = result.problem.model
    spec, soft = model.compliance_spec, model.deflection
    if spec is None or soft is None:
        return None
    c = model.compliance(result.x)
    if soft.basis is not None:
        return _basis_compliance(spec, soft.basis, c)
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


def _basis_compliance(spec: ComplianceSpec, basis: Any, beta: np.ndarray) -> dict[str, Any]:
    """The gravity basis model: its coefficients [rad] and the directions each term stands for.

    The directions are checked against the robot's own basis when the file is loaded.
    """
    owner = np.repeat(np.arange(len(spec.joints)), basis.terms)
    return {
        **spec.to_dict(),
        "basis_coefficients_rad": {j: beta[owner == i].tolist() for i, j in enumerate(spec.joints)},
        "basis_directions": {j: {"columns": cols.tolist(), "directions": v.tolist()}
                             for j, (cols, v) in zip(spec.joints, basis.directions, strict=True)},
        "model": "q_link = q + sum_k beta_jk b_jk(q), b the gravity basis of calib_pin.robot.gravity_basis",
    }


def _determined(result: CalibrationResult) -> dict[str, Any]:
    """What the data determines of the deviations, and the predicted accuracy at the named points."""
    u, accuracy = result.uncertainty, result.accuracy
    assert u is not None and accuracy is not None  # a kinematic result
    n = result.problem.model.sensor_start
    split = result.determined
    noise, _ = split.covariance()
    robot = split.robot
    return {"status": dict(zip(u.names[:n], u.status[:n], strict=True)),
            "combinations": u.as_dict()["combinations"], "prior": result.prior.as_dict(),
            "accuracy_mm": [p.as_dict() for p in accuracy.points], "points_named_by_user": bool(result.tcp),
            "unknowns": [u.names[i] for i in robot], "prior_sigma_si": split.sigma.tolist(),
            "undetermined_prior_units": split.vt[split.rank:].tolist(),
            "noise_covariance_si": noise[np.ix_(robot, robot)].tolist(),
            "model_error_mm_per_coordinate": accuracy.model_error * 1e3}


def calibration_document(result: CalibrationResult) -> dict[str, Any]:
    """The calibration file's content (JSON-ready)."""
    model, chain = result.problem.model, result.chain
    robot_x = model.robot(result.x)
    sensor_names = model.names[model.sensor_start:]
    return {
        "format": FORMAT, "format_version": FORMAT_VERSION,
        "robot": chain.name,
        "urdf": str(chain.description.urdf),
        "urdf_sha256": file_sha256(Path(chain.description.urdf)),
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
        "determined": _determined(result),
        "versions": {"calib_pin": package_version(), "pinocchio": pin.__version__, "numpy": np.__version__},
        "note": "the URDF beside this file holds the geometry only; the joint compliances are here",
    }


def calibration_text(result: CalibrationResult) -> str:
    """The text :func:`write_calibration` writes: the calibration file of ``result``.

    Args:
        result: A calibration's result.

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
    return json.dumps(calibration_document(result), indent=2, allow_nan=False) + "\n"


def write_calibration(result: CalibrationResult, path: str | Path) -> Path:
    """Write the calibration file of ``result`` to ``path``.

    Args:
        result: A calibration's result.
        path: The calibration file to write.

    Raises:
        CalibPinError: the method estimates no kinematic parameters (``rbf``), or a
            compliance is negative (or NaN).
    """
    text = calibration_text(result)
    path = Path(path)
    write_text(path, text)
    return path

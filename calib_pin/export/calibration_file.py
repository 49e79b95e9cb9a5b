"""The calibration file: everything needed to reproduce a calibrated robot.

A calibration is more than a URDF: the URDF holds the geometry only, not the joints'
compliance nor what it was measured with. ``<robot>_calibration.json``, written beside
the URDF (:func:`calib_pin.calibration.record.write_calibration`), holds

- the robot (name, URDF path and its SHA-256) and the end frame;
- the parameter model and the robot's deviations (SI, and in mm/deg for people);
- the joint compliances with their spec (joints, payload, cable tension and the cable's
  hook and anchor the torques used);
- the sensor's calibrated geometry (for positions the device frame), the method and
  the data source, the metrics;
- the versions of calib-pin, Pinocchio and NumPy.

:func:`load_calibration` reads it back as a :class:`~calib_pin.export.compensation.CalibratedRobot`
(``.model``, ``.forward(q)``, ``.compensate(q)``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import CalibPinError, DataError, RobotError
from ..parameters import parameter_model
from ..parameters.sanity import beyond_sanity
from ..robot.chain import Chain, load_chain
from ..robot.deflection import ComplianceSpec, stiffness
from ..robot.description import as_robot, resolve_robot
from ..util.arguments import MAX_MM, as_bool, as_optional, as_path
from ..util.input_files import check_regular
from ..util.units import for_humans
from .compensation import CalibratedRobot, Determination

#: What the file says it is, and its layout's version.
FORMAT = "calib-pin calibration"
FORMAT_VERSION = 1


def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes, in hex (the calibrated URDF's, in the file)."""
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def calibration_path(folder: str | Path, robot: str) -> Path:
    """``folder/<robot>_calibration.json``."""
    return Path(folder) / f"{robot}_calibration.json"


def find_calibration(path: Path) -> Path:
    """The calibration file ``path``, or the one ``*_calibration.json`` of folder ``path``.

    Args:
        path: A calibration file, or the folder that holds one.

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


def _json_spelling(value: float) -> str:
    return "NaN" if value != value else ("Infinity" if value > 0 else "-Infinity")


def _check_finite(value: Any, source: Path, key: str = "") -> None:
    """Refuse a NaN or infinite number anywhere in the document (calib-pin never writes one).

    The refusal names its key (``deviations_si.a_1``, ``compliance.cable_pull.anchor_mm[0]``).
    """
    if isinstance(value, float) and not np.isfinite(value):
        raise DataError(str(source), f"{_json_spelling(value)} is not a finite number", None, key or None)
    if isinstance(value, dict):
        for k, v in value.items():
            _check_finite(v, source, f"{key}.{k}" if key else str(k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _check_finite(v, source, f"{key}[{i}]")


def _field(doc: dict[str, Any], key: str, kind: type | tuple[type, ...], what: str, source: Path,
           prefix: str = "") -> Any:
    """``doc[key]`` when it is a ``kind``; else a DataError naming ``prefix + key``."""
    name = prefix + key
    if key not in doc:
        raise DataError(str(source), f"missing ({what})", None, name)
    value = doc[key]
    if isinstance(value, bool) or not isinstance(value, kind):
        raise DataError(str(source), f"expected {what}, got {json.dumps(value)[:40]}", None, name)
    return value


def _number(doc: dict[str, Any], key: str, source: Path, prefix: str, unit: str) -> float:
    return float(_field(doc, key, (int, float), f"a number in {unit}", source, prefix))


def _version(doc: dict[str, Any], source: Path) -> None:
    version = _field(doc, "format_version", int, f"a whole number from 1 to {FORMAT_VERSION}", source)
    if version > FORMAT_VERSION:
        raise DataError(str(source), f"format version {version} is newer than this calib-pin "
                        f"reads ({FORMAT_VERSION}): update calib-pin", None, "format_version")
    if version < 1:
        raise DataError(str(source), f"format version {version} does not exist (1 to {FORMAT_VERSION})",
                        None, "format_version")


def _chain(doc: dict[str, Any], robot: str | None, source: Path) -> Chain:
    """The nominal chain the calibration was made on: by name, else by the URDF path.

    Its URDF must be the one calibrated (same SHA-256), its joints the file's.
    """
    for key in ("robot", "urdf", "urdf_sha256", "end_frame"):
        _field(doc, key, str, "text", source)
    joints = _field(doc, "joints", list, "the list of joint names", source)
    if robot is not None and resolve_robot(robot).name != doc["robot"]:
        raise DataError(str(source), f"is a calibration of robot '{doc['robot']}', not '{resolve_robot(robot).name}'",
                        None, "robot")
    candidates = [robot] if robot is not None else [doc["robot"], doc["urdf"]]
    for candidate in candidates:
        try:
            description = resolve_robot(candidate)
        except RobotError:
            continue
        if file_sha256(Path(description.urdf)) == doc["urdf_sha256"]:
            try:
                chain = load_chain(description, doc["end_frame"])
            except RobotError as e:
                raise DataError(str(source), str(e), None, "end_frame") from None
            if list(joints) != list(chain.joint_names):
                raise DataError(str(source), f"{', '.join(map(str, joints))[:80]} are not the joints of "
                                f"'{chain.name}' to '{chain.end_frame}' ({', '.join(chain.joint_names)})",
                                None, "joints")
            return chain
    raise CalibPinError(f"{source}: the URDF of robot '{doc['robot']}' is not the one calibrated "
                        f"({doc['urdf']}, SHA-256 {doc['urdf_sha256'][:12]}...): calibrate again")


def _deviations(doc: dict[str, Any], params: Any, chain: Chain, source: Path) -> np.ndarray:
    """The robot's deviations (SI), each a number within calibrate's sanity bound."""
    stored = _field(doc, "deviations_si", dict, "the deviations by name", source)
    missing = [n for n in params.names if n not in stored]
    extra = [n for n in stored if n not in params.names]
    if missing or extra or list(stored) != list(params.names):
        what = (f"no {missing[0]}" if missing else f"{extra[0]} is not" if extra else "not in the order of")
        raise DataError(str(source), f"deviations do not match the {params.name} model of '{chain.name}' "
                        f"({what}{' a parameter of it' if extra and not missing else ''})", None, "deviations_si")
    x = np.array([_number(stored, name, source, "deviations_si.", unit)
                  for name, unit in zip(params.names, params.units, strict=True)])
    for value, name, unit in zip(x, params.names, params.units, strict=True):
        beyond = beyond_sanity(value, unit)
        if beyond:
            raise DataError(str(source), f"{beyond} that calibrate refuses to export: not a plausible "
                            "calibration (calibrate again)", None, f"deviations_si.{name}")
    _same_for_humans(doc, x, params, source)
    return x


def _same_for_humans(doc: dict[str, Any], x: np.ndarray, params: Any, source: Path) -> None:
    """Refuse a file whose ``deviations`` do not say what its ``deviations_si`` say.

    ``deviations`` are in mm and deg, for people to read; ``deviations_si`` are the values
    used. A value edited by hand in one of them only is refused, naming it. A file without
    ``deviations`` is fine.
    """
    shown = doc.get("deviations")
    if shown is None:
        return
    if not isinstance(shown, dict):
        raise DataError(str(source), f"expected the deviations in mm and deg by name, got {json.dumps(shown)[:40]}",
                        None, "deviations")
    for (key, used), name in zip(for_humans(x, params.names, params.units).items(), params.names, strict=True):
        if key not in shown:
            continue
        value = _number(shown, key, source, "deviations.", key.rsplit("_", 1)[-1])
        if not math.isclose(value, used, rel_tol=1e-6, abs_tol=1e-9):
            raise DataError(str(source), f"{value:g} contradicts deviations_si.{name} ({used:g} "
                            f"{key.rsplit('_', 1)[-1]}), the value compensate uses: edit both, or calibrate again",
                            None, f"deviations.{key}")


def _xyz_mm(doc: dict[str, Any], key: str, source: Path, prefix: str) -> np.ndarray:
    value = _field(doc, key, list, "3 numbers x, y, z in mm", source, prefix)
    if len(value) != 3 or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) < MAX_MM
                                  for v in value):
        raise DataError(str(source), f"expected 3 numbers x, y, z in mm, got {json.dumps(value)[:40]}",
                        None, prefix + key)
    return np.array(value, dtype=float) * 1e-3


def _compliance_of(soft: dict[str, Any], chain: Chain, source: Path,
                   cable: bool) -> tuple[ComplianceSpec, np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """The compliance spec, its values [rad/Nm] (each >= 0) and the cable's pull, checked."""
    p = "compliance."
    joints = _field(soft, "joints", list, "the compliant joints' names", source, p)
    unknown = [j for j in joints if j not in chain.joint_names]
    if unknown or not joints or len(set(joints)) != len(joints):
        raise DataError(str(source), f"{json.dumps(joints)[:60]} are not distinct joints of '{chain.name}' "
                        f"({', '.join(chain.joint_names)})", None, p + "joints")
    tension = _number(soft, "cable_tension_n", source, p, "N") if "cable_tension_n" in soft else 0.0
    if tension < 0:
        raise DataError(str(source), f"{tension:g} N is negative", None, p + "cable_tension_n")
    payload = soft.get("payload")
    if payload is not None:
        payload = _field(soft, "payload", dict, "the payload (mass_kg, com_mm) or null", source, p)
        if _number(payload, "mass_kg", source, p + "payload.", "kg") < 0:
            raise DataError(str(source), "a mass is >= 0", None, p + "payload.mass_kg")
        _xyz_mm(payload, "com_mm", source, p + "payload.")
    spec = ComplianceSpec.from_dict(soft)
    if spec.model == "basis":
        return spec, _basis_values(soft, spec, chain, source), None
    if spec.model != "cad":
        raise DataError(str(source), f"{json.dumps(spec.model)[:20]} is not a compliance model (cad, basis)", None,
                        p + "compliance_model")
    stored = _field(soft, "compliance_rad_per_Nm", dict, "the compliance of each joint", source, p)
    if sorted(stored) != sorted(spec.joints):
        raise DataError(str(source), f"holds {', '.join(stored) or 'none'}, the compliant joints are "
                        f"{', '.join(spec.joints)}", None, p + "compliance_rad_per_Nm")
    values = np.array([_number(stored, j, source, p + "compliance_rad_per_Nm.", "rad/Nm") for j in spec.joints])
    for j, c in zip(spec.joints, values, strict=True):
        if c < 0:
            raise DataError(str(source), f"{c:g} rad/Nm is negative: a compliance is >= 0", None,
                            f"{p}compliance_rad_per_Nm.{j}")
    shown = soft.get("stiffness_Nm_per_rad")  # for people; a hand edit there only is refused
    for j, k in zip(spec.joints, stiffness(values).tolist(), strict=True):
        if isinstance(shown, dict) and j in shown:
            given = shown[j]
            same = given is None if not np.isfinite(k) else (
                isinstance(given, (int, float)) and not isinstance(given, bool) and math.isclose(given, k, rel_tol=1e-6))
            if not same:
                raise DataError(str(source), f"{json.dumps(given)[:20]} contradicts compliance_rad_per_Nm.{j} (a "
                                f"stiffness of {k:.6g} Nm/rad), the value compensate uses: edit both, or calibrate "
                                "again", None, f"{p}stiffness_Nm_per_rad.{j}")
    pull = None
    if soft.get("cable_pull") is not None:
        where = _field(soft, "cable_pull", dict, "the cable's hook_mm and anchor_mm", source, p)
        hook = _xyz_mm(where, "hook_mm", source, p + "cable_pull.")
        anchor = _xyz_mm(where, "anchor_mm", source, p + "cable_pull.")
        pull = (hook, anchor) if cable else None
    return spec, values, pull


def _basis_values(soft: dict[str, Any], spec: ComplianceSpec, chain: Chain, source: Path) -> np.ndarray:
    """The basis coefficients [rad] of the file, in the robot's basis order.

    The file's basis directions must be the robot's (the same URDF gives the same basis).
    """
    from ..robot.gravity_basis import GravityBasis

    p = "compliance."
    basis = GravityBasis(chain, spec.joints)
    stored = _field(soft, "basis_coefficients_rad", dict, "the basis coefficients of each joint", source, p)
    directions = _field(soft, "basis_directions", dict, "the basis directions of each joint", source, p)
    values = []
    for j, n, (cols, v) in zip(spec.joints, basis.terms, basis.directions, strict=True):
        given = stored.get(j)
        if not isinstance(given, list) or len(given) != n:
            raise DataError(str(source), f"needs {n} coefficient(s) for {j}, the terms of its gravity basis", None,
                            f"{p}basis_coefficients_rad.{j}")
        values += [_number({str(k): v for k, v in enumerate(given)}, str(k), source,
                           f"{p}basis_coefficients_rad.{j}.", "rad") for k in range(n)]
        d = directions.get(j)
        given_v = d.get("directions") if isinstance(d, dict) else None
        same = isinstance(d, dict) and d.get("columns") == cols.tolist() and given_v is not None and \
            np.shape(given_v) == v.shape and np.allclose(given_v, v, rtol=1e-6, atol=1e-9)
        if not same:
            raise DataError(str(source), f"the gravity basis of {j} is not this robot's (another URDF or "
                            "calib-pin version): calibrate again", None, f"{p}basis_directions.{j}")
    return np.array(values, dtype=float)


def _robot(doc: dict[str, Any], chain: Chain, source: Path, cable: bool) -> CalibratedRobot:
    name = _field(doc, "parameter_model", str, "a parameter model's name", source)
    if name != "placement" and chain.description.dh is None:  # a URDF path has no DH table
        raise CalibPinError(f"{source} is a {name} calibration, which needs the DH table of "
                            f"robot '{doc['robot']}': give the robot by its name '{doc['robot']}', not as a URDF path")
    try:
        params = parameter_model(chain, name)
    except RobotError as e:
        raise DataError(str(source), str(e), None, "parameter_model") from None
    x = _deviations(doc, params, chain, source)
    soft = doc.get("compliance")
    if not soft:
        robot = CalibratedRobot(chain, params, x)
    else:
        soft = _field(doc, "compliance", dict, "the joint compliances or null", source)
        spec, values, pull = _compliance_of(soft, chain, source, cable)
        robot = CalibratedRobot(chain, params, x, spec, values, pull)
    determined = doc.get("determined")
    if isinstance(determined, dict):
        robot.determination = Determination.from_dict(determined, tuple(params.names))
    return robot


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
            not the one calibrated; a file whose content is not what calibrate writes:
            its format version, a value that is not a finite number (anywhere), other
            joints or parameter names than the robot's, a deviation beyond calibrate's
            sanity bound (:mod:`calib_pin.parameters.sanity`), a negative compliance. The message
            names the file and the key (``deviations_si.a_1``).
    """
    source = find_calibration(as_path(path, "path"))
    robot = as_optional(as_robot, robot, "robot")
    cable = as_bool(cable, "cable")
    try:
        doc = json.loads(source.read_text(encoding="utf-8-sig"))  # a BOM: an editor on Windows
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise DataError(str(source), f"not a {FORMAT} file", None, "format")
        _version(doc, source)
        _check_finite(doc, source)
        return _robot(doc, _chain(doc, robot, source), source, cable)
    except OSError as e:
        raise DataError(str(source), f"cannot read: {e.strerror or e}") from None
    except (ValueError, KeyError, TypeError, AttributeError) as e:
        raise DataError(str(source), f"not a calib-pin calibration file ({type(e).__name__}: {e})") from None


def __getattr__(name: str) -> Any:
    """The old names of what moved elsewhere (the writer of calib_pin.calibration.record), with a DeprecationWarning."""
    from ..util.deprecation import moved_names

    return moved_names(__name__, {
        "calibration_document": "calib_pin.calibration.record", "calibration_text": "calib_pin.calibration.record",
        "write_calibration": "calib_pin.calibration.record"})(name)

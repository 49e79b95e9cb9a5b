"""Calibration results as YAML a robot description loads.

- :func:`write_joint_origins_yaml`: ``joint_name: {x, y, z, roll, pitch, yaw}`` for every
  chain joint and the tool chain's first fixed joint, the corrected URDF ``<origin>`` of
  that joint (relative to its parent link; [m], [rad]; rpy as URDF's fixed-axis X-Y-Z,
  Pinocchio's ``matrixToRpy``). The same origins :func:`calib_pin.export.write_calibrated_urdf`
  writes, for a xacro that loads them with ``xacro.load_yaml``.
- :func:`write_ur_kinematics_yaml`: for Universal Robots arms, the layout of
  ur_description's ``config/<type>/default_kinematics.yaml`` (see :func:`ur_kinematics`);
  :func:`read_ur_kinematics_yaml` reads that layout back (a controller's own calibration,
  extracted by ``ur_calibration``, or the file calib-pin wrote) as the chain's corrections.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin
import yaml
from lxml import etree

from ..exceptions import DataError, RobotError
from ..robot.chain import Chain
from ..util.atomic import write_text
from .urdf import corrected_origins, top_level_joints

#: ur_description's kinematics keys for the six UR joints, base to wrist.
UR_KEYS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
UR_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
             "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")


def _pose_dict(placement: pin.SE3) -> dict[str, float]:
    """x, y, z [m] and roll, pitch, yaw [rad] (URDF fixed-axis X-Y-Z) of a placement."""
    rpy = pin.rpy.matrixToRpy(placement.rotation)
    values = [*placement.translation, *rpy]
    return {k: float(v) if abs(v) > 1e-15 else 0.0
            for k, v in zip(("x", "y", "z", "roll", "pitch", "yaw"), values, strict=True)}


def _write_yaml(path: str | Path, header: list[str], body: dict) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = "".join(f"# {line}\n" for line in header)
    write_text(path, text + yaml.safe_dump(body, sort_keys=False, default_flow_style=False))
    return path


def joint_origins(chain: Chain, deltas: Sequence[pin.SE3]) -> dict[str, pin.SE3]:
    """Corrected URDF origins of the chain's joints and of the tool chain's first fixed joint.

    The origins :func:`calib_pin.export.write_calibrated_urdf` writes (see
    :func:`calib_pin.export.urdf.corrected_origins`).

    Args:
        chain: The nominal chain (its URDF is the source).
        deltas: ``n_joints + 1`` transforms from a parameter model.

    Returns:
        Joint name -> origin relative to the joint's parent link, base to end.

    Raises:
        RobotError: the end frame has a correction but no fixed joint to carry it.
    """
    root = etree.parse(str(chain.description.urdf)).getroot()
    return corrected_origins(top_level_joints(root), chain, deltas)


def write_joint_origins_yaml(chain: Chain, deltas: Sequence[pin.SE3], path: str | Path,
                             notes: Sequence[str] = ()) -> Path:
    """Write the corrected joint origins as ``joint: {x, y, z, roll, pitch, yaw}``.

    Units [m] and [rad]; each origin is relative to the joint's parent link, as in the
    URDF ``<origin xyz rpy>``. A xacro loads it with ``xacro.load_yaml``.

    Args:
        chain: The nominal robot chain.
        deltas: The perturbation of each joint placement and of the end frame.
        path: The YAML file to write.

    Raises:
        RobotError: as :func:`joint_origins`.
    """
    origins = joint_origins(chain, deltas)
    header = [
        (f"calib-pin: corrected joint origins of robot '{chain.name}' "
        f"(URDF {Path(chain.description.urdf).name}, end frame {chain.end_frame})"),
        "each entry: the joint's <origin> relative to its parent link; x y z [m],",
        "roll pitch yaw [rad] (URDF fixed-axis X-Y-Z). Load with xacro.load_yaml.",
        *notes,
    ]
    return _write_yaml(path, header, {name: _pose_dict(p) for name, p in origins.items()})


def _axis_lines(model: pin.Model, q: np.ndarray) -> tuple[list[pin.SE3], list[np.ndarray]]:
    """Joint frames and joint axis directions (base frame) of a chain model at q."""
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    frames, axes = [], []
    for j in range(1, model.njoints):
        local = pin.getJointJacobian(model, data, j, pin.LOCAL)[3:, model.joints[j].idx_v]
        frames.append(data.oMi[j].copy())
        axes.append(data.oMi[j].rotation @ (local / np.linalg.norm(local)))
    return frames, axes


def _closest(p1: np.ndarray, u1: np.ndarray, p2: np.ndarray, u2: np.ndarray) -> np.ndarray:
    """Point of line (p1, u1) closest to line (p2, u2); the foot of p2 if they are parallel."""
    w = p1 - p2
    b = u1 @ u2
    denom = 1.0 - b * b
    s = (b * (u2 @ w) - (u1 @ w)) / denom if denom > 1e-12 else -(u1 @ w)
    return p1 + s * u1


def _rx(angle: float) -> pin.SE3:
    return pin.SE3(pin.rpy.rpyToMatrix(angle, 0.0, 0.0), np.zeros(3))


#: ur_description's fixed transforms: base_link -> base_link_inertia, wrist_3_link -> tool0.
UR_BASE_INERTIA = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, np.pi), np.zeros(3))
UR_WRIST3_TOOL0 = pin.SE3(pin.rpy.rpyToMatrix(0.0, -np.pi / 2, -np.pi / 2), np.zeros(3)) * pin.SE3(
    pin.rpy.rpyToMatrix(np.pi / 2, 0.0, np.pi / 2), np.zeros(3))
#: Rotation of each UR joint origin at the nominal geometry (the DH twists pi/2, 0, 0, pi/2, -pi/2).
_UR_TWISTS = (0.0, np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2)


def _ur_link_frames(chain: Chain) -> list[pin.SE3]:
    """Nominal ur_description link frames (shoulder_link ... wrist_3_link) at q = 0, base frame.

    Origins follow UR's DH layout: shoulder and upper arm at the crossing of axes 1 and
    2, forearm at the foot of that point on axis 3, wrist 1/2 at the crossings of axes
    4-5 and 5-6, wrist 3 at tool0's origin on axis 6.
    """
    frames, axes = _axis_lines(chain.model, chain.configuration(np.zeros(chain.n_joints)))
    p = [f.translation for f in frames]
    data = chain.model.createData()
    pin.framesForwardKinematics(chain.model, data, chain.configuration(np.zeros(chain.n_joints)))
    tool0 = data.oMf[chain.frame_id].translation
    shoulder = _closest(p[1], axes[1], p[0], axes[0])
    origins = [
        _closest(p[0], axes[0], p[1], axes[1]),
        shoulder,
        _closest(p[2], axes[2], shoulder, axes[2]),  # foot of the shoulder point on axis 3
        _closest(p[3], axes[3], p[4], axes[4]),
        _closest(p[4], axes[4], p[5], axes[5]),
        _closest(p[5], axes[5], tool0, axes[5]),
    ]
    rotation = UR_BASE_INERTIA.rotation.copy()
    out = []
    for i, (twist, origin) in enumerate(zip(_UR_TWISTS, origins, strict=True)):
        rotation = rotation @ _rx(twist).rotation
        if abs(rotation[:, 2] @ axes[i]) < 1 - 1e-9:
            raise RobotError(f"joint '{chain.joint_names[i]}' of '{chain.name}' is not where a UR "
                             "arm has it at zero (ur_description layout does not apply)")
        out.append(pin.SE3(rotation, origin))
    return out


def ur_kinematics(chain: Chain, deltas: Sequence[pin.SE3]) -> tuple[dict[str, pin.SE3], pin.SE3]:
    """Corrected UR joint origins in ur_description's layout, and what it cannot hold.

    ur_description builds base_link -> base_link_inertia (Rz(pi)) -> shoulder_pan_joint
    origin ``shoulder`` -> ... -> wrist_3_joint origin ``wrist_3`` -> flange -> tool0 (fixed
    rotations). Its link frames are attached to the same bodies as this URDF's (a
    constant transform G_i per link, found at the nominal geometry and checked), so the
    corrected origins are G_{i-1}^-1 P_i G_i with P_i the corrected joint placements.
    The end frame's correction is absorbed as far as a screw about axis 6 allows (into
    ``wrist_3``); the rest is returned.

    Args:
        chain: A UR chain (6 joints named like ur_description's, end frame tool0).
        deltas: ``n_joints + 1`` transforms from a parameter model.

    Returns:
        origins: kinematics key (``shoulder`` ... ``wrist_3``) -> origin [m, rad].
        tool0_rest: the part of the end-frame correction the layout cannot hold: the
            calibrated tool0 is ur_description's tool0 times this (identity when the
            end frame is uncorrected).

    Raises:
        RobotError: the chain is not laid out like a UR arm.
    """
    if chain.n_joints != 6 or not all(n.endswith(u) for n, u in zip(chain.joint_names, UR_JOINTS, strict=True)):
        raise RobotError(f"robot '{chain.name}' does not have UR's six joints "
                         f"({', '.join(UR_JOINTS)}): no ur_description kinematics")
    links = _ur_link_frames(chain)
    data = chain.model.createData()
    pin.forwardKinematics(chain.model, data, chain.configuration(np.zeros(6)))
    g = [data.oMi[i + 1].actInv(link) for i, link in enumerate(links)]
    tool_nominal = pin.updateFramePlacement(chain.model, data, chain.frame_id)
    if np.linalg.norm(pin.log6(tool_nominal.actInv(links[5] * UR_WRIST3_TOOL0)).vector) > 1e-6:
        raise RobotError(f"'{chain.end_frame}' of '{chain.name}' is not UR's tool0 (flange "
                         "convention of ur_description): no ur_description kinematics")
    model = chain.perturbed_model(deltas, full=False)
    origins = {}
    previous = UR_BASE_INERTIA
    for key, placement, link in zip(UR_KEYS, list(model.jointPlacements)[1:], g, strict=True):
        origins[key] = previous.actInv(placement * link)
        previous = link
    m = g[5].actInv(model.frames[chain.frame_id].placement) * UR_WRIST3_TOOL0.inverse()
    screw = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, np.arctan2(m.rotation[1, 0], m.rotation[0, 0])),
                    np.array([0.0, 0.0, m.translation[2]]))
    origins["wrist_3"] = origins["wrist_3"] * screw
    rest = UR_WRIST3_TOOL0.actInv(screw.actInv(m * UR_WRIST3_TOOL0))
    return origins, rest


def write_ur_kinematics_yaml(chain: Chain, deltas: Sequence[pin.SE3], path: str | Path) -> pin.SE3:
    """Write ur_description's ``default_kinematics.yaml`` layout for a calibrated UR arm.

    ``kinematics: {shoulder, upper_arm, forearm, wrist_1, wrist_2, wrist_3: {x, y, z,
    roll, pitch, yaw}, hash}`` in [m] and [rad]; the hash is calib-pin's (the UR driver
    warns that it is not the controller's own calibration). Pass the file as
    ur_description's ``kinematics_params`` / ``kinematics_parameters_file``.

    Args:
        chain: The nominal chain of a UR arm.
        deltas: The perturbation of each joint placement and of the end frame.
        path: The YAML file to write.

    Returns:
        The part of the end-frame correction this layout cannot hold (see
        :func:`ur_kinematics`), also written in the file's header; the caller should
        say so when it is not the identity (set it as the tool/TCP offset).

    Raises:
        RobotError: not a UR arm.
    """
    origins, rest = ur_kinematics(chain, deltas)
    body = {key: _pose_dict(p) for key, p in origins.items()}
    digest = hashlib.sha256(yaml.safe_dump(body).encode()).hexdigest()[:16]
    shift = rest.translation * 1e3
    turn = np.rad2deg(pin.rpy.matrixToRpy(rest.rotation))
    header = [
        f"calib-pin: calibrated kinematics of '{chain.name}' in ur_description's default_kinematics.yaml",
        "layout: joint origins relative to the parent link of ur_description's URDF; x y z [m],",
        "roll pitch yaw [rad]. The hash is calib-pin's, not the controller's calibration checksum.",
        "tool0 correction this layout cannot hold (calibrated tool0 = ur_description tool0 * T):",
        (f"T xyz [mm] = {shift[0]:.9f} {shift[1]:.9f} {shift[2]:.9f}; "  # read back by read_ur_kinematics_yaml
        f"rpy [deg] = {turn[0]:.9f} {turn[1]:.9f} {turn[2]:.9f}"),
    ]
    _write_yaml(path, header, {"kinematics": {**body, "hash": f"calib_pin_{digest}"}})
    return rest




#: The header line write_ur_kinematics_yaml writes for the tool0 part the layout cannot hold.
_REST = re.compile(r"T xyz \[mm\] = (\S+) (\S+) (\S+); rpy \[deg\] = (\S+) (\S+) (\S+)")


def read_ur_entries(path: str | Path) -> tuple[dict[str, list[float]], str]:
    """The six joint origins of a ``default_kinematics.yaml`` as written, and the file's text.

    Each kinematics key (``shoulder`` ... ``wrist_3``) -> ``[x, y, z, roll, pitch, yaw]``,
    numbers as the file gives them (metres and, in the layout, radians).

    Raises:
        DataError: not the layout (naming the missing key or bad value).
    """
    path = Path(path)
    text = path.read_text(encoding="utf-8-sig")
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise DataError(str(path), f"not YAML: {str(e).splitlines()[0]}") from None
    body = doc.get("kinematics") if isinstance(doc, dict) else None
    if not isinstance(body, dict):
        raise DataError(str(path), "no 'kinematics:' mapping (ur_description's default_kinematics.yaml layout)")
    entries = {}
    for key in UR_KEYS:
        entry = body.get(key)
        if not isinstance(entry, dict):
            raise DataError(str(path), f"no kinematics.{key} entry {{x, y, z, roll, pitch, yaw}}")
        try:
            v = [float(entry[k]) for k in ("x", "y", "z", "roll", "pitch", "yaw")]
        except (KeyError, TypeError, ValueError):
            raise DataError(str(path), f"kinematics.{key} needs numbers x, y, z [m], roll, pitch, yaw [rad]") from None
        if not np.all(np.isfinite(v)) or max(abs(c) for c in v[:3]) > 10.0:
            raise DataError(str(path), f"kinematics.{key}: {v} is not a joint origin in m and rad")
        entries[key] = v
    return entries, text


def read_ur_kinematics_yaml(chain: Chain, path: str | Path, angle_unit: float = 1.0) -> list[pin.SE3]:
    """The corrections of ``chain`` that a ``default_kinematics.yaml`` holds.

    The inverse of :func:`write_ur_kinematics_yaml`.

    Each key's origin gives the joint placement P_i = G_{i-1} O_i G_i^-1 (the link frames
    G_i of :func:`ur_kinematics`); wrist_3's screw about axis 6 stays in P_6 (it commutes
    with joint 6), and a calib-pin header's tool0 line (the part the layout cannot hold)
    becomes the end frame's correction. A controller's own file has no such line: tool0
    is ur_description's.

    Args:
        chain: The nominal chain of a UR arm.
        path: The ``default_kinematics.yaml`` file.
        angle_unit: Radians per unit of the file's roll, pitch, yaw (1: radians, the layout's).

    Returns:
        ``n_joints + 1`` transforms right-multiplied onto the chain's joint placements and
        end frame (:meth:`calib_pin.robot.chain.Chain.perturbed_model`).

    Raises:
        DataError: not the layout (naming the missing key or bad value).
        RobotError: the chain is not a UR arm.
    """
    entries, text = read_ur_entries(path)
    origins = [pin.SE3(pin.rpy.rpyToMatrix(*(np.array(v[3:]) * angle_unit)), np.array(v[:3]))
               for v in entries.values()]
    ur_kinematics(chain, [pin.SE3.Identity()] * (chain.n_joints + 1))  # a UR arm, or RobotError
    links = _ur_link_frames(chain)
    data = chain.model.createData()
    pin.forwardKinematics(chain.model, data, chain.configuration(np.zeros(6)))
    g = [data.oMi[i + 1].actInv(link) for i, link in enumerate(links)]
    deltas, previous = [], UR_BASE_INERTIA
    for i, origin in enumerate(origins):
        placement = previous * origin * g[i].inverse()
        deltas.append(chain.model.jointPlacements[i + 1].actInv(placement))
        previous = g[i]
    rest = pin.SE3.Identity()
    found = _REST.search(text)
    if found:
        values = [float(v) for v in found.groups()]
        rest = pin.SE3(pin.rpy.rpyToMatrix(*np.deg2rad(values[3:])), np.array(values[:3]) * 1e-3)
    end = chain.model.frames[chain.frame_id].placement
    deltas.append(end.actInv(g[5] * UR_WRIST3_TOOL0 * rest))
    return deltas

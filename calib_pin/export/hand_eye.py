"""A hand-eye calibration as a ROS-style YAML file, the layout easy_handeye reads.

``parameters`` and ``transformation`` are easy_handeye's (its ``HandeyeCalibration.from_dict``
reads the file): the camera's placement, ``x, y, z`` [m] and the unit quaternion ``qx, qy,
qz, qw``, in the robot's effector frame (eye in hand) or base frame (eye to hand), with
``p_parent = R p_child + t``. Beside them: ``camera_mount``, ``parent_frame`` and
``child_frame`` of that transform, and ``board``, the board's placement in the other frame
(the base, eye in hand; the effector, eye to hand). ``notes`` (the gauge the placements
share with the robot) are comments at the top.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass(frozen=True)
class HandEye:
    """A camera set-up's calibrated placements and the frames they join.

    Attributes:
        eye_in_hand: The camera on the robot's effector (True), or fixed in the cell.
        camera: The camera's placement in ``effector`` (eye in hand) or ``base`` (pin.SE3, [m]).
        board: The board's placement in ``base`` (eye in hand) or ``effector`` (pin.SE3, [m]).
        base, effector: The robot's base and effector frames (URDF links).
        camera_frame, board_frame: The camera's and the board's frames (the calibrated URDF's links).
    """

    eye_in_hand: bool
    camera: pin.SE3
    board: pin.SE3
    base: str
    effector: str
    camera_frame: str
    board_frame: str


def transformation(placement: pin.SE3) -> dict[str, float]:
    """``{x, y, z, qx, qy, qz, qw}`` of a placement: [m] and its unit quaternion, qw >= 0."""
    q = pin.Quaternion(placement.rotation).normalized()
    sign = -1.0 if q.w < 0 else 1.0
    x, y, z = (float(v) for v in placement.translation)
    return {"x": x, "y": y, "z": z, "qx": sign * q.x, "qy": sign * q.y, "qz": sign * q.z, "qw": sign * q.w}


def placement_of(doc: dict[str, float]) -> pin.SE3:
    """Inverse of :func:`transformation`."""
    q = pin.Quaternion(float(doc["qw"]), float(doc["qx"]), float(doc["qy"]), float(doc["qz"])).normalized()
    return pin.SE3(q.matrix(), np.array([doc["x"], doc["y"], doc["z"]], dtype=float))


def hand_eye_text(he: HandEye, namespace: str, notes: Sequence[str] = ()) -> str:
    """The YAML text of ``he`` (module docstring); ``namespace``: easy_handeye's name of the calibration."""
    import yaml  # PyYAML: imported when a YAML is written

    mount = "eye-in-hand" if he.eye_in_hand else "eye-to-hand"
    parent = he.effector if he.eye_in_hand else he.base
    board_parent = he.base if he.eye_in_hand else he.effector
    body = {
        "camera_mount": mount,
        "parent_frame": parent,
        "child_frame": he.camera_frame,
        "parameters": {"namespace": namespace, "move_group_namespace": "/", "move_group": "manipulator",
                       "eye_on_hand": he.eye_in_hand, "robot_base_frame": he.base,
                       "robot_effector_frame": he.effector, "tracking_base_frame": he.camera_frame,
                       "tracking_marker_frame": he.board_frame},
        "transformation": transformation(he.camera),
        "board": {"parent_frame": board_parent, "child_frame": he.board_frame,
                  "transformation": transformation(he.board)},
    }
    head = ["calib-pin hand-eye calibration: the camera's placement (transformation: x, y, z in m; rotation as a unit "
            "quaternion qx, qy, qz, qw) in parent_frame, p_parent = R p_child + t; board: the board's, likewise",
            *notes]
    comments = "".join(f"# {line}\n" for note in head for line in note.splitlines())
    return comments + yaml.safe_dump(body, sort_keys=False, default_flow_style=False)


__all__ = ["HandEye", "hand_eye_text", "placement_of", "transformation"]

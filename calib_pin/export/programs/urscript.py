"""Universal Robots URScript: a function of ``movej([...], a=, v=)`` calls, in radians.

``def <name>():`` then one ``movej([q1, ..., q6], a=A, v=V)`` per target in order (joint
positions [rad], a [rad/s^2], v [rad/s]; UR's own defaults 1.4 and 1.05 unless given),
``end``. Comments start with ``#``.

Syntax relied on (Universal Robots, The URScript Programming Language, "Connecting to
URControl" and module motion ``movej(q, a=1.4, v=1.05, t=0, r=0)``): a script sent to the
controller must start with a function definition (``def``) in the first column, every other
line indented by at least one space, the last line ``end`` in the first column, in
(extended) ASCII; so the file's comments are inside the function, indented. Run it by
sending the file to the controller's script port, or load it in a PolyScope Script node
and call ``<name>()``.

Joint convention (:data:`CONVENTIONS`): the UR arms of example-robot-data
(ur_description's ``ur5_robot.urdf`` ...) use the controller's joint values: zero with the
arm stretched horizontally, the same signs; the ur_description kinematics files
(``default_kinematics.yaml``, read and written by calib-pin) are defined on those joint
values. Another robot is written in its URDF's convention, and the file says so.
"""

from __future__ import annotations

import numpy as np

from .base import (
    Convention,
    Program,
    comment_lines,
    convention_of,
    note,
    refuse_collisions,
    same_convention,
    six_axes,
)

#: UR's default joint acceleration [rad/s^2] and speed [rad/s] of movej.
DEFAULT_ACCEL_RAD_S2, DEFAULT_SPEED_RAD_S = 1.4, 1.05
_UR = same_convention(6, "UR joint values = URDF joint angles (same zero and signs)")
#: Robot name -> the controller's joint convention against the URDF's.
CONVENTIONS: dict[str, Convention] = {name: _UR for name in ("ur3", "ur5", "ur10", "ur3e", "ur5e", "ur10e", "ur16e")}


def convention(robot: str) -> Convention:
    """The UR convention of ``robot`` (the URDF's, said so, when none is known)."""
    return convention_of(CONVENTIONS, robot, "UR")


#: URScript's built-in functions a program's name must not take (a ``def`` of one hides it:
#: ``def movej():`` would call itself): the motion and common ones of the script manual.
BUILT_INS = ("movej", "movel", "movep", "movec", "servoj", "servoc", "speedj", "speedl", "stopj", "stopl",
             "sleep", "sync", "textmsg", "popup", "halt", "get_actual_joint_positions", "get_actual_tcp_pose",
             "get_inverse_kin", "get_forward_kin", "set_tcp", "set_payload", "set_digital_out", "socket_open",
             "socket_send_string", "force_mode", "end_force_mode", "freedrive_mode", "end_freedrive_mode")


def check(name: str, poses: np.ndarray) -> None:
    """Refuse a function name that is a built-in it calls or hides (:data:`BUILT_INS`)."""
    refuse_collisions("URScript", {name: "function"},
                      {b: f"the built-in function {'it calls' if b == 'movej' else 'it would hide'}" for b in BUILT_INS},
                      case=True)


def write(program: Program) -> dict[str, str]:
    """The URScript of ``program``: {".script": text}."""
    check(program.name, program.pose_ids)
    six_axes(program, "URScript")
    conv = convention(program.robot)
    q = np.deg2rad(conv.to_controller_deg(program.q))  # the controller's joint values [rad]
    accel = float(program.options.get("accel_rad_s2", DEFAULT_ACCEL_RAD_S2))
    speed = float(program.options.get("speed_rad_s", DEFAULT_SPEED_RAD_S))
    lines = [f"def {program.name}():"]  # the first line, in the first column (see the module's docstring)
    lines += comment_lines((*program.header, f"joint convention: {conv.note}",
                            "joint positions [rad], a [rad/s^2], v [rad/s]"), "#", "  ")
    for k, (pose, row) in enumerate(zip(program.pose_ids, q, strict=True)):
        lines += comment_lines((f"pose {int(pose)}" + (f": {note(program, k)}" if note(program, k) else ""),), "#", "  ")
        lines.append(f"  movej([{', '.join(f'{v:.12f}' for v in row)}], a={accel:g}, v={speed:g})")
    lines.append("end")
    return {".script": "\n".join(lines) + "\n"}

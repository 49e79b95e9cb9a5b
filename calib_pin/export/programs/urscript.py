"""Universal Robots URScript: a function of ``movej([...], a=, v=)`` calls, in radians.

``def <name>():`` then one ``movej([q1, ..., q6], a=A, v=V)`` per target in order (joint
positions [rad], a [rad/s^2], v [rad/s]; UR's own defaults 1.4 and 1.05 unless given),
``end``. Comments start with ``#``.

Joint convention (:data:`CONVENTIONS`): the UR arms of example-robot-data
(ur_description's ``ur5_robot.urdf`` ...) use the controller's joint values: zero with the
arm stretched horizontally, the same signs; the ur_description kinematics files
(``default_kinematics.yaml``, read and written by calib-pin) are defined on those joint
values. Another robot is written in its URDF's convention, and the file says so.
"""

from __future__ import annotations

import numpy as np

from . import Convention, Program, note, same_convention, six_axes

#: UR's default joint acceleration [rad/s^2] and speed [rad/s] of movej.
DEFAULT_ACCEL_RAD_S2, DEFAULT_SPEED_RAD_S = 1.4, 1.05
_UR = same_convention(6, "UR joint values = URDF joint angles (same zero and signs)")
#: Robot name -> the controller's joint convention against the URDF's.
CONVENTIONS: dict[str, Convention] = {name: _UR for name in ("ur3", "ur5", "ur10", "ur3e", "ur5e", "ur10e", "ur16e")}


def convention(robot: str) -> Convention:
    """The UR convention of ``robot`` (the URDF's, said so, when none is known)."""
    return CONVENTIONS.get(robot, same_convention(6, f"URDF joint angles of '{robot}' as they are: "
                                                     "no UR convention known for it, check signs and zeros"))


def write(program: Program) -> dict[str, str]:
    """The URScript of ``program``: {".script": text}."""
    six_axes(program, "URScript")
    conv = convention(program.robot)
    q = np.deg2rad(conv.to_controller_deg(program.q))  # the controller's joint values [rad]
    accel = float(program.options.get("accel_rad_s2", DEFAULT_ACCEL_RAD_S2))
    speed = float(program.options.get("speed_rad_s", DEFAULT_SPEED_RAD_S))
    lines = [f"# {line}" for line in (*program.header, f"joint convention: {conv.note}",
                                      "joint positions [rad], a [rad/s^2], v [rad/s]")]
    lines.append(f"def {program.name}():")
    for k, (pose, row) in enumerate(zip(program.pose_ids, q, strict=True)):
        comment = f"  # pose {int(pose)}" + (f": {note(program, k)}" if note(program, k) else "")
        lines += [comment, f"  movej([{', '.join(f'{v:.12f}' for v in row)}], a={accel:g}, v={speed:g})"]
    lines.append("end")
    return {".script": "\n".join(lines) + "\n"}

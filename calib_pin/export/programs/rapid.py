"""ABB RAPID: a module of ``CONST jointtarget`` declarations and a ``MoveAbsJ`` routine.

Each target is ``CONST jointtarget jt_<pose>:=[[rax_1,...,rax_6],[9E9,...]];`` in degrees
(the six external axes unused: 9E9), and the routine ``PROC <name>_run()`` visits them in
order with ``MoveAbsJ jt_<pose>\\NoEOffs, v100, fine, tool0;``. Comments start with ``!``.
Values are written with 9 decimals; the controller stores a ``num`` in single precision
(about 7 significant digits, 1e-5 deg at 100 deg).

Syntax relied on (ABB, Technical reference manual - RAPID Instructions, Functions and Data
types, ``jointtarget`` and ``MoveAbsJ``; Technical reference manual - RAPID kernel): a
jointtarget's ``robax`` holds the six axes in degrees from the calibration position and its
``extax`` 9E9 for an axis that is not connected (e.g. ``CONST jointtarget jpos40 := [[0, 0,
0, 0, 0, 0], [0, 9E9, 9E9, 9E9, 9E9, 9E9]];``); ``MoveAbsJ ToJointPos [\\NoEOffs], Speed,
Zone, Tool``; identifiers are letters, digits and ``_`` starting with a letter, at most 32
characters, no reserved word (names here: at most 24 + ``_run``; a pose ``-3`` is
``jt_m3``); the character set is ISO 8859-1 (comments here are ASCII, wrapped to 78
characters).

Joint convention (:data:`CONVENTIONS`): for the IRB120 of calib-pin (robots/irb120.urdf,
ROS-Industrial abb_irb120_support's frames) the controller's axis values are the URDF
joint angles: the same zero (upper arm upright, forearm horizontal: ABB's calibration
position) and the same signs (joint_3's asymmetric range -110..+70 deg is axis 3's range in
ABB's product specification). Another robot is written in its URDF's convention, and the
file says so.
"""

from __future__ import annotations

import numpy as np

from .base import (
    Convention,
    Program,
    comment_lines,
    convention_of,
    note,
    point_name,
    refuse_collisions,
    same_convention,
    six_axes,
)

#: Robot name -> the controller's joint convention against the URDF's.
CONVENTIONS: dict[str, Convention] = {
    "irb120": same_convention(6, "ABB axis values = URDF joint angles (same zero and signs)"),
}
#: MoveAbsJ's speed data, zone data and tool.
SPEED, ZONE, TOOL = "v100", "fine", "tool0"
#: Unused external axes.
UNUSED = "9E9"


def convention(robot: str) -> Convention:
    """The ABB convention of ``robot`` (the URDF's, said so, when none is known)."""
    return convention_of(CONVENTIONS, robot, "ABB")


#: RAPID's predefined data and instructions a module or routine name must not take: those
#: the module uses (its speed, zone and tool; MoveAbsJ) and the other system data a module
#: most often meets (wobj0, load0).
PREDEFINED = {SPEED: "the predefined speed data it moves at", ZONE: "the predefined zone data it stops with",
              TOOL: "the predefined tool it moves", "wobj0": "the predefined work object",
              "load0": "the predefined load", "MoveAbsJ": "the instruction it calls"}


def check(name: str, poses: np.ndarray) -> None:
    """Refuse a module (or its routine ``<name>_run``) named like a joint target it defines
    (``jt_1``) or a predefined name it uses (``tool0``), without case as RAPID compares."""
    targets = {point_name("jt_", pose): "a joint target it defines" for pose in np.asarray(poses).reshape(-1)}
    refuse_collisions("RAPID", {name: "module", f"{name}_run": "routine"}, {**targets, **PREDEFINED}, case=False)


def write(program: Program) -> dict[str, str]:
    """The RAPID module of ``program``: {".mod": text}."""
    check(program.name, program.pose_ids)
    six_axes(program, "RAPID")
    conv = convention(program.robot)
    values = conv.to_controller_deg(program.q)
    lines = [f"MODULE {program.name}"]
    lines += comment_lines((*program.header, f"joint convention: {conv.note}",
                            "axis values in degrees; external axes unused (9E9)"), "!", "    ")
    for k, (pose, row) in enumerate(zip(program.pose_ids, values, strict=True)):
        if note(program, k):
            lines += comment_lines((f"pose {int(pose)}: {note(program, k)}",), "!", "    ")
        axes = ",".join(f"{v:.9f}" for v in row)
        lines.append(f"    CONST jointtarget {point_name('jt_', pose)}:=[[{axes}],[{','.join([UNUSED] * 6)}]];")
    lines.append(f"    PROC {program.name}_run()")
    lines += [f"        MoveAbsJ {point_name('jt_', pose)}\\NoEOffs, {SPEED}, {ZONE}, {TOOL};" for pose in program.pose_ids]
    lines += ["    ENDPROC", "ENDMODULE"]
    return {".mod": "\n".join(lines) + "\n"}

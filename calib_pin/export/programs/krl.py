"""KUKA KRL: a ``.src``/``.dat`` pair, ``E6AXIS`` points in the ``.dat``, PTP moves in the ``.src``.

``<name>.dat``: ``DEFDAT <name> PUBLIC`` with ``DECL E6AXIS XP<pose>={A1 ..,A6 ..,E1 0.0,...,E6 0.0}``
in degrees; ``<name>.src``: ``DEF <name>( )``, the BAS initialisation, then ``PTP XP<pose>``
in order. Comments start with ``;``. KRL names the program after its files: ``<name>`` is
the ``--out`` file's stem (a KRL name: a letter, then letters, digits or ``_``, at most 24).

Syntax relied on (KUKA System Software 8, Operating and Programming Instructions for System
Integrators, "Names", "DEF ... END", "DECL", "PTP", E6AXIS; the same layout as the .src/.dat
pairs KUKA's own WorkVisual and offline tools write): names of at most 24 characters, not
a keyword, the program's DEF and DEFDAT named as its files; an E6AXIS point as ``{A1 ..,
..., A6 .., E1 .., ..., E6 ..}`` in degrees (E1..E6 0.0: no external axes); the first PTP
of the program is the BCO run, to a fully given axis point, after ``BAS (#INITMOV,0 )`` set
the default velocities and accelerations (BAS.SRC of the KSS). A pose ``-3`` is ``XPm3``.
Nothing here reads $CONFIG.DAT: no tool, base or global point is assumed.

Joint convention (:data:`CONVENTIONS`): KUKA's axis values differ from many URDFs (A1
positive clockwise seen from above, A2 = -90 deg with the upper arm upright). No KUKA arm
ships with calib-pin, so no convention is known: a robot is written in its URDF's
convention, and the file says so; add a :class:`~calib_pin.export.programs.Convention`
here for a KUKA URDF whose joints differ from the controller's.
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
    six_axes,
)

#: Robot name -> the controller's joint convention against the URDF's.
CONVENTIONS: dict[str, Convention] = {}


def convention(robot: str) -> Convention:
    """The KUKA convention of ``robot`` (the URDF's, said so, when none is known)."""
    return convention_of(CONVENTIONS, robot, "KUKA")


#: The subprogram the .src calls (the KSS's BAS.SRC), a name the program must not take.
CALLED = {"BAS": "the system subprogram it calls"}


def check(name: str, poses: np.ndarray) -> None:
    """Refuse a program (its DEF and DEFDAT) named like a point it declares (``XP1``) or
    the subprogram it calls (``BAS``), without case as KRL compares."""
    points = {point_name("XP", pose): "a point it declares" for pose in np.asarray(poses).reshape(-1)}
    refuse_collisions("KRL", {name: "program"}, {**points, **CALLED}, case=False)


def write(program: Program) -> dict[str, str]:
    """The KRL pair of ``program``: {".src": text, ".dat": text}."""
    check(program.name, program.pose_ids)
    six_axes(program, "KRL")
    conv = convention(program.robot)
    values = conv.to_controller_deg(program.q)
    comments = comment_lines((*program.header, f"joint convention: {conv.note}", "A1..A6 in degrees"), ";")
    src = ["&ACCESS RVP", "&REL 1", f"DEF {program.name}( )", *comments, ";FOLD INI",
           "  BAS (#INITMOV,0 )", ";ENDFOLD (INI)"]
    src += [f"  PTP {point_name('XP', pose)}" for pose in program.pose_ids]
    src.append("END")
    dat = ["&ACCESS RVP", "&REL 1", f"DEFDAT {program.name} PUBLIC", *comments]
    for k, (pose, row) in enumerate(zip(program.pose_ids, values, strict=True)):
        if note(program, k):
            dat += comment_lines((f"pose {int(pose)}: {note(program, k)}",), ";")
        axes = ",".join(f"A{i + 1} {v:.9f}" for i, v in enumerate(row))
        dat.append(f"DECL E6AXIS {point_name('XP', pose)}={{{axes},E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}")
    dat.append("ENDDAT")
    return {".src": "\n".join(src) + "\n", ".dat": "\n".join(dat) + "\n"}

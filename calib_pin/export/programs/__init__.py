"""Compensated joint targets as a program in a robot controller's language.

A writer turns a :class:`Program` (joint commands in the URDF's convention, [rad]) into the
files of one format: ``rapid`` (ABB RAPID module, :mod:`.rapid`), ``krl`` (KUKA KRL
``.src``/``.dat`` pair, :mod:`.krl`), ``urscript`` (Universal Robots, :mod:`.urscript`).
``csv`` stays calib-pin's own pose list (:func:`calib_pin.measurements.csv_writer.write_compensated`,
written by ``calib-pin compensate`` itself). Each vendor module holds that controller's
joint convention (:class:`Convention`): the sign and zero of each controller axis against
the URDF joint, applied on writing.

Registry: :data:`PROGRAMS` (format name -> :class:`ProgramFormat`); :func:`program_files`
gives the files of a format as ``{path: text}``, for the atomic output writer.
"""

from __future__ import annotations

from pathlib import Path

from ...exceptions import CalibPinError
from . import krl, rapid, urscript
from .base import (
    COMMENT_WIDTH,
    RESERVED,
    Convention,
    Program,
    ProgramFormat,
    comment_lines,
    identifier,
    note,
    point_name,
    refuse_collisions,
    same_convention,
    six_axes,
)


def _registry() -> dict[str, ProgramFormat]:
    return {
        "rapid": ProgramFormat((".mod",), rapid.write, "ABB RAPID module: CONST jointtarget + MoveAbsJ routine",
                               rapid.check),
        "krl": ProgramFormat((".src", ".dat"), krl.write, "KUKA KRL .src/.dat pair: E6AXIS points + PTP", krl.check),
        "urscript": ProgramFormat((".script",), urscript.write, "URScript function of movej([...], a=, v=)",
                                  urscript.check),
    }


#: Format name -> its writer (``csv`` is the compensate command's own).
PROGRAMS: dict[str, ProgramFormat] = _registry()
#: Every format ``calib-pin compensate --format`` takes.
FORMATS = ("csv", *PROGRAMS)


def program_paths(fmt: str, out: Path) -> list[Path]:
    """The files format ``fmt`` writes for ``--out out``: ``out`` itself and its companions.

    ``out`` with its suffix (added when missing), and the companions (KRL's ``.dat`` beside
    the ``.src``).

    Args:
        fmt: The program format's name.
        out: The ``--out`` path.

    Raises:
        CalibPinError: ``out`` has another format's suffix.
    """
    suffixes = PROGRAMS[fmt].suffixes
    if out.suffix.lower() not in ("", *suffixes):
        raise CalibPinError(f"--out {out}: a {fmt} program is {' + '.join(suffixes)}, not '{out.suffix}'")
    stem = out.with_suffix("") if out.suffix else out
    return [stem.with_name(stem.name + s) for s in suffixes]


def program_files(fmt: str, program: Program, out: Path) -> dict[Path, str]:
    """The files of ``program`` in format ``fmt`` for ``--out out``: path -> text."""
    texts = PROGRAMS[fmt].write(program)
    return dict(zip(program_paths(fmt, out), (texts[s] for s in PROGRAMS[fmt].suffixes), strict=True))


__all__ = ["COMMENT_WIDTH", "FORMATS", "PROGRAMS", "RESERVED", "Convention", "Program", "ProgramFormat", "comment_lines",
           "identifier", "note", "point_name", "program_files", "program_paths", "refuse_collisions", "same_convention",
           "six_axes"]

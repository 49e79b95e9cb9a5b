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

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...exceptions import CalibPinError


@dataclass(frozen=True)
class Convention:
    """A controller's joint convention against the URDF's: controller = sign * urdf + zero.

    Attributes:
        sign: Per joint +1 or -1, shape (n_joints,).
        zero_deg: Per joint the controller's reading at the URDF's zero, [deg].
        note: Where the convention comes from (for the file's header).
    """

    sign: tuple[float, ...]
    zero_deg: tuple[float, ...]
    note: str

    def to_controller_deg(self, q_rad: np.ndarray) -> np.ndarray:
        """URDF joint angles (n, n_joints) [rad] as controller axis values [deg]."""
        return np.rad2deg(q_rad) * np.asarray(self.sign) + np.asarray(self.zero_deg)

    def to_urdf_rad(self, controller_deg: np.ndarray) -> np.ndarray:
        """Controller axis values (n, n_joints) [deg] as URDF joint angles [rad]."""
        return np.deg2rad((np.asarray(controller_deg) - np.asarray(self.zero_deg)) * np.asarray(self.sign))


def same_convention(n_joints: int, note: str) -> Convention:
    """The controller reads the URDF's joint angles as they are (sign +1, zero 0)."""
    return Convention((1.0,) * n_joints, (0.0,) * n_joints, note)


@dataclass(frozen=True)
class Program:
    """Joint commands to write, in order.

    Attributes:
        name: The program's (module's, routine's) name, a valid identifier.
        q: Joint commands, shape (n_targets, n_joints), [rad], URDF convention.
        pose_ids: The targets' pose numbers, shape (n_targets,).
        robot: The robot's name; joint_names its joints (URDF).
        header: Comment lines for the file (what made it, the targets left out), without
            comment marks.
        notes: Per target a comment ("" for none), e.g. a position-only target's residual.
        options: Format options: ``speed_rad_s`` and ``accel_rad_s2`` (URScript movej
            ``v=``, ``a=``).
    """

    name: str
    q: np.ndarray
    pose_ids: np.ndarray
    robot: str
    joint_names: tuple[str, ...]
    header: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    options: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class ProgramFormat:
    """One controller language: file suffixes and the writer.

    Attributes:
        suffixes: The files it writes, by suffix (``.mod``; ``.src`` and ``.dat``).
        write: Program -> {suffix: text}.
        description: For help texts.
    """

    suffixes: tuple[str, ...]
    write: Callable[[Program], dict[str, str]]
    description: str


def identifier(text: str, first: str = "p") -> str:
    """``text`` as a controller identifier: letters, digits, ``_``; starts with a letter;
    at most 24 characters (KRL's limit; RAPID allows 32)."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", text)
    if not name or not name[0].isalpha():
        name = first + name
    return name[:24]


def six_axes(program: Program, language: str) -> None:
    """Refuse a program that is not of a six-axis arm (the language's joint target holds six)."""
    if program.q.shape[1] != 6:
        raise CalibPinError(f"a {language} joint target holds 6 robot axes; robot '{program.robot}' has "
                            f"{program.q.shape[1]} joints")


def note(program: Program, k: int) -> str:
    """Target k's comment ("" for none)."""
    return program.notes[k] if k < len(program.notes) else ""


def _registry() -> dict[str, ProgramFormat]:
    from . import krl, rapid, urscript

    return {
        "rapid": ProgramFormat((".mod",), rapid.write, "ABB RAPID module: CONST jointtarget + MoveAbsJ routine"),
        "krl": ProgramFormat((".src", ".dat"), krl.write, "KUKA KRL .src/.dat pair: E6AXIS points + PTP"),
        "urscript": ProgramFormat((".script",), urscript.write, "URScript function of movej([...], a=, v=)"),
    }


#: Format name -> its writer (``csv`` is the compensate command's own).
PROGRAMS: dict[str, ProgramFormat] = _registry()
#: Every format ``calib-pin compensate --format`` takes.
FORMATS = ("csv", *PROGRAMS)


def program_paths(fmt: str, out: Path) -> list[Path]:
    """The files format ``fmt`` writes for ``--out out``: ``out`` itself with its suffix
    (added when missing), and the companions (KRL's ``.dat`` beside the ``.src``).

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


__all__ = ["FORMATS", "PROGRAMS", "Convention", "Program", "ProgramFormat", "identifier", "note", "program_files",
           "program_paths", "same_convention", "six_axes"]

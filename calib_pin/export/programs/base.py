"""What every controller program writer shares: the joint convention, the program, names and comments."""


from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field

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


def convention_of(conventions: dict[str, Convention], robot: str, vendor: str) -> Convention:
    """``vendor``'s convention of ``robot`` from ``conventions``; else the URDF's, said so."""
    return conventions.get(robot, same_convention(6, f"URDF joint angles of '{robot}' as they are: "
                                                     f"no {vendor} convention known for it, check signs and zeros"))


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
    """One controller language: file suffixes, the writer, and the check of its names.

    Attributes:
        suffixes: The files it writes, by suffix (``.mod``; ``.src`` and ``.dat``).
        write: Program -> {suffix: text}.
        description: For help texts.
        check: (program name, pose numbers) -> None; refuses a program name that collides
            with a name the program defines or calls (:func:`refuse_collisions`).
    """

    suffixes: tuple[str, ...]
    write: Callable[[Program], dict[str, str]]
    description: str
    check: Callable[[str, np.ndarray], None] = lambda name, poses: None


def refuse_collisions(language: str, names: dict[str, str], others: dict[str, str], case: bool) -> None:
    """Refuse a program whose own names (``names``: its module's, routine's; name -> what it
    is) are also names it defines or calls (``others``: name -> what it is to the program:
    ``the joint target it defines``, ``the built-in function it calls``), compared with
    case when ``case`` (URScript), without (RAPID, KRL): such a program would call itself,
    or a target or tool of its would be the module.

    Raises:
        CalibPinError: naming both, and how to avoid it (another --out file name).
    """
    def fold(text: str) -> str:
        return text if case else text.lower()

    theirs = {fold(name): (name, what) for name, what in others.items()}
    for name, what in names.items():
        clash = theirs.get(fold(name))
        if clash is not None:
            raise CalibPinError(f"a {language} {what} named '{name}' collides with {clash[1]}, '{clash[0]}': "
                                "name the program otherwise (another --out file name)")


#: Words the three languages reserve (compared without case; RAPID and KRL ignore case), that
#: a program or routine name must not be: RAPID's (Technical reference manual - RAPID kernel,
#: "Reserved words"), KRL's (KUKA System Software 8, "Keywords") and URScript's (script
#: manual, "Flow of control", "Function"), the ones a file stem could plausibly be.
RESERVED = frozenset((
    "alias", "and", "backward", "case", "connect", "const", "default", "div", "do", "else", "elseif",
    "endfor", "endfunc", "endif", "endmodule", "endproc", "endrecord", "endtest", "endtrap", "endwhile",
    "error", "exit", "false", "for", "from", "func", "goto", "if", "inout", "local", "mod", "module",
    "noview", "not", "or", "pers", "proc", "raise", "readonly", "record", "retry", "return", "step",
    "sysmodule", "test", "then", "to", "trap", "true", "trynext", "undo", "var", "viewonly", "while", "with",
    "xor", "def", "deffct", "defdat", "end", "enddat", "endfct", "endloop", "endswitch", "loop", "ptp",
    "lin", "circ", "switch", "repeat", "until", "wait", "halt", "decl", "global", "public", "int", "real",
    "bool", "char", "frame", "pos", "axis", "e6pos", "e6axis", "signal", "struc", "enum", "sec", "thread",
    "run", "kill", "elif", "pass", "break", "continue",
))


def identifier(text: str, first: str = "p") -> str:
    """``text`` as a controller identifier: ASCII letters, digits, ``_``, starting with a letter.

    At most 24 characters (KRL's limit for names, KUKA System Software 8 "Names"; RAPID
    allows 32, Technical reference manual - RAPID kernel "Identifiers"); never a reserved
    word of RAPID, KRL or URScript (:data:`RESERVED`: ``module`` becomes ``p_module``).
    """
    name = re.sub(r"[^A-Za-z0-9_]", "_", text)
    if not name or not name[0].isascii() or not name[0].isalpha():
        name = first + name
    if name.lower() in RESERVED:
        name = f"{first}_{name}"
    return name[:24]


def point_name(prefix: str, pose: int) -> str:
    """The name of pose ``pose``'s joint target: ``prefix`` and the pose number.

    A minus sign is written ``m`` (``jt_3``, ``XPm3``): ``jt_-3`` is no identifier in any
    language.
    """
    pose = int(pose)
    return f"{prefix}{'m' if pose < 0 else ''}{abs(pose)}"


#: Longest comment line written, [characters]: the pendants' editors show about 80 (and
#: a refused target's reason, or a long file name, must not make a line of hundreds).
COMMENT_WIDTH = 78


def comment_lines(lines: tuple[str, ...] | list[str], mark: str, indent: str = "") -> list[str]:
    """``lines`` as comments: ``indent + mark + " "`` before each, wrapped, in ASCII.

    Wrapped to :data:`COMMENT_WIDTH`; another character becomes ``?`` (RAPID files are
    ISO 8859-1, URScript "extended ASCII", KRL's editor ANSI).
    """
    import textwrap

    out = []
    lead = f"{indent}{mark} "
    for line in lines:
        text = line.encode("ascii", "replace").decode("ascii")
        out += [lead + part for part in textwrap.wrap(text, COMMENT_WIDTH - len(lead), break_on_hyphens=False,
                                                      break_long_words=True) or [""]]
    return out


def six_axes(program: Program, language: str) -> None:
    """Refuse a program that is not of a six-axis arm (the language's joint target holds six)."""
    if program.q.shape[1] != 6:
        raise CalibPinError(f"a {language} joint target holds 6 robot axes; robot '{program.robot}' has "
                            f"{program.q.shape[1]} joints")


def note(program: Program, k: int) -> str:
    """Target k's comment ("" for none)."""
    return program.notes[k] if k < len(program.notes) else ""

"""What every command shares: one-line errors, argument types, the exit codes.

Exit status: 0 done; 2 bad input, one line on stderr naming the file, line or field
(never a traceback for a user's mistake); 3 a sensor fault (collect); 130 stopped by
Ctrl-C, with one line.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

from ..arguments import as_names
from ..exceptions import ArgumentError, CalibPinError
from ..sensors.setup import estimate_names, finite, xyz_mm  # noqa: F401 (the sensors' flag parsers)

BAD_INPUT_EXIT = 2
SENSOR_FAULT_EXIT = 3
INTERRUPTED_EXIT = 130


#: A value that is a negative number or starts a list of numbers (``-2.2,0,50``, ``-1e-3``):
#: argparse would take it for an option.
_NEGATIVE_VALUE = re.compile(r"^-\.?\d[\d.eE+\-,;\s]*$")
#: Actions that collect repeated options (a list) rather than replace the first.
_LIST_ACTIONS = (argparse._AppendAction, argparse._AppendConstAction, argparse._CountAction, argparse._ExtendAction)


def one_line(text: str) -> str:
    """``text`` with every control character escaped as ``repr`` does (``\\n``, ``\\x1b``):
    a file name or a field may hold them, and an error message stays one line."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


class OneLineParser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit 2, for every command.

    On top of argparse: an option is spelled out in full (no prefix abbreviations,
    ``allow_abbrev=False``); an option that holds one value may be given once (a second
    ``--data`` would silently replace the first); and a value that is a negative number
    or a list of numbers (``--tool-mm -2.2,0,50``) is the option's value, not an option.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        self.exit(BAD_INPUT_EXIT, f"{self.prog}: error: {one_line(message)} (see --help)\n")

    def parse_known_args(self, args: Sequence[str] | None = None,  # type: ignore[override]
                         namespace: argparse.Namespace | None = None) -> tuple[argparse.Namespace, list[str]]:
        argv = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(self._prepared(argv), namespace)

    def _prepared(self, argv: list[str]) -> list[str]:
        """``argv`` with ``--opt -2.2,0,50`` as ``--opt=-2.2,0,50``; refuses an option
        that holds one value given twice (in any spelling: ``--opt x``, ``--opt=x``)."""
        out: list[str] = []
        seen: dict[argparse.Action, str] = {}
        i = 0
        while i < len(argv):
            token = argv[i]
            if token == "--":
                out.extend(argv[i:])
                break
            name, eq, _ = token.partition("=")
            action = self._option_string_actions.get(name) if token.startswith("-") else None
            if action is None or action.nargs == 0 or action.nargs not in (None, 1):
                out.append(token)
                i += 1
                continue
            value = argv[i + 1] if not eq and i + 1 < len(argv) else None
            spelled = repr(token[:60] if eq or value is None else f"{name} {value[:40]}")
            if action in seen and not isinstance(action, _LIST_ACTIONS):  # a list option may repeat
                self.error(f"{name} given twice ({seen[action]} and {spelled}): give it once; a second "
                           "one would replace the first")
            seen[action] = spelled
            if value is not None and _NEGATIVE_VALUE.match(value):
                out.append(f"{name}={value}")
                i += 2
            elif value is not None and not value.startswith("-"):
                out += [token, value]
                i += 2
            else:
                out.append(token)
                i += 1
        return out


def fail(message: str) -> int:
    """Print one error line on stderr (control characters escaped); the bad-input exit status."""
    print(f"error: {one_line(message)}", file=sys.stderr)
    return BAD_INPUT_EXIT


#: run()'s Ctrl-C line when the command says nothing else.
NOTHING_WRITTEN = "stopped by Ctrl-C: nothing was written"


def run(action: Callable[[], int], interrupted: str = NOTHING_WRITTEN) -> int:
    """Run a command's work: a user's mistake becomes one line on stderr and exit 2,
    Ctrl-C one line and exit 130 (naming the outputs already written in full, if any)."""
    from ..export.outputs import WRITTEN

    mark = len(WRITTEN)
    try:
        return action()
    except CalibPinError as e:
        return fail(str(e))
    except KeyboardInterrupt:
        done = WRITTEN[mark:]
        if done and interrupted == NOTHING_WRITTEN:  # Ctrl-C after the commit (while printing the summary)
            names = ", ".join(str(p) for p in done[:3]) + (", ..." if len(done) > 3 else "")
            interrupted = f"stopped by Ctrl-C after the outputs were written in full ({len(done)} file(s): {names})"
        print(f"\n{one_line(interrupted)}", file=sys.stderr)
        return INTERRUPTED_EXIT
    except BrokenPipeError:
        return fail("standard output was closed (files already written are kept)")
    except MemoryError:
        return fail("not enough memory for this size: ask for fewer poses or candidates, or give a smaller file")
    except OSError as e:
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        return fail(f"{where}{e.strerror or e}")




def fraction(text: str) -> float:
    """A number in [0, 1)."""
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0.0 <= value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1), got '{text[:40]}'")
    return value + 0.0  # -0 is 0 (it printed as "test fraction -0")


def non_negative(kind: type, upper: float = 1e9) -> Callable[[str], Any]:
    """A non-negative ``kind`` (int or float) no larger than ``upper``."""
    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except (ValueError, OverflowError):
            value = -1
        if not value >= 0:
            raise argparse.ArgumentTypeError(f"expected a non-negative {kind.__name__}, got '{text[:40]}'")
        if value > upper:
            raise argparse.ArgumentTypeError(f"expected at most {upper:g}, got '{text[:40]}'")
        return value + 0  # '-0' is 0 (numpy's scale >= 0 checks refuse a negative zero)

    return parse


def positive_float(upper: float) -> Callable[[str], float]:
    """A number in (0, upper]."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = -1.0
        if not 0.0 < value <= upper:
            raise argparse.ArgumentTypeError(f"expected a number in (0, {upper:g}], got '{text[:40]}'")
        return value

    return parse




def count(upper: int) -> Callable[[str], int]:
    """A whole number in [1, upper]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            try:
                as_float = float(text)
                value = int(as_float) if as_float.is_integer() and abs(as_float) < 1e18 else 0
            except (ValueError, OverflowError):
                value = 0
        if not 1 <= value <= upper:
            raise argparse.ArgumentTypeError(f"expected a whole number from 1 to {upper}, got '{text[:40]}'")
        return value

    return parse


def methods(text: str) -> list[str]:
    """Comma-separated estimator names."""
    from ..estimators import ESTIMATORS

    names = [n.strip() for n in text.split(",")]
    if "" in names:
        raise argparse.ArgumentTypeError(f"empty method name in '{text}' (comma-separated, e.g. lm,ekf-qibas)")
    unknown = [n for n in names if n not in ESTIMATORS]
    if unknown:
        raise argparse.ArgumentTypeError(
            f"unknown method '{unknown[0]}' (valid: {', '.join(ESTIMATORS)})")
    return names




def joint_names(text: str) -> tuple[str, ...]:
    """Comma-separated joint names (or ``all``), each once."""
    try:
        names = as_names(text, "compliance")
    except ArgumentError as e:
        raise argparse.ArgumentTypeError(e.reason) from None
    if not names:
        raise argparse.ArgumentTypeError(f"expected joint names, comma-separated (joint_2,joint_3) or all, got '{text[:40]}'")
    return names


def add_robot_arguments(p: argparse.ArgumentParser, anchor_default: str, tool_default: str, *,
                        skip: Sequence[str] = (), defaults: dict[str, Any] | None = None,
                        anchor_per_session: bool = False) -> None:
    """The robot arguments shared by calibrate and simulate, and every registered sensor's
    set-up flags (:func:`calib_pin.sensors.add_sensor_arguments`; ``skip``: fields without
    a flag here, ``defaults``: flag defaults); ``anchor_default`` and ``tool_default`` say
    what the point flags default to (``anchor_per_session``: --anchor-mm may be given once
    per session, a list)."""
    from ..sensors import add_sensor_arguments

    p.add_argument("robot", help="robot name (irb120, or an example-robot-data name) or URDF path")
    p.add_argument("--end-frame", help="end frame (default: the data file's, else tool0)")
    p.add_argument("--seed", type=non_negative(int), default=0, help="seed, a whole number >= 0 (default 0)")
    add_sensor_arguments(p, {"anchor_mm": anchor_default, "tool_mm": tool_default}, skip, defaults,
                         append=("anchor_mm",) if anchor_per_session else ())


def add_compliance_arguments(p: argparse.ArgumentParser, what: str = "estimate") -> None:
    """Joint compliance and its loads (see :mod:`calib_pin.robot.deflection`)."""
    p.add_argument("--compliance", metavar="JOINTS", type=joint_names,
                   help=f"{what} the compliance [rad/Nm] of these joints under gravity (and payload, cable pull): "
                   "joint names comma-separated (joint_2,joint_3) or all (see --compliance-model)")
    p.add_argument("--payload-kg", type=non_negative(float, 1e4), help="payload mass carried by the end frame, kg")
    p.add_argument("--payload-com-mm", type=xyz_mm, help="payload centre of mass in the end frame, 'x,y,z' mm (default 0,0,0)")
    p.add_argument("--cable-tension-n", type=non_negative(float, 1e4), help="the drawstring's pull on the tool point, N")
    p.add_argument("--compliance-model", choices=("cad", "basis"),
                   help="cad: compliances on the URDF's inertias; basis: the gravity torque patterns of the "
                   "kinematics, no inertias needed (default: cad when the URDF has inertial data, else basis)")


def compliance_options(args: argparse.Namespace) -> dict[str, Any]:
    """The compliance arguments as one record, built once: ``{"compliance": Compliance
    or None}``, the keyword argument of ``prepare``/``calibrate``/``compare``/``simulate``.

    Raises:
        CalibPinError: a load (--payload-kg, --payload-com-mm, --cable-tension-n)
            without --compliance.
    """
    from ..robot.deflection import LOAD_FIELDS, Compliance

    loads = {k: getattr(args, k) for k in LOAD_FIELDS}
    model = getattr(args, "compliance_model", None)
    if args.compliance is None:
        given = [k for k, v in {**loads, "compliance_model": model}.items() if v is not None]
        if given:
            raise CalibPinError(f"--{given[0].replace('_', '-')} needs compliant joints "
                                "(--compliance joint_2,joint_3 or all)")
        return {"compliance": None}
    return {"compliance": Compliance(args.compliance, **loads, model=model)}

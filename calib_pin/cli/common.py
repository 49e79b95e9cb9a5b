"""What every command shares: one-line errors, argument types, exit codes, shared argument groups.

The argument groups several commands hold (:func:`add_robot_arguments`,
:func:`add_seed_argument`, :func:`add_compliance_arguments`, :func:`add_parallel_arguments`,
...): each option is defined once here and added to every ``calib-pin`` subcommand that
takes it, under the same group title, with the same help.

This module imports no numpy, scipy or Pinocchio (``calib-pin --help`` and the parser's
skeleton stay quick): a group that needs a registry (the parameter models, the sensors'
set-up records) imports it when it is added to a command's parser.

stdout carries a command's results (its tables, the files written); a warning or a note
about the inputs or the run is one line on stderr (:func:`warn`).

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

from ..exceptions import ArgumentError, CalibPinError

BAD_INPUT_EXIT = 2
SENSOR_FAULT_EXIT = 3
INTERRUPTED_EXIT = 130


#: A value that is a negative number or starts a list of numbers (``-2.2,0,50``, ``-1e-3``):
#: argparse would take it for an option.
_NEGATIVE_VALUE = re.compile(r"^-\.?\d[\d.eE+\-,;\s]*$")
#: Actions that collect repeated options (a list) rather than replace the first.
_LIST_ACTIONS = (argparse._AppendAction, argparse._AppendConstAction, argparse._CountAction, argparse._ExtendAction)


def one_line(text: str) -> str:
    """``text`` with every control character escaped as ``repr`` does (``\\n``, ``\\x1b``).

    A file name or a field may hold them, and an error message stays one line.
    """
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
        """``argv`` with ``--opt -2.2,0,50`` as ``--opt=-2.2,0,50``.

        Refuses an option that holds one value given twice (in any spelling: ``--opt x``,
        ``--opt=x``).
        """
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


#: The command line's flag of each library argument a command's error may name, where it is
#: not the argument's own name as a flag (``test_fraction``: ``--test-fraction``).
ARGUMENT_FLAGS = {"holdout": "--cv", "folds": "--cv", "parameters": "--model", "same": "--test-data: same",
                  "register": "--test-data: register"}
#: The library arguments a command gives by the flag of the same name.
SAME_NAMED = ("data", "test_data", "test_fraction", "method", "methods", "loss", "seed", "noise_mm", "noise_deg",
              "end_frame", "compliance", "fix", "free", "nominal", "trials", "poses")


def cli_message(error: CalibPinError) -> str:
    """A library error in the command line's words: an argument is named by its flag.

    An :class:`~calib_pin.exceptions.ArgumentError` of an argument a command gives by a flag
    says ``argument --flag: ...`` as argparse does; a refused sensor set-up field
    (``setup``: ``anchor_mm is for ...``) is named by its flag (``--anchor-mm is for ...``).
    Every other error keeps its message.
    """
    if not isinstance(error, ArgumentError):
        return str(error)
    from ..sensors import setup_fields
    from ..sensors.setup import flag_of

    if error.argument == "setup":
        field, _, rest = error.reason.partition(" ")
        return f"{flag_of(field)} {rest}" if field in setup_fields() else str(error)
    name = error.argument
    flag = ARGUMENT_FLAGS.get(name) or (flag_of(name) if name in SAME_NAMED or name in setup_fields() else None)
    return f"argument {flag}: {error.reason}" if flag else str(error)


def fail(message: str) -> int:
    """Print one error line on stderr (control characters escaped); the bad-input exit status."""
    print(f"error: {one_line(message)}", file=sys.stderr)
    return BAD_INPUT_EXIT


def warn(message: str, kind: str = "warning") -> None:
    """Print one ``warning: ...`` (or ``note: ...``) line on stderr, control characters
    escaped: stdout carries a command's results only, which scripts parse."""
    print(f"{kind}: {one_line(message)}", file=sys.stderr)


#: run()'s Ctrl-C line when the command says nothing else.
NOTHING_WRITTEN = "stopped by Ctrl-C: nothing was written"


def run(action: Callable[[], int], interrupted: str = NOTHING_WRITTEN) -> int:
    """Run a command's work: a user's mistake is one line and exit 2, Ctrl-C one line and 130.

    A user's mistake goes to stderr; Ctrl-C names the outputs already written in full, if any.
    """
    from ..util.outputs import WRITTEN

    mark = len(WRITTEN)
    try:
        return action()
    except CalibPinError as e:
        return fail(cli_message(e))
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




def count(upper: int, lower: int = 1) -> Callable[[str], int]:
    """A whole number in [lower, upper]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            try:
                as_float = float(text)
                value = int(as_float) if as_float.is_integer() and abs(as_float) < 1e18 else 0
            except (ValueError, OverflowError):
                value = 0
        if not lower <= value <= upper:
            raise argparse.ArgumentTypeError(f"expected a whole number from {lower} to {upper}, got '{text[:40]}'")
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
    from ..util.arguments import as_names

    if not text.replace(",", "").strip():
        raise argparse.ArgumentTypeError(f"expected joint names, comma-separated (joint_2,joint_3) or all, got '{text[:40]}'")
    try:
        return as_names(text, "compliance")
    except ArgumentError as e:
        raise argparse.ArgumentTypeError(e.reason) from None


def unknown_names(text: str) -> str:
    """``--fix`` / ``--free``: comma-separated unknowns, at least one, each once (the text
    as given: the library reads it, :func:`calib_pin.calibration.held.held_names`)."""
    from ..util.arguments import as_names

    try:
        as_names(text, "names")
    except ArgumentError as e:
        raise argparse.ArgumentTypeError(e.reason.replace("leave names out", "leave the option out")) from None
    return text


#: The titles of the shared argument groups: a section of each command's ``--help``.
ROBOT_GROUP = "robot"
FIT_GROUP = "method and seed"
COMPLIANCE_GROUP = "compliance (joint deflection under gravity, payload and cable pull)"
PARALLEL_GROUP = "parallel (local processes or a Dask cluster)"

#: The shared options' types: one object each, so every command parses an option alike.
SEED_TYPE = non_negative(int)
LOAD_TYPE = non_negative(float, 1e4)
JOBS_TYPE = count(1024)

#: The shared options' help texts, the same in every command.
ROBOT_HELP = "robot name (irb120, or an example-robot-data name) or URDF path"
END_FRAME_HELP = "end frame (default: the data file's, else tool0)"
SEED_HELP = ("seed, a whole number >= 0, of the split, the estimator and simulated data; repeats "
             "(trials, sessions) take seed, seed+1, ... (default 0)")
TEST_FRACTION_HELP = "share of poses held out for testing, per set (default 0.2)"
LOSS_HELP = "linear (default), or a robust loss: huber, soft_l1, cauchy"
MODEL_HELP = ("parameter model: dh (default with a DH table), hayati (dh with a tilt beta for parallel "
              "axes), placement (6D offset per joint, any URDF; default without a DH table)")
QUIET_HELP = "no progress bar (it is drawn on stderr, only on a terminal)"


def group(p: argparse.ArgumentParser, title: str) -> Any:
    """``p``'s argument group ``title``, made on first use.

    So the shared options of a group land in one section of ``--help`` wherever a command
    adds them.
    """
    for g in p._action_groups:
        if g.title == title:
            return g
    return p.add_argument_group(title)


def add_robot_argument(p: argparse.ArgumentParser) -> None:
    """The positional ROBOT (name or URDF path)."""
    group(p, ROBOT_GROUP).add_argument("robot", help=ROBOT_HELP)


def add_end_frame_argument(p: argparse.ArgumentParser) -> None:
    """``--end-frame``: the frame whose pose the sensor measures."""
    group(p, ROBOT_GROUP).add_argument("--end-frame", help=END_FRAME_HELP)


def add_seed_argument(p: argparse.ArgumentParser) -> None:
    """``--seed``: a whole number >= 0, default 0."""
    group(p, FIT_GROUP).add_argument("--seed", type=SEED_TYPE, default=0, help=SEED_HELP)


def add_test_fraction_argument(p: argparse.ArgumentParser) -> None:
    """``--test-fraction``: the held-out share of poses, in [0, 1)."""
    group(p, FIT_GROUP).add_argument("--test-fraction", type=fraction, default=0.2, help=TEST_FRACTION_HELP)


def add_loss_argument(p: argparse.ArgumentParser) -> None:
    """``--loss``: linear or a robust loss (checked by the estimator, once)."""
    group(p, FIT_GROUP).add_argument("--loss", default="linear", help=LOSS_HELP)


def add_model_argument(p: argparse.ArgumentParser) -> None:
    """``--model``: the parameter model (:data:`calib_pin.parameters.MODELS`)."""
    from ..parameters import MODELS

    group(p, FIT_GROUP).add_argument("--model", choices=MODELS, help=MODEL_HELP)


def add_unknowns_arguments(p: argparse.ArgumentParser, start_note: str = "") -> None:
    """``--fix``, ``--free`` and ``--nominal``: the unknowns held, and where the estimate starts."""
    g = group(p, FIT_GROUP)
    g.add_argument("--fix", type=unknown_names, help="unknowns held at their nominal value, comma-separated: robot deviations "
                   "(theta_1,d_1), compliances (compliance_joint_2) or sensor unknowns (device_rz)")
    g.add_argument("--free", type=unknown_names, help="the robot deviations and compliances to estimate, comma-separated; every "
                   "other one is held at its nominal value (the sensor's unknowns stay free)")
    g.add_argument("--nominal", help="start from the robot's own calibrated kinematics instead of the catalogue "
                   "URDF: a calib-pin <robot>_calibration.json (or the calibrate --out folder holding it), or a UR "
                   "default_kinematics.yaml (ur_description's "
                   f"layout; what --export yaml writes){start_note}")
    g.add_argument("--prior-mm", type=positive_float(100.0), metavar="MM",
                   help="what a length deviation of the robot is before calibration, 1 sigma, mm (default 1): the "
                   "robot stays at its start along what the data does not determine, and this bounds the error "
                   "left there in the predicted accuracy")
    g.add_argument("--prior-deg", type=positive_float(10.0), metavar="DEG",
                   help="the same for an angle deviation, deg (default 0.1)")


def unknowns_options(args: argparse.Namespace) -> dict[str, Any]:
    """``--fix``, ``--free``, ``--nominal``, ``--prior-mm``/``--prior-deg`` as keyword arguments.

    Of calibrate, compare and compare_models; only those given.
    """
    options = {k: v for k, v in (("fix", args.fix), ("free", args.free), ("nominal", args.nominal)) if v is not None}
    if args.prior_mm is not None or args.prior_deg is not None:
        from ..parameters.prior import Prior

        default = Prior()
        options["prior"] = Prior(args.prior_mm or default.length_mm, args.prior_deg or default.angle_deg)
    return options


def add_quiet_argument(p: argparse.ArgumentParser) -> None:
    """``--quiet``: no progress bar."""
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP)


def add_parallel_arguments(p: argparse.ArgumentParser) -> None:
    """``--jobs N`` local processes or ``--scheduler ADDRESS`` of a Dask cluster."""
    g = group(p, PARALLEL_GROUP)
    g.add_argument("--jobs", type=JOBS_TYPE, default=1, help="run in N local worker processes (default 1)")
    g.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on this Dask scheduler (tcp://host:8786) instead of local processes")


def add_robot_arguments(p: argparse.ArgumentParser, anchor_default: str, tool_default: str, *,
                        skip: Sequence[str] = (), defaults: dict[str, Any] | None = None,
                        anchor_per_session: bool = False) -> None:
    """The robot arguments shared by calibrate and simulate, and every registered sensor's set-up flags.

    The set-up flags come from :func:`calib_pin.sensors.add_sensor_arguments`; ``skip``:
    fields without a flag here, ``defaults``: flag defaults; ``anchor_default`` and
    ``tool_default`` say what the point flags default to (``anchor_per_session``:
    --anchor-mm may be given once per session, a list).
    """
    from ..sensors import add_sensor_arguments

    add_robot_argument(p)
    add_end_frame_argument(p)
    add_seed_argument(p)
    add_sensor_arguments(p, {"anchor_mm": anchor_default, "tool_mm": tool_default}, skip, defaults,
                         append=("anchor_mm",) if anchor_per_session else ())


def add_compliance_arguments(p: argparse.ArgumentParser, what: str = "estimate") -> None:
    """Joint compliance and its loads (see :mod:`calib_pin.robot.deflection`)."""
    from ..sensors.setup import point_mm

    g = group(p, COMPLIANCE_GROUP)
    g.add_argument("--compliance", metavar="JOINTS", type=joint_names,
                   help=f"{what} the compliance [rad/Nm] of these joints under gravity (and payload, cable pull): "
                   "joint names comma-separated (joint_2,joint_3) or all (see --compliance-model)")
    g.add_argument("--payload-kg", type=LOAD_TYPE, help="payload mass carried by the end frame, kg")
    g.add_argument("--payload-com-mm", type=point_mm("end frame"),
                   help="payload centre of mass in the end frame, 'x,y,z' mm (default 0,0,0)")
    g.add_argument("--cable-tension-n", type=LOAD_TYPE, help="the drawstring's pull on the tool point, N")
    g.add_argument("--compliance-model", choices=("cad", "basis"),
                   help="cad: compliances on the URDF's inertias; basis: the gravity torque patterns of the "
                   "kinematics, no inertias needed (default: cad when the URDF has inertial data, else basis)")


def compliance_options(args: argparse.Namespace) -> dict[str, Any]:
    """The compliance arguments as one record, built once: ``{"compliance": Compliance or None}``.

    The keyword argument of ``prepare``/``calibrate``/``compare``/``simulate``.

    Args:
        args: The parsed command line (``--compliance`` and its loads).

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


#: The sensors' flag parsers, re-exported from :mod:`calib_pin.sensors.setup` on first use
#: (importing it loads numpy: this module stays light).
_SENSOR_PARSERS = ("estimate_names", "finite", "point_mm", "xyz_mm")


def __getattr__(name: str) -> Any:
    if name in _SENSOR_PARSERS:
        from ..sensors import setup

        return getattr(setup, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

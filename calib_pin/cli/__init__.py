"""The ``calib-pin`` command: one argparse parser, a subparser for every command.

``calib-pin calibrate|simulate|compare|collect|make-poses|plan-poses|fake-indicator|compensate|benchmark|batch|detect ...``;
the ``scripts/*.py`` wrappers run the same parser (:func:`command`). :func:`parser` builds
it: ``prog`` ``calib-pin``, ``add_subparsers`` with one :class:`CommandParser` per
command. Each command's arguments are defined in its own module, by
``add_<command>_arguments(p)`` (``add_calibrate_arguments``, ``add_make_poses_arguments``),
and the options several commands share by the argument groups of :mod:`.common`; its work
is its ``<command>_main``. A subparser gets its arguments when it is first used (parsing or
``--help``; :meth:`CommandParser.populate`), so building the parser and ``calib-pin --help``
import no command module, no numpy, scipy or Pinocchio, and ``calib-pin COMMAND`` imports
that command's module alone.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from .common import ROBOT_GROUP, OneLineParser

#: Subcommand -> (module of calib_pin.cli, its main function, what it does).
COMMANDS: dict[str, tuple[str, str, str]] = {
    "calibrate": ("calibrate", "calibrate_main", "calibrate a robot from a measurement set"),
    "simulate": ("simulate", "simulate_main", "simulate a measurement set with known truth"),
    "compare": ("compare", "compare_main", "run the estimators side by side (Table I)"),
    "collect": ("collect", "collect_main", "read the drawstring sensor pose by pose"),
    "make-poses": ("poses", "make_poses_main", "write random poses within the joint limits"),
    "plan-poses": ("poses", "plan_poses_main", "choose D-optimal poses"),
    "fake-indicator": ("fake_indicator", "fake_indicator_main", "serve a simulated indicator on a pty"),
    "compensate": ("compensate", "compensate_main", "correct a program's joint targets with a calibration"),
    "benchmark": ("benchmark", "benchmark_main", "time the estimators"),
    "batch": ("batch", "batch_main", "calibrate many sets, in local processes or on a Dask cluster"),
    "detect": ("detect", "detect_main", "find a board's corners in images: a camera set"),
}


#: What ``calib-pin --help`` says above the commands.
DESCRIPTION = ("Kinematic calibration of robot arms from drawstring readings or laser-tracker marker "
               "positions (Pinocchio). 'calib-pin COMMAND --help' shows a command's options.")

#: What ``calib-pin --help`` says below the commands.
EPILOG = ("exit status: 0 done; 2 bad input (one line on stderr naming the file, line or field); "
          "3 a sensor fault (collect); 130 stopped by Ctrl-C")


def arguments_function(name: str) -> str:
    """The name of the function of command ``name``'s module that adds its arguments.

    ``add_<main function less _main>_arguments`` (``add_make_poses_arguments``).
    """
    return f"add_{COMMANDS[name][1].removesuffix('_main')}_arguments"


class CommandParser(OneLineParser):
    """The subparser of one command: prog ``calib-pin COMMAND``, its arguments added on first use.

    ``fill`` adds them (the command module's ``add_<command>_arguments``); errors are one
    line, exit 2, as :class:`~.common.OneLineParser`'s.
    """

    def __init__(self, *args: Any, fill: Callable[[argparse.ArgumentParser], Any] | None = None,
                 **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._fill = fill

    def populate(self) -> CommandParser:
        """Add the command's arguments (once; importing its module). Returns self."""
        fill, self._fill = self._fill, None
        if fill is not None:
            fill(self)
            first = [g for g in self._action_groups if g.title == ROBOT_GROUP]  # --help: the robot first
            self._action_groups[:] = first + [g for g in self._action_groups if g not in first]
        return self

    def parse_known_args(self, args: Sequence[str] | None = None,  # type: ignore[override]
                         namespace: argparse.Namespace | None = None) -> tuple[argparse.Namespace, list[str]]:
        """Parse the command's arguments; an argument it does not know is this command's error.

        Reported as ``calib-pin calibrate: error: unrecognized arguments: ...``.
        """
        self.populate()
        parsed, extras = super().parse_known_args(args, namespace)
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return parsed, extras

    def format_usage(self) -> str:
        self.populate()
        return super().format_usage()

    def format_help(self) -> str:
        self.populate()
        return super().format_help()


class _CommandList(argparse.HelpFormatter):
    """``calib-pin --help``: each command and what it does on one line."""

    def __init__(self, prog: str) -> None:
        super().__init__(prog, max_help_position=24, width=100)

    def add_argument(self, action: argparse.Action) -> None:
        super().add_argument(action)
        if isinstance(action, argparse._SubParsersAction):  # argparse measures the names one indent short
            longest = max(len(name) for name in action.choices) + self._current_indent + 2 * self._indent_increment
            self._action_max_length = max(self._action_max_length, longest)


def _filler(name: str) -> Callable[[argparse.ArgumentParser], Any]:
    """The function that adds command ``name``'s arguments, importing its module when called."""
    def fill(p: argparse.ArgumentParser) -> Any:
        module = importlib.import_module(f"{__name__}.{COMMANDS[name][0]}")
        add = getattr(module, arguments_function(name), None)
        return add(p) if add is not None else None  # a command whose main builds its own parser adds none here

    return fill


def parser(populate: Iterable[str] = ()) -> OneLineParser:
    """The one ``calib-pin`` parser: a subparser per command of :data:`COMMANDS`.

    Dest ``command``; each subparser is filled with its arguments on first use; the
    commands in ``populate`` are filled at once (this imports their modules).
    """
    top = OneLineParser(prog="calib-pin", description=DESCRIPTION, epilog=EPILOG, formatter_class=_CommandList)
    commands = top.add_subparsers(title="commands", dest="command", metavar="COMMAND", required=True,
                                  parser_class=CommandParser)
    for name, (_, _, what) in COMMANDS.items():
        commands.add_parser(name, help=what, prog=f"calib-pin {name}", fill=_filler(name))
    for name in populate:
        command_parser(top, name)
    return top


def command_parser(top: argparse.ArgumentParser, name: str) -> CommandParser:
    """The subparser of command ``name`` in ``top`` (a :func:`parser`), with its arguments."""
    for action in top._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices[name].populate()
    raise KeyError(name)


def parse_args(name: str, argv: Sequence[str] | None = None) -> argparse.Namespace:
    """``calib-pin NAME ARGV...`` parsed by the one parser (``argv`` None: ``sys.argv[1:]``).

    A bad argument exits 2 with one line naming it.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    return parser().parse_args([name, *argv])


#: BLAS threads of every command. calib-pin's matrices are small (at most a few
#: hundred thousand rows by ~50 columns): one thread costs little at the largest sizes,
#: and on a loaded machine a multithreaded BLAS spins and turns a quick SVD into a long
#: wait. Library callers keep their own setting.
BLAS_THREADS = 1


#: Environment variables the BLAS and OpenMP libraries read when they load.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def limit_blas_threads(threads: int = BLAS_THREADS) -> None:
    """Limit the BLAS and OpenMP pools of this process and of its worker processes to ``threads``.

    threadpoolctl for the libraries already loaded, the environment for those loaded
    later (scipy bundles its own OpenBLAS, loaded with scipy.linalg, and Pinocchio brings
    OpenMP).
    """
    global _ENVIRONMENT_LIMITED
    for variable in THREAD_VARIABLES:
        os.environ[variable] = str(threads)
    if threads == _ENVIRONMENT_LIMITED and "threadpoolctl" not in sys.modules:
        return  # every pool loaded since read the environment, and none was changed since: nothing to limit
    if not any(name in sys.modules for name in NATIVE_MODULES):  # no pool loaded yet: the environment suffices
        _ENVIRONMENT_LIMITED = threads
        return
    _ENVIRONMENT_LIMITED = None  # the loaded pools are limited to another count from here
    import numpy  # noqa: F401 - threadpoolctl limits the libraries already loaded
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=threads)


#: The modules that bring a BLAS or OpenMP pool (numpy's OpenBLAS, scipy's own, Pinocchio's
#: OpenMP); until one is imported, no pool exists and the environment limits them all.
NATIVE_MODULES = ("numpy", "scipy", "pinocchio")

#: The thread count the environment was set to before any of :data:`NATIVE_MODULES` was
#: imported (each pool then read it when it loaded); None: not so in this process.
_ENVIRONMENT_LIMITED: int | None = None


def command(name: str) -> Callable[[Sequence[str] | None], int]:
    """The main function of subcommand ``name``, run with :data:`BLAS_THREADS` BLAS threads."""
    module, function, _ = COMMANDS[name]
    try:
        limit_blas_threads()  # before the command's module loads numpy, scipy or Pinocchio
        main = getattr(importlib.import_module(f"{__name__}.{module}"), function)
    except KeyboardInterrupt:  # Ctrl-C while the libraries load: one line, not a traceback
        return _stopped

    def limited(argv: Sequence[str] | None = None) -> int:
        try:
            limit_blas_threads()
            return main(argv)
        except KeyboardInterrupt:  # outside the command's own run() (parsing): nothing was written
            return _stopped(argv)

    return limited


def _stopped(argv: Sequence[str] | None = None) -> int:
    """Ctrl-C before a command's work began: one line, exit 130."""
    print("\nstopped by Ctrl-C: nothing was written", file=sys.stderr)
    return 130


def main(argv: Sequence[str] | None = None) -> int:
    """``calib-pin COMMAND ...``: see ``calib-pin --help``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in ("-h", "--help"):
        parser().print_help()
        return 0
    if not argv or argv[0] not in COMMANDS:
        from .common import one_line

        what = f"unknown command '{one_line(argv[0][:40])}'" if argv else "give a command"
        print(f"calib-pin: error: {what} (commands: {', '.join(COMMANDS)}; see calib-pin --help)", file=sys.stderr)
        return 2
    return command(argv[0])(argv[1:])


__all__ = ["BLAS_THREADS", "COMMANDS", "CommandParser", "command", "command_parser", "limit_blas_threads", "main",
           "parse_args", "parser"]

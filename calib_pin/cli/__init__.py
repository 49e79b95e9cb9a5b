"""The ``calib-pin`` command: one entry point, a subcommand for every command.

``calib-pin calibrate|simulate|compare|analyze|collect|make-poses|plan-poses|fake-indicator|benchmark ...``;
the ``scripts/*.py`` wrappers call the same functions. Each command's module is imported
only when it runs, so starting is quick.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Sequence

#: Subcommand -> (module of calib_pin.cli, its main function, what it does).
COMMANDS: dict[str, tuple[str, str, str]] = {
    "calibrate": ("calibrate", "calibrate_main", "calibrate a robot from a measurement set"),
    "simulate": ("simulate", "simulate_main", "simulate a measurement set with known truth"),
    "compare": ("compare", "compare_main", "run the estimators side by side (Table I)"),
    "collect": ("collect", "collect_main", "read the drawstring sensor pose by pose"),
    "make-poses": ("poses", "make_poses_main", "write random poses within the joint limits"),
    "plan-poses": ("poses", "plan_poses_main", "choose D-optimal poses"),
    "fake-indicator": ("fake_indicator", "fake_indicator_main", "serve a simulated indicator on a pty"),
    "benchmark": ("benchmark", "benchmark_main", "time the estimators"),
}


def command(name: str) -> Callable[[Sequence[str] | None], int]:
    """The main function of subcommand ``name``."""
    module, function, _ = COMMANDS[name]
    return getattr(importlib.import_module(f"{__name__}.{module}"), function)


def main(argv: Sequence[str] | None = None) -> int:
    """``calib-pin COMMAND ...``: see ``calib-pin --help``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help") or argv[0] not in COMMANDS:
        lines = [f"  {name:16s}{what}" for name, (_, _, what) in COMMANDS.items()]
        text = "usage: calib-pin COMMAND [options] (calib-pin COMMAND --help)\ncommands:\n" + "\n".join(lines)
        if argv and argv[0] in ("-h", "--help"):
            print(text)
            return 0
        what = f"unknown command '{argv[0][:40]}'" if argv else "give a command"
        print(f"calib-pin: error: {what} (commands: {', '.join(COMMANDS)}; see calib-pin --help)", file=sys.stderr)
        return 2
    return command(argv[0])(argv[1:])


__all__ = ["COMMANDS", "command", "main"]

"""A calib-pin process: how ``scripts/*.py`` and the ``calib-pin`` console script run a command.

The command is :func:`calib_pin.cli.command`'s, as a caller in its own process runs it;
what differs is Python's cyclic garbage collector, which belongs to the process:

* While a one-pass command (:data:`ONE_PASS`: one calibration, one simulated set, one
  compensated program, one pose file) runs, the collector is off. Such a command imports
  its libraries as it goes (numpy, Pinocchio, scipy, filterpy, matplotlib: hundreds of
  thousands of objects with the report), and the collector traverses them again and again
  while they load, a large share of a short command's time. What it would free is the
  command's own cyclic garbage, too little to change a large run's peak memory. Reference
  counting frees everything else as usual, and every file is written and closed before
  the command returns.
* A part of a one-pass command whose cyclic garbage would grow with its input runs with the
  collector on again, everything made before it frozen (:func:`collecting`): the drawing of
  report.html when it has several sets (figures per set, which only the collector frees, so
  the peak memory would grow with the sets). One set's figures take bounded memory, and the
  collector's passes over matplotlib while it draws them take time.
* The other commands (compare, batch, collect, benchmark, fake-indicator) repeat their work
  for as long as they are asked to, so their garbage would grow with it: the collector
  stays on.
* When any command returns, every tracked object is frozen (``gc.freeze``): the
  interpreter's last collection at exit then skips them instead of traversing the
  libraries' objects once more.

A library caller (``command(name)(argv)`` in its own process, the tests) keeps its
collector as it is: only :func:`run_command` changes it, and only for its own process.
"""

from __future__ import annotations

import contextlib
import gc
import sys
from collections.abc import Iterator, Sequence

#: Commands that make one bounded pass, run with the cyclic collector off (see the module docstring).
ONE_PASS = frozenset({"calibrate", "simulate", "compensate", "make-poses", "plan-poses", "detect"})


def run_command(name: str, argv: Sequence[str] | None = None) -> int:
    """Run command ``name`` with ``argv`` as this process's work; its exit status.

    See the module docstring. Call it once, from the process's entry point.
    """
    from . import command

    if name in ONE_PASS:
        gc.disable()
    try:
        return command(name)(argv)
    finally:
        gc.freeze()  # the interpreter's exit collection skips what the command made


@contextlib.contextmanager
def collecting() -> Iterator[None]:
    """The cyclic collector on for a part of a one-pass command whose cyclic garbage grows with its input.

    That part is report.html's figures: matplotlib frees a figure only through the
    collector, so with it off the peak memory of a report of many sets grows with the sets.
    Every object made before is frozen first, so its passes skip them; off again after.
    Nothing changes when the collector is on (a library caller, a repeating command).
    """
    if gc.isenabled():
        yield
        return
    gc.freeze()
    gc.enable()
    try:
        yield
    finally:
        gc.disable()


def main(argv: Sequence[str] | None = None) -> int:
    """The ``calib-pin`` console script: ``calib-pin COMMAND ...`` through :func:`run_command`.

    Help and an unknown or missing command as :func:`calib_pin.cli.main` answers them.
    """
    from . import COMMANDS
    from . import main as cli_main

    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in COMMANDS:
        return run_command(argv[0], argv[1:])
    return cli_main(argv)


__all__ = ["ONE_PASS", "collecting", "main", "run_command"]

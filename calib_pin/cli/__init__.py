"""The ``calib-pin`` command: one entry point, a subcommand for every command.

``calib-pin calibrate|simulate|compare|collect|make-poses|plan-poses|fake-indicator|compensate|benchmark|batch ...``;
the ``scripts/*.py`` wrappers call the same functions. Each command's module is imported
only when it runs, so starting is quick.
"""

from __future__ import annotations

import importlib
import os
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
    "compensate": ("compensate", "compensate_main", "correct a program's joint targets with a calibration"),
    "benchmark": ("benchmark", "benchmark_main", "time the estimators"),
    "batch": ("batch", "batch_main", "calibrate many measurement sets, in processes or on a Dask cluster"),
}


#: BLAS threads of every command. calib-pin's matrices are small (at most a few
#: hundred thousand rows by ~50 columns): one thread costs little at the largest sizes,
#: and on a loaded machine a multithreaded BLAS spins and turns a millisecond SVD into
#: half a second in some processes. Library callers keep their own setting.
BLAS_THREADS = 1


#: Environment variables the BLAS and OpenMP libraries read when they load.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def limit_blas_threads(threads: int = BLAS_THREADS) -> None:
    """Limit the BLAS and OpenMP pools of this process (and of the worker processes it
    starts) to ``threads``: threadpoolctl for the libraries already loaded, the
    environment for those loaded later (scipy bundles its own OpenBLAS, loaded with
    scipy.linalg, and Pinocchio brings OpenMP)."""
    for variable in THREAD_VARIABLES:
        os.environ[variable] = str(threads)
    import numpy  # noqa: F401 - threadpoolctl limits the libraries already loaded
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=threads)


def command(name: str) -> Callable[[Sequence[str] | None], int]:
    """The main function of subcommand ``name``, run with :data:`BLAS_THREADS` BLAS threads."""
    module, function, _ = COMMANDS[name]
    try:
        limit_blas_threads()  # before the command's module loads numpy, scipy or Pinocchio
        main = getattr(importlib.import_module(f"{__name__}.{module}"), function)
    except KeyboardInterrupt:  # Ctrl-C while the libraries load (half a second): one line, not a traceback
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
    if not argv or argv[0] in ("-h", "--help") or argv[0] not in COMMANDS:
        lines = [f"  {name:16s}{what}" for name, (_, _, what) in COMMANDS.items()]
        text = "usage: calib-pin COMMAND [options] (calib-pin COMMAND --help)\ncommands:\n" + "\n".join(lines)
        if argv and argv[0] in ("-h", "--help"):
            print(text)
            return 0
        from .common import one_line

        what = f"unknown command '{one_line(argv[0][:40])}'" if argv else "give a command"
        print(f"calib-pin: error: {what} (commands: {', '.join(COMMANDS)}; see calib-pin --help)", file=sys.stderr)
        return 2
    return command(argv[0])(argv[1:])


__all__ = ["BLAS_THREADS", "COMMANDS", "command", "limit_blas_threads", "main"]

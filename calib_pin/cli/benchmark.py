"""``benchmark``: time the estimators (see :mod:`calib_pin.studies.benchmark`)."""

from __future__ import annotations

import argparse
import os
import platform
from collections.abc import Sequence

from ..estimators import DEFAULT_METHOD, PAPER_METHODS
from . import parse_args
from .common import add_seed_argument, count, methods, run


def benchmark_parser() -> argparse.ArgumentParser:
    """The ``calib-pin benchmark`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "benchmark")


def add_benchmark_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """benchmark's arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = "Time calib-pin's estimators on a seeded simulated IRB120 session."
    p.add_argument("--repeats", type=count(1000), default=5, help="timed runs per method (5)")
    p.add_argument("--methods", type=methods,
                   help=f"comma-separated methods (the paper's nine; against FIGAROH: {DEFAULT_METHOD},lm)")
    add_seed_argument(p)
    p.add_argument("--poses", type=count(100_000), default=120, help="poses of the simulated set, 80 %% train (120)")
    p.add_argument("--scaling", action="store_true",
                   help="also print the scaling table: lm, ekf, ekf-qibas, qibas at 100, 1 000, 10 000 poses (minutes)")
    p.add_argument("--against", choices=["figaroh"],
                   help="also race FIGAROH (when installed) on simulated UR5 positions, 100 and 1 000 samples")
    return p


def benchmark_main(argv: Sequence[str] | None = None) -> int:
    """``benchmark.py [--repeats 5] [--methods ekf-qibas,lm] [--seed 0] [--poses 120]``."""
    args = parse_args("benchmark", argv)
    return run(lambda: _benchmark(args))


def _benchmark(args: argparse.Namespace) -> int:
    from .. import __version__
    from ..studies.benchmark import benchmark, floor, format_scaling, format_timings, scaling
    from . import BLAS_THREADS

    what, rows = benchmark(args.methods or list(PAPER_METHODS), args.repeats, args.seed, args.poses)
    print(f"calib-pin {__version__} benchmark: {what}")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; BLAS and OpenMP limited to {BLAS_THREADS} thread "
          "(threadpoolctl and the environment: calib_pin.cli.limit_blas_threads, every command)")
    print(format_timings(rows))
    cost = floor(args.poses, args.seed)
    print(f"one evaluation over {round(0.8 * args.poses)} poses [ms]: " +
          ", ".join(f"{k} {v:.3f}" for k, v in cost.items()) +
          f"; residual {cost['residual'] / cost['floor FK']:.1f}x FK, "
          f"Jacobian {cost['jacobian'] / cost['floor FK+regressor']:.1f}x FK+regressor")
    print("goals: EKF-QIBAS at 96 poses < 30 ms; 10 000 poses < 5 s; cost and memory linear in the poses")
    if args.scaling:
        print(format_scaling(scaling(seed=args.seed)))
    if args.against == "figaroh":
        _against_figaroh(args)
    return 0


def _against_figaroh(args: argparse.Namespace) -> None:
    """Print the FIGAROH race, or one line saying it is skipped."""
    from ..studies.benchmark_figaroh import (
        FRESH_POSES,
        NOISE_MM,
        TIMED,
        against_figaroh,
        figaroh_version,
        format_goal,
        format_races,
    )
    from . import BLAS_THREADS

    chosen = args.methods or [DEFAULT_METHOD, "lm"]
    rows = against_figaroh(chosen, args.repeats, args.seed)
    if rows is None:
        print("against figaroh: skipped, figaroh is not installed (pip install figaroh; not a dependency)")
        return
    print(f"against FIGAROH {figaroh_version()}: simulated UR5 positions (one marker, {NOISE_MM:g} mm per axis, "
          f"seed {args.seed}), every sample trains; interleaved calib-pin/FIGAROH, {args.repeats} repeat(s), "
          f"medians; both in this process with BLAS and OpenMP limited to {BLAS_THREADS} thread")
    print(format_races(rows))
    print(f"ratio: FIGAROH's median over calib-pin's; RMSE: Euclidean position error against the noise-free "
          f"truth at the training poses and at {FRESH_POSES} fresh poses [mm]; params: calib-pin/FIGAROH unknowns")
    print(f"timed: {TIMED}")
    print(format_goal(rows))

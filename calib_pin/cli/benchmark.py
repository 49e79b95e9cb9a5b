"""``benchmark``: time the estimators (see :mod:`calib_pin.benchmark`)."""

from __future__ import annotations

import argparse
import os
import platform
from collections.abc import Sequence

from ..estimators import PAPER_METHODS
from .common import OneLineParser, count, methods, non_negative, run


def benchmark_parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="benchmark.py", description="Time calib-pin's estimators on a seeded simulated IRB120 session.")
    p.add_argument("--repeats", type=count(1000), default=5, help="timed runs per method (5)")
    p.add_argument("--methods", type=methods, default=list(PAPER_METHODS),
                   help="comma-separated methods (default the paper's nine)")
    p.add_argument("--seed", type=non_negative(int), default=0, help="seed (0)")
    p.add_argument("--poses", type=count(100_000), default=120, help="poses of the simulated set, 80 %% train (120)")
    p.add_argument("--scaling", action="store_true",
                   help="also print the scaling table: lm, ekf, ekf-qibas, qibas at 100, 1 000, 10 000 poses (minutes)")
    p.add_argument("--against", choices=["figaroh"], help="also compare with FIGAROH when it is installed")
    return p


def benchmark_main(argv: Sequence[str] | None = None) -> int:
    """``benchmark.py [--repeats 5] [--methods ekf-qibas,lm] [--seed 0] [--poses 120]``."""
    args = benchmark_parser().parse_args(argv)
    return run(lambda: _benchmark(args))


def _benchmark(args: argparse.Namespace) -> int:
    from .. import __version__
    from ..benchmark import benchmark, floor, format_scaling, format_timings, scaling
    from . import BLAS_THREADS

    what, rows = benchmark(args.methods, args.repeats, args.seed, args.poses)
    print(f"calib-pin {__version__} benchmark: {what}")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; BLAS limited to {BLAS_THREADS} thread by threadpoolctl "
          "(calib_pin.cli.limit_blas_threads, every command)")
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
        try:
            import figaroh  # noqa: F401
        except ImportError:
            print("against figaroh: skipped, figaroh is not installed (pip install figaroh; not a dependency)")
        else:
            print("against figaroh: figaroh imports, but the comparison harness is not part of this version")
    return 0

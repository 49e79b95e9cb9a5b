"""``benchmark``: time the estimators (see :mod:`calib_pin.benchmark`)."""

from __future__ import annotations

import argparse
import os
import platform
from collections.abc import Sequence

from ..estimators import ESTIMATORS
from .common import OneLineParser, count, methods, non_negative, run


def benchmark_parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="benchmark.py", description="Time calib-pin's estimators on a seeded simulated IRB120 session.")
    p.add_argument("--repeats", type=count(1000), default=5, help="timed runs per method (5)")
    p.add_argument("--methods", type=methods, default=list(ESTIMATORS), help="comma-separated methods (all)")
    p.add_argument("--seed", type=non_negative(int), default=0, help="seed (0)")
    p.add_argument("--poses", type=count(100_000), default=120, help="poses of the simulated set, 80 %% train (120)")
    return p


def benchmark_main(argv: Sequence[str] | None = None) -> int:
    """``benchmark.py [--repeats 5] [--methods ekf-qibas,lm] [--seed 0] [--poses 120]``."""
    args = benchmark_parser().parse_args(argv)
    return run(lambda: _benchmark(args))


def _benchmark(args: argparse.Namespace) -> int:
    from .. import __version__
    from ..benchmark import benchmark, format_timings

    what, rows = benchmark(args.methods, args.repeats, args.seed, args.poses)
    print(f"calib-pin {__version__} benchmark: {what}")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}")
    print(format_timings(rows))
    return 0

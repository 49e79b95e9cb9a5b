"""``compare``: the estimators side by side (the paper's Table I, Fig. 2 and Fig. 3)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ..estimators import PAPER_METHODS
from ..progress import quiet_progress
from ..simulation import NOISE_KINDS
from .common import (
    OneLineParser,
    add_compliance_arguments,
    compliance_options,
    count,
    fail,
    fraction,
    methods,
    non_negative,
    positive_float,
    run,
)

#: Most trials one comparison may run.
MAX_TRIALS = 100_000


def compare_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="compare.py",
        description="Run the estimators side by side on one data set and split (the paper's "
        "Table I, Fig. 2, Fig. 3); writes table1.csv, table1.md and two PNG figures.",
    )
    p.add_argument("robot", help="robot name (irb120) or URDF path")
    p.add_argument("--data", help="measurement set CSV (default: the robot's shipped set)")
    p.add_argument("--trials", type=count(MAX_TRIALS), default=1,
                   help="repeat over N seeded splits (or simulated sets): mean ± sd (default 1)")
    p.add_argument("--out", default="out/compare", help="output folder (default ./out/compare)")
    p.add_argument("--methods", type=methods, default=list(PAPER_METHODS),
                   help=f"comma-separated methods (default the paper's nine: {','.join(PAPER_METHODS)})")
    p.add_argument("--seed", type=non_negative(int), default=0, help="first seed (default 0)")
    p.add_argument("--test-fraction", type=fraction, default=0.2, help="held-out share (default 0.2)")
    p.add_argument("--simulate", choices=NOISE_KINDS,
                   help="run on seeded simulated sets with this noise kind instead of --data")
    p.add_argument("--noise-mm", type=positive_float(100.0), default=0.05,
                   help="noise of simulated sets, 1 sigma, mm (default 0.05)")
    p.add_argument("--poses", type=count(100_000), default=120, help="poses of simulated sets (default 120)")
    add_compliance_arguments(p)
    p.add_argument("--jobs", type=count(1024), default=1, help="run the trials in N local processes (default 1)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the trials on this Dask scheduler (tcp://host:8786) instead")
    p.add_argument("--quiet", action="store_true", help="no progress bar (it is drawn on stderr, only on a terminal)")
    return p


def compare_main(argv: Sequence[str] | None = None) -> int:
    """``compare.py ROBOT [--data CSV] [--trials N] [--out DIR] [--methods a,b] [--simulate KIND]``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = compare_parser().parse_args(argv)
    if args.simulate and args.data:
        return fail("give either --data or --simulate, not both")
    with quiet_progress(args.quiet):
        return run(lambda: _compare(args, argv))


def _compare(args: argparse.Namespace, argv: list[str]) -> int:
    from ..comparison import compare
    from ..figures import convergence_figure, residual_figure

    if args.trials >= 10:
        print(f"comparing {len(args.methods)} methods over {args.trials} trials; this can take long "
              "(Ctrl-C stops, writing nothing)", file=sys.stderr, flush=True)
    result = compare(
        args.robot, args.data, methods=args.methods, trials=args.trials, seed=args.seed,
        test_fraction=args.test_fraction, simulate_noise=args.simulate,
        noise_mm=args.noise_mm, poses=args.poses, jobs=args.jobs, scheduler=args.scheduler,
        **compliance_options(args),
    )
    out = Path(args.out)
    print(result.format_table())
    command = "python scripts/compare.py " + " ".join(argv)
    written = [
        result.write_csv(out / "table1.csv"),
        result.write_markdown(out / "table1.md", command),
        residual_figure(result, out / "fig2_residuals.png"),
        convergence_figure(result, out / "fig3_convergence.png"),
    ]
    for path in written:
        print(f"wrote {path}")
    return 0

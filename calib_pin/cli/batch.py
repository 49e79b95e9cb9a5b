"""``batch``: one calibration per measurement set, here (``--jobs``) or on a Dask cluster.

Exit status 0 when every set calibrated, 2 on bad options, when any set failed (each
failed set's one-line error is in ``summary.csv`` and on stderr) or when a worker or the
scheduler failed (one line naming which). Finished sets are kept in
``OUT/.calib-pin-checkpoint`` as they finish: after Ctrl-C (exit 130) or a fault the
same command runs only the rest, and says so.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ..estimators import ESTIMATORS
from . import parse_args
from .common import (
    INTERRUPTED_EXIT,
    add_loss_argument,
    add_model_argument,
    add_parallel_arguments,
    add_seed_argument,
    add_test_fraction_argument,
    fail,
    one_line,
    run,
)


def batch_parser() -> argparse.ArgumentParser:
    """The ``calib-pin batch`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "batch")


def add_batch_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """batch's arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = ("Calibrate many measurement sets, here (--jobs) or on a Dask cluster "
                     "(--scheduler): per set OUT/<set>/report.json and the corrected URDF, plus "
                     "OUT/summary.csv with one row per set.")
    p.add_argument("sessions", nargs="+", metavar="SESSION",
                   help="measurement set CSVs, one calibration each (file stems must differ); "
                   "a.csv+b.csv+c.csv is ONE calibration of those three sets together (one robot, each "
                   "set its own sensor set-up from its file), written as OUT/a+b+c/ (a file whose own "
                   "name holds '+' is one set when it exists)")
    p.add_argument("--out", required=True, help="output folder (each finished set is kept in OUT/.calib-pin-checkpoint "
                   "until the run completes: after Ctrl-C or a fault the same command resumes)")
    p.add_argument("--robot", help="robot name or URDF path (default: each file's '# robot:' line)")
    p.add_argument("--method", default="lm", choices=ESTIMATORS, metavar="METHOD",
                   help=f"estimator: {', '.join(ESTIMATORS)} (default lm)")
    add_seed_argument(p)
    add_test_fraction_argument(p)
    add_model_argument(p)
    add_loss_argument(p)
    add_parallel_arguments(p)
    return p


def batch_main(argv: Sequence[str] | None = None) -> int:
    """``calib-pin batch SESSIONS... --out DIR [--method M] [--jobs N] [--scheduler ADDRESS]``."""
    args = parse_args("batch", argv)
    return run(lambda: _batch(args))


def calibration_files(argument: str) -> str | tuple[str, ...]:
    """One SESSION argument: a CSV, or several joined by ``+`` (one calibration of those sets).

    An existing file is taken whole, '+' in its name or not; otherwise the argument is cut
    at the '+' that leave existing files (``a+b.csv+c.csv`` with a file ``a+b.csv``: two
    sets), and where no cut does, at every '+' but inside the longest existing names (the
    files missing are then named).

    Args:
        argument: The SESSION argument as typed.

    Raises:
        CalibPinError: an empty part (``a.csv++b.csv``, a leading or trailing ``+``); two
            ways to cut it into existing files.
    """
    from ..exceptions import CalibPinError

    if "+" not in argument or _is_file(argument):
        return argument
    parts = argument.split("+")
    if not all(p.strip() for p in parts):
        raise CalibPinError(f"SESSION '{argument}': an empty set between '+' (join sets as a.csv+b.csv)")
    cuts = _file_cuts(parts, 0, {})
    if len(cuts) > 1:
        raise CalibPinError(f"SESSION '{argument}': two readings of existing files, "
                            f"{' and '.join(' + '.join(repr(f) for f in cut) for cut in cuts[:2])}: rename one")
    files = cuts[0] if cuts else _longest_files(parts)
    return tuple(files) if len(files) > 1 else files[0]


def _file_cuts(parts: list[str], start: int, memo: dict[int, list[list[str]]]) -> list[list[str]]:
    """Up to two ways to join ``parts[start:]`` into existing files (each a run of parts
    joined by '+')."""
    if start == len(parts):
        return [[]]
    if start not in memo:
        found: list[list[str]] = []
        for end in range(start + 1, len(parts) + 1):
            name = "+".join(parts[start:end])
            if _is_file(name):
                found += [[name, *rest] for rest in _file_cuts(parts, end, memo)][:2 - len(found)]
            if len(found) == 2:
                break
        memo[start] = found
    return memo[start]


def _is_file(name: str) -> bool:
    """``name`` is an existing file (a name too long for the file system is none)."""
    try:
        return Path(name).is_file()
    except OSError:  # ENAMETOOLONG: sessions joined by '+' beyond 255 bytes
        return False


def _longest_files(parts: list[str]) -> list[str]:
    """``parts`` joined where they make an existing file (the longest run first), the
    others alone."""
    files, k = [], 0
    while k < len(parts):
        end = next((e for e in range(len(parts), k, -1) if _is_file("+".join(parts[k:e]))), k + 1)
        files.append("+".join(parts[k:end]))
        k = end
    return files


def _batch(args: argparse.Namespace) -> int:
    from ..estimators import get_method
    from ..studies.batch import BatchTask, run_batch
    from ..studies.checkpoint import Interrupted

    get_method(args.method).check(args.loss)  # a bad --loss fails once, not once per set
    options = {"test_fraction": args.test_fraction, "loss": args.loss, "parameters": args.model}
    tasks = [BatchTask(args.robot, calibration_files(str(s)), args.method, args.seed, options) for s in args.sessions]
    where = f"Dask scheduler {args.scheduler}" if args.scheduler else f"{args.jobs} local process(es)"
    print(f"{len(tasks)} set(s), method {args.method}, seed {args.seed}, on {where}", flush=True)
    try:
        outcomes = run_batch(tasks, out=args.out, jobs=args.jobs, scheduler=args.scheduler,
                             notify=lambda line: print(line, flush=True))
    except Interrupted as e:
        print(f"\n{one_line(str(e))}", file=sys.stderr)
        return INTERRUPTED_EXIT
    width = max(len(o.name) for o in outcomes)
    for o in outcomes:
        if o.status == "ok":
            r = o.row
            print(f"{o.name:{width}s}  ok      test RMSE {r.get('test_rmse_before_mm', '-')} -> "
                  f"{r.get('test_rmse_after_mm', '-')} mm, {r['time_s']} s")
        else:
            print(f"{o.name:{width}s}  failed  {o.error}")
    print(f"wrote {Path(args.out) / 'summary.csv'}")
    failed = [o for o in outcomes if o.status != "ok"]
    if failed:
        return fail(f"{len(failed)} of {len(outcomes)} set(s) failed, first {failed[0].name}: {failed[0].error}")
    return 0

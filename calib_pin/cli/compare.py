"""``compare``: the estimators side by side (the paper's Table I, Fig. 2 and Fig. 3).

Writes table1.csv, table1.md, fig2_residuals.png and fig3_convergence.png all together
or none (:class:`~calib_pin.util.outputs.Outputs`); the figures are optional: without a
working matplotlib one warning line, and the tables. Each finished trial is kept in
``OUT/.calib-pin-checkpoint`` as it finishes: after Ctrl-C (exit 130, one line) or a
worker fault the same command runs only the trials not yet done, and says so.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..estimators import PAPER_METHODS
from ..robot.description import robot_inputs
from ..simulation import NOISE_KINDS
from ..util.outputs import Outputs
from ..util.progress import quiet_progress
from . import parse_args
from .common import (
    INTERRUPTED_EXIT,
    add_compliance_arguments,
    add_model_argument,
    add_parallel_arguments,
    add_quiet_argument,
    add_robot_argument,
    add_seed_argument,
    add_test_fraction_argument,
    add_unknowns_arguments,
    compliance_options,
    count,
    estimate_names,
    fail,
    methods,
    one_line,
    positive_float,
    run,
    unknowns_options,
)

#: Most trials one comparison may run.
MAX_TRIALS = 100_000


def compare_parser() -> argparse.ArgumentParser:
    """The ``calib-pin compare`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "compare")


def add_compare_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """compare's arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = ("Run the estimators side by side on one data set and split (the paper's "
                     "Table I, Fig. 2, Fig. 3); writes table1.csv, table1.md and two PNG figures.")
    add_robot_argument(p)
    p.add_argument("--data", action="append",
                   help="measurement set CSV (default: the robot's shipped set); give it once per set "
                   "(--data a.csv --data b.csv) to compare on the sets fitted together as calibrate fits them: "
                   "one robot, each set its own sensor set-up from its file (or FILE:key=value, as calibrate's "
                   "--data), every set split by pose with each trial's seed")
    p.add_argument("--trials", type=count(MAX_TRIALS), default=1,
                   help="repeat over N seeded splits (or simulated sets): mean ± sd (default 1)")
    p.add_argument("--out", default="out/compare", help="output folder (default ./out/compare); each finished trial is "
                   "kept in OUT/.calib-pin-checkpoint until the run completes: after Ctrl-C or a fault the same command resumes")
    p.add_argument("--methods", type=methods, default=list(PAPER_METHODS),
                   help=f"comma-separated methods (default the paper's nine: {','.join(PAPER_METHODS)})")
    add_seed_argument(p)
    add_test_fraction_argument(p)
    p.add_argument("--simulate", choices=NOISE_KINDS,
                   help="run on seeded simulated sets with this noise kind instead of --data")
    p.add_argument("--noise-mm", type=positive_float(100.0), default=0.05,
                   help="noise of simulated sets, 1 sigma, mm (default 0.05)")
    p.add_argument("--poses", type=count(100_000), default=120, help="poses of simulated sets (default 120)")
    add_compliance_arguments(p)
    add_model_argument(p)
    p.add_argument("--estimate", type=estimate_names, default=(),
                   help="sensor geometry to estimate with the robot, comma-separated: anchor, offset (drawstring)")
    p.add_argument("--models",
                   help="compare models instead of methods, on the same splits by pose, fitted with --method-of-models: "
                   "comma-separated geometric, dh, hayati, placement, compliance:JOINT+JOINT[:cad|basis], "
                   "compliance:all; the first is the reference of the paired differences; writes models.md, models.csv")
    p.add_argument("--method-of-models", default="lm", help="the estimator of --models (default lm)")
    add_unknowns_arguments(p, "; measured data only (not --simulate)")
    add_parallel_arguments(p)
    add_quiet_argument(p)
    return p


def compare_main(argv: Sequence[str] | None = None) -> int:
    """``compare.py ROBOT [--data CSV] [--trials N] [--out DIR] [--methods a,b] [--simulate KIND]``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args("compare", argv)
    if args.simulate and args.data:
        return fail("give either --data or --simulate, not both")
    if args.models is not None and args.simulate:
        return fail("--models compares on measured data: give --data, not --simulate")
    if args.models is not None and any(a == "--methods" or a.startswith("--methods=") for a in argv):
        return fail("--models fits every model with one method, --method-of-models (default lm): leave --methods out")
    if args.nominal and args.simulate:
        return fail("--nominal starts from one robot's own calibration: give --data, without --simulate")
    with quiet_progress(args.quiet):
        return run(lambda: _compare_models(args, argv) if args.models is not None else _compare(args, argv))


def _compare_models(args: argparse.Namespace, argv: list[str]) -> int:
    """``--models``: the models side by side on the same splits; models.md and models.csv."""
    from ..exceptions import CalibPinError
    from ..studies.model_comparison import compare_models

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise CalibPinError(f"{out}: the output folder is a file")
    outputs = Outputs(out, inputs=_inputs(args))
    for name in MODEL_OUTPUT_NAMES:
        outputs.check(out / name)
    if args.compliance:  # the loads (--payload-kg, ...) apply to every compliance model
        raise CalibPinError("with --models the compliant joints are in each model (compliance:joint_2+joint_3): "
                            "leave --compliance out")
    result = compare_models(args.robot, _data(args), models=args.models, method=args.method_of_models,
                            trials=args.trials, seed=args.seed, test_fraction=args.test_fraction,
                            parameters=args.model, setup=_setup(args), jobs=args.jobs, scheduler=args.scheduler,
                            payload_kg=args.payload_kg, payload_com_mm=args.payload_com_mm,
                            cable_tension_n=args.cable_tension_n, **unknowns_options(args))
    command = "python scripts/compare.py " + " ".join(argv)
    outputs.add(out / "models.md", lambda tmp: result.write_markdown(tmp, command))
    outputs.add(out / "models.csv", lambda tmp: result.write_csv(tmp))
    written = outputs.commit()
    print(result.format_table())
    for path in written:
        print(f"wrote {path}")
    return 0


def _compare(args: argparse.Namespace, argv: list[str]) -> int:
    from ..exceptions import CalibPinError
    from ..studies.checkpoint import Checkpoint, Interrupted
    from ..studies.comparison import compare

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise CalibPinError(f"{out}: the output folder is a file")
    refusal = Outputs(out, inputs=_inputs(args))
    for name in OUTPUT_NAMES:  # an input is never an output: refused before the trials
        refusal.check(out / name)
    if args.trials >= 10:
        print(f"comparing {len(args.methods)} methods over {args.trials} trials; this can take long "
              "(Ctrl-C stops; the finished trials are kept and the same command resumes)", file=sys.stderr, flush=True)
    try:
        result = compare(
            args.robot, None if args.simulate else _data(args), trials=args.trials, seed=args.seed,
            methods=args.methods if any(a == "--methods" or a.startswith("--methods=") for a in argv) else None,
            test_fraction=args.test_fraction, simulate_noise=args.simulate,
            noise_mm=args.noise_mm, poses=args.poses, jobs=args.jobs, scheduler=args.scheduler,
            checkpoint=out, notify=lambda line: print(line, flush=True), **compliance_options(args),
            parameters=args.model, setup=_setup(args), **unknowns_options(args),
        )
    except Interrupted as e:
        print(f"\n{one_line(str(e))}", file=sys.stderr)
        return INTERRUPTED_EXIT
    kept = Checkpoint(out, "trial")
    try:  # written before the table is printed: a closed pipe loses no file
        written = _write(result, out, "python scripts/compare.py " + " ".join(argv))
    except KeyboardInterrupt:  # while writing, which leaves nothing
        print(f"\nstopped by Ctrl-C while writing: nothing was written; {one_line(kept.kept(args.trials, args.trials))}",
              file=sys.stderr)
        return INTERRUPTED_EXIT
    except (OSError, CalibPinError) as e:  # a full disk: nothing was written, the trials are kept
        raise kept.unwritten(e, args.trials) from None
    Checkpoint(out).clear()
    print(result.format_table())
    for path in written:
        print(f"wrote {path}")
    return 0


def _data(args: argparse.Namespace) -> Any:
    """``--data`` as compare takes it: None, one file, or several (with their per-set options).

    As calibrate's (:func:`calib_pin.cli.calibrate.data_argument`).
    """
    from .calibrate import _data as calibrate_data

    return calibrate_data(args)


def _setup(args: argparse.Namespace) -> Any:
    """``--estimate`` as the set-up record every set gets (None without it)."""
    from ..sensors import setup_record

    return setup_record(estimate=args.estimate) if args.estimate else None


def _inputs(args: argparse.Namespace) -> dict[str, Any]:
    """The command's input files by label (never an output)."""
    from .calibrate import data_argument

    files = [data_argument(d)[0] for d in args.data or ()]
    sets = {"--data": files[0]} if len(files) == 1 else {f"--data {f}": f for f in files}
    return {**robot_inputs(args.robot), **sets, "--nominal": args.nominal}


def _write(result: Any, out: Path, command: str) -> list[Path]:
    """Write the tables and the figures together, or none.

    The figures are optional (:func:`calib_pin.util.optional.figures_or_warn`): without a
    working matplotlib, or when
    drawing fails, one warning line and the tables alone."""
    from ..exceptions import CalibPinError
    from ..util.optional import figures_or_warn

    tables = [(out / "table1.csv", lambda tmp: result.write_csv(tmp)),
              (out / "table1.md", lambda tmp: result.write_markdown(tmp, command))]
    drawers = figures_or_warn("figures", _figure_functions, FIGURES_HINT)
    if drawers is None:
        return _commit(out, tables)
    residual_figure, convergence_figure = drawers
    figures = [(out / "fig2_residuals.png", lambda tmp: residual_figure(result, tmp)),
               (out / "fig3_convergence.png", lambda tmp: convergence_figure(result, tmp))]
    try:
        return _commit(out, tables + figures)
    except (OSError, MemoryError, CalibPinError):
        raise  # a full disk (Outputs' OutputError): nothing was written
    except Exception as e:  # noqa: BLE001 - drawing failed: the tables alone
        print(f"warning: no figures: drawing failed ({type(e).__name__}: {e}) ({FIGURES_HINT})", file=sys.stderr)
        return _commit(out, tables)


#: The files compare --models writes in its --out folder.
MODEL_OUTPUT_NAMES = ("models.md", "models.csv")

#: The files compare writes in its --out folder.
OUTPUT_NAMES = ("table1.csv", "table1.md", "fig2_residuals.png", "fig3_convergence.png")

#: What the figures' warning line adds.
FIGURES_HINT = "the tables are written"


def _figure_functions() -> tuple[Any, Any]:
    """Fig. 2 and Fig. 3's drawing functions (importing matplotlib)."""
    from ..studies.comparison_figures import convergence_figure, residual_figure

    return residual_figure, convergence_figure


def _commit(out: Path, files: list) -> list[Path]:
    """Write ``files`` ((path, write(tmp)) pairs) all together, or none."""
    outputs = Outputs(out)
    for path, write in files:
        outputs.add(path, write)
    return outputs.commit()

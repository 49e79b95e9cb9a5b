"""``calibrate``: a measurement set in, report.json and the corrected URDF out."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..estimators import DEFAULT_METHOD, ESTIMATORS
from ..metrics import Metrics
from ..parameters import MODELS
from .common import OneLineParser, add_robot_arguments, estimate_names, fail, finite, fraction, positive_float, run
from .outputs import Outputs


def calibrate_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="calibrate.py",
        description="Calibrate a robot's kinematics from drawstring readings or marker positions and "
        "write the corrected URDF and a JSON report.",
    )
    add_robot_arguments(p, "default: the file's", "default: the file's")
    p.add_argument("--data", help="measurement set CSV (default: the robot's shipped set)")
    p.add_argument("--test-data", help="a separate validation session CSV: train on all of --data, test on this")
    p.add_argument("--method", default=DEFAULT_METHOD, help=f"estimator: {', '.join(ESTIMATORS)} (default {DEFAULT_METHOD})")
    p.add_argument("--test-fraction", type=fraction, default=0.2, help="share of poses held out for testing (default 0.2)")
    p.add_argument("--out", default="out", help="output folder (default ./out)")
    p.add_argument("--length-offset-mm", type=finite, help="sensor zero offset, mm")
    p.add_argument("--noise-mm", type=positive_float(100.0),
                   help="sensor noise (1 sigma) for the Kalman filters, mm (default: the file's, else 0.05)")
    p.add_argument("--loss", default="linear", help="linear (default), or a robust loss: huber, soft_l1, cauchy")
    p.add_argument("--model", choices=MODELS,
                   help="parameter model: dh (default with a DH table), hayati (dh with a tilt beta for parallel "
                   "axes), placement (6D offset per joint, any URDF; default without a DH table)")
    p.add_argument("--estimate", type=estimate_names, default=(),
                   help="drawstring geometry to estimate with the robot: anchor, offset or anchor,offset")
    p.add_argument("--analyze", action="store_true",
                   help="only print the identifiability report of the data's poses, estimate nothing")
    return p


def calibrate_main(argv: Sequence[str] | None = None) -> int:
    """``calibrate.py ROBOT [--data CSV] [--method NAME] [--seed N] [--test-fraction F] [--out DIR]``."""
    args = calibrate_parser().parse_args(argv)
    return run(lambda: _analyze(args) if args.analyze else _calibrate(args))


def _setup_options(args: argparse.Namespace) -> dict[str, Any]:
    return {"end_frame": args.end_frame, "anchor_mm": args.anchor_mm, "tool_mm": args.tool_mm,
            "length_offset_mm": args.length_offset_mm, "noise_mm": args.noise_mm, "parameters": args.model,
            "estimate": args.estimate}


def _analyze(args: argparse.Namespace) -> int:
    from ..identifiability import analyze
    from ..pipeline import prepare

    setup = prepare(args.robot, args.data, **_setup_options(args))
    print(f"{setup.chain.name}: {setup.data.describe_rows()} from {setup.data.source}, "
          f"{setup.params.name} model, {setup.problem.model.describe()}")
    print(analyze(setup.problem).report())
    print("the estimators move only the identifiable directions: the deviations along the blind "
          "ones above stay at zero in the export")
    return 0


def table(metrics: dict[str, dict[str, Metrics]]) -> str:
    """The before/after metrics as a fixed-width table, [mm]."""
    lines = [f"{'':14s}{'RMSE mm':>10s}{'mean mm':>10s}{'max mm':>10s}"]
    for split, stages in metrics.items():
        for stage, m in stages.items():
            lines.append(f"{split + ' ' + stage:14s}{m.rmse_mm:10.4f}{m.mean_mm:10.4f}{m.max_mm:10.4f}")
    return "\n".join(lines)


def _calibrate(args: argparse.Namespace) -> int:
    from ..pipeline import calibrate

    result = calibrate(args.robot, args.data, method=args.method, seed=args.seed,
                       test_fraction=args.test_fraction, test_data=args.test_data, loss=args.loss,
                       progress=_announce, **_setup_options(args))
    out = Outputs(Path(args.out))
    report = result.report()
    urdf_path = out.folder / f"{result.chain.name}_calibrated.urdf"
    refused = (_unsupported(report) or result.sanity_error()) if result.kinematic else None
    report["urdf"] = str(urdf_path) if result.kinematic and not refused else None
    report["urdf_refused"] = refused or (None if result.kinematic else
                                         f"{result.method} learns a correction of the readings, not kinematic parameters")
    if report["urdf"]:
        out.add(urdf_path, lambda tmp: result.to_urdf(tmp))
    out.add(out.folder / "report.json", lambda tmp: tmp.write_text(json.dumps(report, indent=2, allow_nan=False) + "\n"))
    written = out.commit()  # all together or none; a stale URDF of an earlier run is removed
    if not report["urdf"] and urdf_path.exists():
        urdf_path.unlink()
    if refused:
        return fail(f"{refused} (report: {out.folder / 'report.json'})")
    _summary(result, report)
    for path in written:
        print(f"wrote {path}")
    return 0


#: Rows from which a calibration is announced on stderr before it starts (it may take minutes).
LONG_ROWS = 5000


def _announce(setup: Any) -> None:
    if len(setup.data) >= LONG_ROWS:
        print(f"calibrating {len(setup.data)} rows with {setup.problem.n_params} unknowns; "
              "this can take minutes (Ctrl-C stops, writing nothing)", file=sys.stderr, flush=True)


def _unsupported(report: dict[str, Any]) -> str | None:
    """Why the training poses cannot support a URDF (their rank is below half the unknowns), or None;
    the reason is added to ``report["warnings"]``."""
    ident = report["identifiability"]
    if 2 * ident["rank"] >= ident["unknowns"]:
        return None
    why = (f"the training poses identify only {ident['rank']} of {ident['unknowns']} directions "
           "(identical or too few distinct poses?): no URDF written; measure more varied poses")
    report["warnings"].append(why)
    return why


def _summary(result: Any, report: dict[str, Any]) -> None:
    n_train, n_test = len(result.train), len(result.test)
    test = f"test rows from {result.test_source}" if result.test_source else f"{n_test} test rows"
    print(f"{result.chain.name}: {result.data.describe_rows()} from {result.data.source} "
          f"({n_train} train, {test}, seed {result.seed}), {result.model_name} model, method {result.method}")
    print(f"error per row: {result.problem.model.error_name}")
    print(table(result.metrics))
    shown = ", ".join(f"{k} {v:+.3f}" for k, v in result.sensor_corrections.items() if not k.startswith("marker"))
    if result.sensor_corrections:
        print(f"sensor geometry estimated: {shown or 'marker points'} (corrections; all in report.json)")
    est = result.estimate
    print(f"estimation: {est.time_s:.3f} s, {est.iterations} iterations ({est.message})")
    u = report["uncertainty"]
    if u:
        sigma = u["flange_position_1sigma_mm"]
        print(f"uncertainty: noise {u['noise_estimate_mm']:.4f} mm per value; flange position (1 sigma) over "
              f"{sigma['poses']} workspace poses: RMS {sigma['rms']:.4f} mm, max {sigma['max']:.4f} mm")
    ident = report["identifiability"]
    print(f"identifiable: {ident['rank']} of {ident['unknowns']} directions on the training poses; "
          f"not identifiable: {', '.join(ident['unidentifiable']) or 'none'}; {len(ident['combinations'])} "
          "combination(s) only together (--analyze lists them); blind directions stay at zero")
    if result.loss != "linear":
        lines = ", ".join(str(line) for line in report["outlier_lines"]) or "none"
        print(f"outliers ({result.loss} loss): {len(result.outlier_rows)} training rows, file lines {lines}")
    after, before = result.metrics["train"]["after"], result.metrics["train"]["before"]
    if after.rmse_mm > before.rmse_mm:
        print("warning: the calibrated model fits the training poses worse than the nominal one")
    for warning in result.warnings:
        print(f"warning: {warning}")
    if not result.kinematic:
        print(f"no URDF written: {result.method} learns a correction of the readings, not kinematic parameters")

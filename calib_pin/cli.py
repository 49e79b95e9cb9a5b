"""Command line: ``calibrate``, ``simulate`` and ``compare``.

Exit status 0 on success, 2 on bad input with a one-line message on stderr (never a
traceback for a user's mistake).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from .calibration import calibrate, check_estimate
from .estimators import DEFAULT_METHOD, ESTIMATORS
from .exceptions import CalibPinError
from .measurements import write_measurements
from .metrics import Metrics
from .model import load_chain
from .errors import CABLE_EXTRAS
from .parameters import MODELS, parameter_model
from .simulate import DEFAULT_ANCHOR_MM, DEFAULT_TOOL_MM, NOISE_KINDS, simulate


class OneLineParser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def _xyz(text: str) -> tuple[float, float, float]:
    parts = [p for p in text.replace(",", " ").split() if p]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not np.all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"expected 3 numbers 'x,y,z' in mm, got '{text}'")
    return values  # type: ignore[return-value]


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0.0 <= value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1), got '{text}'")
    return value


def _positive(kind: type) -> Callable[[str], float]:
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            value = -1
        if not value >= 0 or not np.isfinite(value):
            raise argparse.ArgumentTypeError(f"expected a non-negative {kind.__name__}, got '{text}'")
        return value

    return parse


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got '{text}'")
    return value


def _report_errors(action: Callable[[], int], target: str) -> int:
    """Run a command's work; a user's mistake becomes one line on stderr and exit 2."""
    try:
        return action()
    except CalibPinError as e:
        print(f"error: {e}", file=sys.stderr)
    except BrokenPipeError:
        print("error: standard output was closed (rows already written are kept)", file=sys.stderr)
    except OSError as e:
        print(f"error: cannot write {target}: {e.strerror or e}", file=sys.stderr)
    return 2


def _add_robot_arguments(p: argparse.ArgumentParser, anchor_default: str, tool_default: str) -> None:
    p.add_argument("robot", help="robot name (irb120, or an example-robot-data name) or URDF path")
    p.add_argument("--end-frame", help="end frame (default: the data file's, else tool0)")
    p.add_argument("--seed", type=_positive(int), default=0, help="seed, a whole number >= 0 (default 0)")
    p.add_argument("--anchor-mm", type=_xyz, help=f"sensor point P0 in the base frame, 'x,y,z' mm ({anchor_default})")
    p.add_argument("--tool-mm", type=_xyz, help=f"cable hook point in the end frame, 'x,y,z' mm ({tool_default})")


def _rows(data) -> str:
    if data.kind == "position" and data.pose_ids is not None:
        return f"{len(data)} positions at {len(np.unique(data.pose_ids))} poses"
    return f"{len(data)} poses"


def _table(metrics: dict[str, dict[str, Metrics]]) -> str:
    lines = [f"{'':14s}{'RMSE mm':>10s}{'mean mm':>10s}{'max mm':>10s}"]
    for split, stages in metrics.items():
        for stage, m in stages.items():
            label = f"{split} {stage}"
            lines.append(f"{label:14s}{m.rmse_mm:10.4f}{m.mean_mm:10.4f}{m.max_mm:10.4f}")
    return "\n".join(lines)


def _extras(text: str) -> tuple[str, ...]:
    try:
        names = check_estimate(text.split(","))
    except CalibPinError as e:
        raise argparse.ArgumentTypeError(f"{e}, comma-separated") from None
    if not names:
        raise argparse.ArgumentTypeError(f"cannot estimate '{text}' (valid: {', '.join(CABLE_EXTRAS)}, comma-separated)")
    return names


def calibrate_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="calibrate.py",
        description="Calibrate a robot's kinematics from drawstring readings and write the "
        "corrected URDF and a JSON report.",
    )
    _add_robot_arguments(p, "default: the file's", "default: the file's")
    p.add_argument("--data", help="measurement set CSV (default: the robot's shipped set)")
    p.add_argument(
        "--method", default=DEFAULT_METHOD,
        help=f"estimator: {', '.join(ESTIMATORS)} (default {DEFAULT_METHOD})",
    )
    p.add_argument(
        "--test-fraction", type=_fraction, default=0.2,
        help="share of rows held out for testing (default 0.2)",
    )
    p.add_argument("--out", default="out", help="output folder (default ./out)")
    p.add_argument("--length-offset-mm", type=_finite, help="sensor zero offset, mm")
    p.add_argument(
        "--noise-mm", type=_positive(float),
        help="sensor noise (1 sigma) for the EKF, mm (default: the file's, else 0.05)",
    )
    p.add_argument("--loss", default="linear",
                   help="linear (default), or a robust loss: huber, soft_l1, cauchy")
    p.add_argument("--model", choices=MODELS,
                   help="parameter model: dh (default with a DH table), hayati (dh with a tilt beta "
                   "for parallel axes), placement (6D offset per joint, any URDF; default without a DH table)")
    p.add_argument("--estimate", type=_extras, default=(),
                   help="drawstring geometry to estimate with the robot: anchor, offset or anchor,offset")
    p.add_argument("--analyze", action="store_true",
                   help="only print the identifiability report of the data's poses, estimate nothing")
    return p


def calibrate_main(argv: Sequence[str] | None = None) -> int:
    """``calibrate.py ROBOT [--data CSV] [--method NAME] [--seed N] [--test-fraction F] [--out DIR]``."""
    args = calibrate_parser().parse_args(argv)
    return _report_errors(lambda: _calibrate(args), args.out)


def _analyze(args: argparse.Namespace) -> int:
    from .calibration import prepare
    from .identifiability import analyze

    setup = prepare(args.robot, args.data, end_frame=args.end_frame, anchor_mm=args.anchor_mm,
                    tool_mm=args.tool_mm, length_offset_mm=args.length_offset_mm,
                    model=args.model, estimate=args.estimate)
    if setup.data.kind == "position":
        sensor = "positions of markers, device frame and marker points estimated"
    else:
        known = [p for p in ("anchor", "offset") if p not in args.estimate]
        sensor = "drawstring sensor, " + (f"{' and '.join(known)} known" if known else "nothing known")
        if args.estimate:
            sensor += f", {' and '.join(args.estimate)} estimated"
    print(f"{setup.chain.name}: {_rows(setup.data)} from {setup.data.source}, "
          f"{setup.model_name} model, {sensor}")
    print(analyze(setup.problem).report())
    print("the estimators move only the identifiable directions: the deviations along the blind "
          "ones above stay at zero in the export")
    return 0


def _calibrate(args: argparse.Namespace) -> int:
    if args.analyze:
        return _analyze(args)
    result = calibrate(
        args.robot,
        args.data,
        method=args.method,
        seed=args.seed,
        test_fraction=args.test_fraction,
        end_frame=args.end_frame,
        anchor_mm=args.anchor_mm,
        tool_mm=args.tool_mm,
        length_offset_mm=args.length_offset_mm,
        noise_mm=args.noise_mm,
        loss=args.loss,
        model=args.model,
        estimate=args.estimate,
    )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    report = result.report()
    report_path = out / "report.json"
    urdf_path = out / f"{result.chain.name}_calibrated.urdf"
    urdf, refused = None, None
    if result.kinematic:
        try:
            result.check_sanity()
            urdf = urdf_path
        except CalibPinError as e:
            refused = str(e)
    report["urdf"] = str(urdf) if urdf else None
    report_path.write_text(json.dumps(report, indent=2) + "\n")  # kept even when the URDF is refused
    if refused:
        print(f"error: {refused} (report: {report_path})", file=sys.stderr)
        return 2
    if urdf:
        result.to_urdf(urdf)
    n_train, n_test = len(result.train), len(result.test)
    print(
        f"{result.chain.name}: {_rows(result.data)} from {result.data.source} "
        f"({n_train} train, {n_test} test rows, seed {result.seed}), {result.model_name} model, "
        f"method {result.method}"
    )
    if result.data.kind == "position":
        print("errors are Euclidean position errors in the device frame")
    print(_table(result.metrics))
    if result.sensor_corrections:
        shown = ", ".join(f"{k} {v:+.3f}" for k, v in result.sensor_corrections.items()
                          if not k.startswith("marker"))
        print(f"sensor geometry estimated: {shown or 'marker points'} (corrections; all in report.json)")
    est = result.estimate
    print(f"estimation: {est.time_s:.3f} s, {est.iterations} iterations ({est.message})")
    if result.kinematic:
        u = report["uncertainty"]
        print(f"uncertainty: noise {u['noise_estimate_mm']:.4f} mm per value; flange position "
              f"(1 sigma) over {u['flange_position_1sigma_mm']['poses']} workspace poses: RMS "
              f"{u['flange_position_1sigma_mm']['rms']:.4f} mm, max {u['flange_position_1sigma_mm']['max']:.4f} mm")
    ident = report["identifiability"]
    blind = ", ".join(ident["unidentifiable"]) or "none"
    print(f"identifiable: {ident['rank']} of {ident['unknowns']} directions on the training poses; "
          f"not identifiable: {blind}; {len(ident['combinations'])} combination(s) only together "
          "(--analyze lists them); blind directions stay at zero")
    if result.loss != "linear":
        lines = ", ".join(str(line) for line in report["outlier_lines"]) or "none"
        print(f"outliers ({result.loss} loss): {len(result.outlier_rows)} training rows, file lines {lines}")
    after, before = result.metrics["train"]["after"], result.metrics["train"]["before"]
    if after.rmse_mm > before.rmse_mm:
        print("warning: the calibrated model fits the training poses worse than the nominal one")
    if urdf:
        print(f"wrote {urdf}")
    else:
        print(f"no URDF written: {result.method} learns a correction of the readings, not "
              "kinematic parameters")
    print(f"wrote {report_path}")
    return 0


def simulate_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="simulate.py",
        description="Simulate a drawstring measurement set with known true deviations; "
        "writes FILE.csv and FILE.truth.json.",
    )
    _add_robot_arguments(p, "default 600,200,-100", "default 0,0,50")
    p.add_argument("--poses", type=int, default=120, help="number of poses (default 120)")
    p.add_argument("--noise-mm", type=_positive(float), default=0.05, help="reading noise, 1 sigma, mm (default 0.05)")
    p.add_argument(
        "--noise-kind", choices=NOISE_KINDS, default="gauss",
        help="gauss, student (t, 3 dof, heavy tails) or outliers (gauss + 5%% gross errors "
        "of 1-3 mm) (default gauss)",
    )
    p.add_argument(
        "--nominal-rmse-mm", type=_positive(float), default=2.0,
        help="reading error of the nominal model the true deviations cause, mm (default 2)",
    )
    p.add_argument("--offset-mm", type=_finite, default=0.0, help="sensor zero offset, mm (default 0)")
    p.add_argument("--poses-file", help="simulate at the poses of this pose list (make_poses.py) instead of random ones")
    p.add_argument("--model", choices=MODELS,
                   help="parameter model of the true deviations (default dh with a DH table, else placement)")
    p.add_argument("--out", required=True, help="output CSV")
    return p


def simulate_main(argv: Sequence[str] | None = None) -> int:
    """``simulate.py ROBOT --poses N --seed S --noise-mm SIGMA --out FILE.csv``."""
    args = simulate_parser().parse_args(argv)
    if args.poses < 1:
        print("error: --poses must be at least 1", file=sys.stderr)
        return 2
    return _report_errors(lambda: _simulate(args), args.out)


def _simulate(args: argparse.Namespace) -> int:
    out = Path(args.out)
    truth_path = out.with_name(out.name.removesuffix(".csv") + ".truth.json")
    chain = load_chain(args.robot, args.end_frame)
    model = args.model or ("dh" if chain.description.dh is not None else "placement")
    params = parameter_model(chain, model)
    kind = {"dh": "DH", "hayati": "Hayati", "placement": "joint-placement"}[model]
    poses = None
    if args.poses_file:
        from .collect import read_pose_list

        poses = read_pose_list(args.poses_file, chain).q
    data, truth = simulate(
        chain, params, args.poses, args.seed,
        noise_mm=args.noise_mm,
        nominal_rmse_mm=args.nominal_rmse_mm,
        anchor_mm=args.anchor_mm or DEFAULT_ANCHOR_MM,
        tool_mm=args.tool_mm or DEFAULT_TOOL_MM,
        offset_mm=args.offset_mm,
        noise_kind=args.noise_kind,
        poses=poses,
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    write_measurements(out, data)
    truth.to_json(truth_path)
    print(f"{chain.name}: {len(data)} poses, {kind} deviations (seed {args.seed}), "
          f"noise {args.noise_mm:g} mm ({args.noise_kind})")
    print(f"wrote {out}")
    print(f"wrote {truth_path}")
    return 0


def _methods(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in ESTIMATORS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown method '{unknown[0] if unknown else text}' (valid: {', '.join(ESTIMATORS)})"
        )
    return names


def _at_least_one(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got '{text}'")
    return value


def compare_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="compare.py",
        description="Run the estimators side by side on one data set and split (the paper's "
        "Table I, Fig. 2, Fig. 3); writes table1.csv, table1.md and two PNG figures.",
    )
    p.add_argument("robot", help="robot name (irb120) or URDF path")
    p.add_argument("--data", help="measurement set CSV (default: the robot's shipped set)")
    p.add_argument("--trials", type=_at_least_one, default=1,
                   help="repeat over N seeded splits (or simulated sets): mean ± sd (default 1)")
    p.add_argument("--out", default="out/compare", help="output folder (default ./out/compare)")
    p.add_argument("--methods", type=_methods, default=list(ESTIMATORS),
                   help=f"comma-separated methods (default all: {','.join(ESTIMATORS)})")
    p.add_argument("--seed", type=_positive(int), default=0, help="first seed (default 0)")
    p.add_argument("--test-fraction", type=_fraction, default=0.2, help="held-out share (default 0.2)")
    p.add_argument("--simulate", choices=NOISE_KINDS,
                   help="run on seeded simulated sets with this noise kind instead of --data")
    p.add_argument("--noise-mm", type=_positive(float), default=0.05,
                   help="noise of simulated sets, 1 sigma, mm (default 0.05)")
    p.add_argument("--poses", type=_at_least_one, default=120, help="poses of simulated sets (default 120)")
    return p


def compare_main(argv: Sequence[str] | None = None) -> int:
    """``compare.py ROBOT [--data CSV] [--trials N] [--out DIR] [--methods a,b] [--simulate KIND]``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = compare_parser().parse_args(argv)
    if args.simulate and args.data:
        print("error: give either --data or --simulate, not both", file=sys.stderr)
        return 2
    return _report_errors(lambda: _compare(args, argv), args.out)


def _compare(args: argparse.Namespace, argv: list[str]) -> int:
    from .comparison import compare
    from .figures import convergence_figure, residual_figure

    result = compare(
        args.robot, args.data, methods=args.methods, trials=args.trials, seed=args.seed,
        test_fraction=args.test_fraction, simulate_noise=args.simulate,
        noise_mm=args.noise_mm, poses=args.poses,
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


def main(argv: Sequence[str] | None = None) -> int:
    """``calib-pin calibrate|simulate|compare|collect|make-poses ...``."""
    from .collect_cli import collect_main, make_poses_main

    argv = list(sys.argv[1:] if argv is None else argv)
    commands = {"calibrate": calibrate_main, "simulate": simulate_main, "compare": compare_main,
                "collect": collect_main, "make-poses": make_poses_main}
    if not argv or argv[0] not in commands:
        print(f"usage: calib-pin {{{','.join(commands)}}} ... (see calib-pin calibrate --help)",
              file=sys.stderr)
        return 2
    return commands[argv[0]](argv[1:])

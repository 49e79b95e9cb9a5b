"""``simulate``: a drawstring measurement set with known true deviations, and its truth."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..exceptions import CalibPinError
from ..parameters import MODELS
from ..simulation import NOISE_KINDS
from .common import (
    OneLineParser,
    add_compliance_arguments,
    add_robot_arguments,
    count,
    non_negative,
    run,
)
from .outputs import Outputs, add_force_argument, robot_inputs

#: Most poses one simulated set may hold (a larger one would not fit in memory here).
MAX_POSES = 1_000_000


def simulate_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="simulate.py",
        description="Simulate a drawstring measurement set with known true deviations; "
        "writes FILE.csv and FILE.truth.json.",
    )
    add_robot_arguments(p, "default 600,200,-100", "default 0,0,50", skip=("estimate",),
                        defaults={"length_offset_mm": 0.0})
    p.add_argument("--poses", type=count(MAX_POSES), default=120, help="number of poses (default 120)")
    p.add_argument("--noise-mm", type=non_negative(float, 100.0), default=0.05,
                   help="reading noise, 1 sigma, mm (default 0.05; 0: a noise-free set, e.g. the values of a dry run)")
    p.add_argument("--noise-kind", choices=NOISE_KINDS, default="gauss",
                   help="gauss, student (t, 3 dof, heavy tails) or outliers (gauss + 5%% gross errors "
                   "of 1-3 mm) (default gauss)")
    p.add_argument("--nominal-rmse-mm", type=non_negative(float, 1000.0), default=2.0,
                   help="reading error of the nominal model the true deviations cause, mm (default 2)")
    p.add_argument("--poses-file", help="simulate at the poses of this pose list (make_poses.py) instead of random ones")
    p.add_argument("--model", choices=MODELS,
                   help="parameter model of the true deviations (default dh with a DH table, else placement)")
    add_compliance_arguments(p, "simulate")
    p.add_argument("--true-compliance-urad-per-nm", type=_values,
                   help="true compliance of each --compliance joint, comma-separated, urad/Nm (e.g. 25,40)")
    p.add_argument("--out", required=True, help="output CSV (FILE.truth.json is written beside it)")
    add_force_argument(p, "FILE.csv or FILE.truth.json")
    return p


def _values(text: str) -> tuple[float, ...]:
    """Comma-separated non-negative numbers."""
    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        values = ()
    if not values or not all(0 <= v < 1e9 for v in values):
        raise argparse.ArgumentTypeError(f"expected non-negative numbers 'a,b', got '{text[:40]}'")
    return values


def simulate_main(argv: Sequence[str] | None = None) -> int:
    """``simulate.py ROBOT --poses N --seed S --noise-mm SIGMA --out FILE.csv``."""
    args = simulate_parser().parse_args(argv)
    return run(lambda: _simulate(args))


def _simulate(args: argparse.Namespace) -> int:
    from ..hardware.session import read_pose_list
    from ..measurements import write_measurements
    from ..parameters import parameter_model
    from ..robot import load_chain
    from ..robot.deflection import compliance_spec
    from ..simulation import DEFAULT_ANCHOR_MM, DEFAULT_TOOL_MM, simulate

    out = Path(args.out)
    if not out.name or out.is_dir():
        raise OSError(f"--out '{args.out}' is not a file name")
    truth_path = out.with_name(out.name.removesuffix(".csv") + ".truth.json")
    outputs = Outputs(out.parent, force=args.force, inputs={**robot_inputs(args.robot),
                                                            "--poses-file": args.poses_file})
    for path in (out, truth_path):  # refused before the work, and again when written
        outputs.check(path)
    chain = load_chain(args.robot, args.end_frame)
    params = parameter_model(chain, args.model)
    kind = {"dh": "DH", "hayati": "Hayati", "placement": "joint-placement"}[params.name]
    poses = read_pose_list(args.poses_file, chain).q if args.poses_file else None
    spec = compliance_spec(chain, args.compliance, args.payload_kg, args.payload_com_mm, args.cable_tension_n)
    true_c = None if args.true_compliance_urad_per_nm is None else np.array(args.true_compliance_urad_per_nm) * 1e-6
    data, truth = simulate(
        chain, params, args.poses, args.seed, noise_mm=args.noise_mm, nominal_rmse_mm=args.nominal_rmse_mm,
        anchor_mm=args.anchor_mm or DEFAULT_ANCHOR_MM, tool_mm=args.tool_mm or DEFAULT_TOOL_MM,
        length_offset_mm=args.length_offset_mm, noise_kind=args.noise_kind, poses=poses,
        compliance=spec, true_compliance=true_c,
    )
    if not (data.lengths > 0).all():
        raise CalibPinError(f"a simulated length is {data.lengths.min() * 1e3:.3f} mm, not positive: "
                            "--length-offset-mm or the sensor geometry is wrong")
    outputs.add(out, lambda tmp: write_measurements(tmp, data))
    outputs.add(truth_path, lambda tmp: truth.to_json(tmp))
    written = outputs.commit()
    print(f"{chain.name}: {len(data)} poses, {kind} deviations (seed {args.seed}), "
          f"noise {args.noise_mm:g} mm ({args.noise_kind})")
    for path in written:
        print(f"wrote {path}")
    return 0

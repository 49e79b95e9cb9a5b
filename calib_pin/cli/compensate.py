"""``compensate``: a robot program's joint targets in, the commands for the real arm out.

The targets were computed with the nominal model; each corrected target puts the
calibrated arm's end frame (geometry and joint deflection) where the nominal model puts
it, to 1 um and 1 urad (:meth:`calib_pin.compensation.CalibratedRobot.compensate`).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..compensation import CalibratedRobot, Compensation
from ..exceptions import DataError
from ..export.outputs import Outputs, robot_inputs
from . import parse_args
from .common import run
from .outputs import add_force_argument


def compensate_parser() -> argparse.ArgumentParser:
    """The ``calib-pin compensate`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "compensate")


def add_compensate_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """compensate's arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = ("Correct a robot program's joint targets (computed with the nominal model) so that the "
                     "calibrated arm, deflection included, reaches the nominal end-frame poses.")
    p.add_argument("robot", help="robot name (irb120, ...) or URDF path; must be the calibration's")
    p.add_argument("--calibration", required=True,
                   help="folder of <robot>_calibration.json (the calibrate --out folder), or the file")
    p.add_argument("--targets", required=True,
                   help="joint targets CSV: q1_deg, ..., (optional pose column), as a pose list or measurement set")
    p.add_argument("--out", required=True, help="corrected targets CSV (same columns, plus the remaining error)")
    p.add_argument("--with-cable", action="store_true",
                   help="keep the drawstring's pull of the calibration in the deflection (default: the arm without it)")
    add_force_argument(p, "--out file")
    return p


def compensate_main(argv: Sequence[str] | None = None) -> int:
    """``compensate.py ROBOT --calibration DIR --targets CSV --out CSV``."""
    args = parse_args("compensate", argv)
    return run(lambda: _compensate(args))


def _compensate(args: argparse.Namespace) -> int:
    from .. import __version__
    from ..export.calibration_file import find_calibration, load_calibration
    from ..measurements.csv_writer import write_compensated
    from ..measurements.pose_list import read_pose_list

    out = Outputs(Path(args.out).parent, force=args.force,
                  inputs={**robot_inputs(args.robot), "--calibration": args.calibration, "--targets": args.targets})
    out.check(args.out)  # before the work; a calibration folder's file is checked once found
    source = find_calibration(Path(args.calibration))
    out.inputs["--calibration"] = source
    robot = load_calibration(source, args.robot, cable=args.with_cable)
    chain = robot.chain
    targets = read_pose_list(args.targets, chain)
    if targets.end_frame and targets.end_frame != chain.end_frame:
        raise DataError(targets.source, f"targets of end frame '{targets.end_frame}', the calibration's is "
                        f"'{chain.end_frame}'", None, "end_frame")
    pose_ids = targets.pose_ids if targets.pose_ids is not None else np.arange(1, len(targets) + 1)
    rows = np.sort(np.unique(pose_ids, return_index=True)[1])  # one row per pose
    q_nominal = targets.q[rows]
    result = robot.solve(q_nominal)
    for k, problem in enumerate(result.problems):
        if problem:
            line = int(targets.lines[rows[k]]) if targets.lines is not None else None
            raise DataError(targets.source, f"pose {pose_ids[rows[k]]}: {problem}", line)
    own = {k: v for k, v in targets.notes.items() if k != "compensated"}  # the targets' own notes, kept
    notes = {**own, "robot": chain.name, "end_frame": chain.end_frame,
             "compensated": f"{source.name} (calib-pin {__version__}), targets {Path(targets.source).name}"}
    extra = {name: column[rows] for name, column in targets.extra.items()}  # a program's speed, zone, name
    out.add(Path(args.out), lambda tmp: write_compensated(tmp, result.q, pose_ids[rows], result.position_error_m,
                                                        result.orientation_error_rad, notes, extra))
    written = out.commit()
    _summary(robot, q_nominal, result)
    if extra:
        print(f"columns {', '.join(extra)} of {Path(targets.source).name}: copied to the output as they were")
    for path in written:
        print(f"wrote {path}")
    return 0


def _summary(robot: CalibratedRobot, q_nominal: np.ndarray, result: Compensation) -> None:
    """What compensation changed and what is left, for people."""
    real = robot.forward(q_nominal)
    nominal = robot.nominal(q_nominal)
    off = np.array([np.linalg.norm(r.translation - n.translation) for r, n in zip(real, nominal, strict=True)]) * 1e3
    change = np.rad2deg(np.abs(result.q - q_nominal)).max(axis=1)
    print(f"{robot.chain.name}: {len(q_nominal)} targets compensated in {result.iterations} iterations "
          f"({'geometry and deflection of ' + ', '.join(robot.deflection.spec.joints) if robot.deflection else 'geometry'})")
    print(f"uncompensated, the calibrated arm misses the nominal end frame by {off.mean():.3f} mm mean, {off.max():.3f} mm max")
    print(f"largest joint correction per target: {change.mean():.4f} deg mean, {change.max():.4f} deg max")
    print(f"remaining: position {result.position_error_m.max() * 1e6:.2g} um max, "
          f"orientation {result.orientation_error_rad.max() * 1e6:.2g} urad max")

"""``compensate``: a robot program's joint targets in, the commands for the real arm out.

The targets were computed with the nominal model; each corrected target puts the
calibrated arm's end frame (geometry and joint deflection) where the nominal model puts
it, to 1 um and 1 urad (:meth:`calib_pin.export.compensation.CalibratedRobot.solve`). Each target
gets a status: ``ok``, ``position-only`` (near a singularity or a joint limit: the position
met, the orientation residual reported) or ``refused`` (with the reason; left out of the
program, named in it). ``--format`` writes the program as calib-pin's CSV or in a
controller's language (:mod:`calib_pin.export.programs`).

Exit codes: 0 every target ok; 3 some targets position-only, none refused; 4 some targets
refused (the others written); 2 bad input (nothing written); 130 Ctrl-C.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import CalibPinError, DataError
from ..export.compensation import OK, POSITION_ONLY, REFUSED, CalibratedRobot, Compensation
from ..export.programs import FORMATS, PROGRAMS, Program, identifier, program_files, program_paths
from ..robot.description import robot_inputs
from ..sensors.setup import xyz_mm
from ..util.outputs import Outputs
from . import parse_args
from .common import positive_float, run, warn
from .outputs import add_force_argument

if TYPE_CHECKING:
    from ..measurements import MeasurementSet


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
    p.add_argument("--nominal", help="the model the targets were computed with, if not the catalogue URDF: a "
                   "calib-pin calibration file (or the calibrate --out folder holding it) or a UR "
                   "default_kinematics.yaml (e.g. the controller's factory "
                   "calibration); its geometry only")
    p.add_argument("--format", choices=FORMATS, default="csv",
                   help="csv (calib-pin's pose list, default), rapid (ABB .mod), krl (KUKA .src + .dat), "
                   "urscript (Universal Robots .script); the suffix is added to --out when it has none")
    p.add_argument("--speed-rad-s", type=positive_float(10.0), default=None,
                   help="urscript: movej joint speed v= [rad/s] (default 1.05, UR's own)")
    p.add_argument("--accel-rad-s2", type=positive_float(100.0), default=None,
                   help="urscript: movej joint acceleration a= [rad/s^2] (default 1.4, UR's own)")
    p.add_argument("--tcp-mm", type=xyz_mm, metavar="X,Y,Z",
                   help="the point of the end frame the program works with, mm: each target where the calibration "
                   "does not determine it is named (default: the points calibrate --tcp-mm named)")
    add_force_argument(p, "--out file")
    p.epilog = ("exit codes: 0 every target ok; 3 some targets position-only (position met, orientation "
                "residual reported), none refused; 4 some targets refused (the others written); 2 bad input")
    return p


#: Exit codes: every target ok; some position-only (none refused); some refused.
EXIT_OK, EXIT_POSITION_ONLY, EXIT_REFUSED = 0, 3, 4


def compensate_main(argv: Sequence[str] | None = None) -> int:
    """``compensate.py ROBOT --calibration DIR --targets CSV --out CSV``."""
    args = parse_args("compensate", argv)
    return run(lambda: _compensate(args))


def _compensate(args: argparse.Namespace) -> int:
    from ..export.calibration_file import find_calibration, load_calibration
    from ..measurements.csv_writer import write_compensated
    from ..measurements.pose_list import read_pose_list
    from ..util.version import package_version

    if args.format != "urscript" and (args.speed_rad_s is not None or args.accel_rad_s2 is not None):
        raise CalibPinError("--speed-rad-s and --accel-rad-s2 are for --format urscript")
    paths = [Path(args.out)] if args.format == "csv" else program_paths(args.format, Path(args.out))
    name = identifier(paths[0].stem)
    if args.format == "krl" and name != paths[0].stem:
        raise CalibPinError(f"--out {args.out}: KRL names the program after its file: the stem must be a KRL name "
                            f"(a letter, then letters, digits or _, at most 24, not a keyword), e.g. {name}")
    out = Outputs(Path(args.out).parent, force=args.force,
                  inputs={**robot_inputs(args.robot), "--calibration": args.calibration, "--targets": args.targets,
                          "--nominal": args.nominal})
    for path in paths:
        out.check(path)  # before the work; a calibration folder's file is checked once found
    source = find_calibration(Path(args.calibration))
    out.inputs["--calibration"] = source
    robot = load_calibration(source, args.robot, cable=args.with_cable)
    chain = robot.chain
    reference = None
    if args.nominal is not None:
        from ..calibration.start import load_start

        reference = load_start(Path(args.nominal), chain, robot.params)
        robot.set_reference(reference.robot_x)
    targets = read_pose_list(args.targets, chain)
    _refuse_compensated(targets)
    if targets.end_frame and targets.end_frame != chain.end_frame:
        raise DataError(targets.source, f"targets of end frame '{targets.end_frame}', the calibration's is "
                        f"'{chain.end_frame}'", None, "end_frame")
    pose_ids = targets.pose_ids if targets.pose_ids is not None else np.arange(1, len(targets) + 1)
    rows = np.sort(np.unique(pose_ids, return_index=True)[1])  # one row per pose
    if args.format != "csv":  # a program named like a target of its own, or a built-in it calls
        try:
            PROGRAMS[args.format].check(name, pose_ids[rows])
        except CalibPinError as e:
            raise CalibPinError(f"--out {args.out}: {e}") from e
    q_nominal = targets.q[rows]
    result = robot.solve(q_nominal)
    kept = np.array([s != REFUSED for s in result.status], dtype=bool)

    def where(k: int) -> str:
        line = f" (line {int(targets.lines[rows[k]])})" if targets.lines is not None else ""
        return f"pose {pose_ids[rows[k]]}{line}"

    refused = {f"refused_pose_{pose_ids[rows[k]]}": f"{where(int(k))}: {result.reasons[k]}"
               for k in np.flatnonzero(~kept)}
    own = {k: v for k, v in targets.notes.items()  # the targets' own notes, kept
           if k != "compensated" and not k.startswith("refused_pose_")}
    compensated = f"{source.name} (calib-pin {package_version()}), targets {Path(targets.source).name}"
    if reference is not None:
        compensated += f" of the model {reference.describe()}"
    notes = {**own, "robot": chain.name, "end_frame": chain.end_frame, "compensated": compensated, **refused}
    extra = {name: column[rows][kept] for name, column in targets.extra.items()}  # a program's speed, zone, name
    if args.format == "csv":
        status = {"status": np.array(result.status, dtype=object)[kept]}
        out.add(paths[0], lambda tmp: write_compensated(
            tmp, result.q[kept], pose_ids[rows][kept], result.position_error_m[kept],
            result.orientation_error_rad[kept], notes, {**extra, **status}))
    else:
        header = [f"calib-pin compensate: robot {chain.name}, end frame {chain.end_frame}, calibration {compensated}",
                  f"{int(kept.sum())} of {len(kept)} targets; refused (left out): {'' if refused else 'none'}",
                  *(f"refused {reason}" for reason in refused.values())]  # one comment per refused target
        options = {k: v for k, v in (("speed_rad_s", args.speed_rad_s), ("accel_rad_s2", args.accel_rad_s2))
                   if v is not None}
        notes_per_target = tuple(f"position-only: {r}" if s == POSITION_ONLY else ""
                                 for s, r in zip(result.status, result.reasons, strict=True) if s != REFUSED)
        program = Program(name, result.q[kept], pose_ids[rows][kept], chain.name, chain.joint_names,
                          tuple(header), notes_per_target, options)
        for path, content in program_files(args.format, program, Path(args.out)).items():
            out.add(path, _writer(content))
    written = out.commit()
    _summary(robot, q_nominal, result)
    _undetermined(robot, result.q[kept], [where(int(k)) for k in np.flatnonzero(kept)], args.tcp_mm)
    if reference is not None:
        print(f"targets: poses of the model {reference.describe()}, not of the catalogue URDF")
    for k, state in enumerate(result.status):
        if state != OK:
            print(f"{where(k)}: {state}: {result.reasons[k]}")
    if extra and args.format == "csv":
        warn(f"columns {', '.join(extra)} of {Path(targets.source).name}: copied to the output as they were", "note")
    for path in written:
        print(f"wrote {path}")
    if not kept.all():
        return EXIT_REFUSED
    return EXIT_OK if all(s == OK for s in result.status) else EXIT_POSITION_ONLY


#: A point whose predicted error at a target is more than this share (of its variance) the prior's is named.
BLIND_SHARE = 0.5


def _undetermined(robot: CalibratedRobot, q: np.ndarray, names: list[str], tcp_mm: Any) -> None:
    """One warning line per target at which a point worked with is not determined.

    One warning line per target at which a point the program works with (``tcp_mm``, else
    the points named at calibration) is not determined by the calibration: most of its
    predicted error there is the prior's, not the data's.
    """
    d = robot.determination
    if d is None:
        if tcp_mm is not None:
            warn("the calibration file does not say what its data determined (an older file): the --tcp-mm "
                 "point is not checked", "note")
        return
    points = [("tcp", np.asarray(tcp_mm, dtype=float) * 1e-3)] if tcp_mm is not None else list(d.points)
    for name, point in points:
        parts = robot.point_accuracy(q, point) if len(q) else None
        if parts is None:
            continue
        total, blind = parts
        for k in np.flatnonzero(blind**2 > BLIND_SHARE * total**2):
            warn(f"{names[k]}: the {name} ({', '.join(f'{v:g}' for v in point * 1e3)} mm) is not determined by the "
                 f"calibration there: {total[k] * 1e3:.3f} mm RMS predicted, {blind[k] * 1e3:.3f} mm of it the "
                 "prior's (what the data did not see); the compensation moves it by the model's guess")


def _refuse_compensated(targets: MeasurementSet) -> None:
    """Refuse targets that are compensate's own output (its ``# compensated:`` line): they
    are corrected already, and corrected again every joint would be corrected twice.

    Raises:
        DataError: naming the file and the line.
    """
    made = targets.notes.get("compensated")
    if made is None:
        return
    raise DataError(targets.source, f"'{made}': these targets are compensate's own output, already corrected "
                    "(compensated again, every joint would be corrected twice): give the program's nominal "
                    "targets", _metadata_line(targets.source, "compensated"), "compensated")


def _metadata_line(path: str, key: str) -> int | None:
    """The 1-based line of metadata ``# key:`` in the file ``path`` (before its header), or None."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as f:
            for number, raw in enumerate(f, 1):
                line = raw.strip()
                if line and not line.startswith("#"):
                    return None
                if line.lstrip("#").strip().startswith(f"{key}:"):
                    return number
    except OSError:
        return None
    return None


def _writer(text: str) -> Callable[[Path], object]:
    """What the output writer calls to write ``text`` to its temporary file."""
    from ..util.atomic import write_text

    return lambda tmp: write_text(tmp, text)


def _summary(robot: CalibratedRobot, q_nominal: np.ndarray, result: Compensation) -> None:
    """What compensation changed and what is left, for people."""
    real = robot.forward(q_nominal)
    nominal = robot.nominal(q_nominal)
    off = np.array([np.linalg.norm(r.translation - n.translation) for r, n in zip(real, nominal, strict=True)]) * 1e3
    swing = np.rad2deg(np.abs(result.q - q_nominal))
    change = swing.max(axis=1)
    k, j = np.unravel_index(int(np.argmax(swing)), swing.shape)
    counts = {s: result.status.count(s) for s in (OK, POSITION_ONLY, REFUSED)}
    print(f"{robot.chain.name}: {len(q_nominal)} targets compensated in {result.iterations} iterations "
          f"({'geometry and deflection of ' + ', '.join(robot.deflection.spec.joints) if robot.deflection else 'geometry'})")
    print(f"uncompensated, the calibrated arm misses the nominal end frame by {off.mean():.3f} mm mean, {off.max():.3f} mm max")
    print(f"largest joint correction per target: {change.mean():.4f} deg mean, {change.max():.4f} deg max "
          f"({robot.chain.joint_names[j]} of target {k + 1})")
    met = np.array([s != REFUSED for s in result.status], dtype=bool)
    full = np.array([s == OK for s in result.status], dtype=bool)
    if met.any():
        orientation = f"{result.orientation_error_rad[full].max() * 1e6:.2g} urad max" if full.any() else "-"
        print(f"remaining: position {result.position_error_m[met].max() * 1e6:.2g} um max, "
              f"orientation {orientation} (ok targets)")
    print(f"status: {counts[OK]} ok, {counts[POSITION_ONLY]} position-only, {counts[REFUSED]} refused")

"""``make-poses`` (random poses within the limits) and ``plan-poses`` (D-optimal poses)."""

from __future__ import annotations

import argparse
import inspect
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..exceptions import CalibPinError
from ..robot.description import robot_inputs
from ..sensors import SENSORS, add_sensor_arguments, default_kind
from ..util.outputs import Outputs
from ..util.progress import quiet_progress
from . import parse_args
from .common import (
    add_end_frame_argument,
    add_model_argument,
    add_quiet_argument,
    add_robot_argument,
    add_seed_argument,
    count,
    fail,
    non_negative,
    run,
)
from .outputs import add_force_argument

#: Most poses or candidates a pose command draws (more would not fit in memory here).
MAX_POSES = 1_000_000


def make_poses_parser() -> argparse.ArgumentParser:
    """The ``calib-pin make-poses`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "make-poses")


def add_make_poses_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """make-poses' arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = "Write a random pose list within the joint limits."
    add_robot_argument(p)
    p.add_argument("--n", type=count(MAX_POSES), default=120, help="number of poses (120)")
    add_seed_argument(p)
    p.add_argument("--margin-deg", type=non_negative(float), default=5.0,
                   help="keep this far inside every joint limit, deg (5)")
    add_end_frame_argument(p)
    p.add_argument("--out", required=True, help="pose list CSV")
    add_force_argument(p, "--out file")
    return p


def _pose_output(args: argparse.Namespace) -> Outputs:
    """The pose list ``--out``, refused before the work (an existing file without --force, the URDF)."""
    out = Outputs(Path(args.out).parent, force=args.force, inputs={**robot_inputs(args.robot)})
    out.check(args.out)
    return out


def make_poses_main(argv: Sequence[str] | None = None) -> int:
    """``make_poses.py ROBOT --n 120 --seed S --out poses.csv [--margin-deg 5]``."""
    args = parse_args("make-poses", argv)
    return run(lambda: _make_poses(args))


def _make_poses(args: argparse.Namespace) -> int:
    from ..measurements import write_poses
    from ..robot import load_chain
    from ..robot.poses import random_poses

    out = _pose_output(args)
    chain = load_chain(args.robot, args.end_frame)
    margin = np.deg2rad(args.margin_deg)
    span = np.where(np.isfinite(chain.upper - chain.lower), chain.upper - chain.lower, np.inf)
    if np.any(span <= 2 * margin):
        k = int(np.argmin(span))
        raise CalibPinError(
            f"--margin-deg {args.margin_deg:g} leaves no range for {chain.joint_names[k]} "
            f"({np.rad2deg(span[k]):g} deg between its limits)"
        )
    q = random_poses(chain, args.n, np.random.default_rng(args.seed), margin=margin)
    notes = {"source": f"make_poses.py seed {args.seed}, margin {args.margin_deg:g} deg"}
    out.add(args.out, lambda tmp: write_poses(tmp, q, robot=chain.name, end_frame=chain.end_frame, notes=notes))
    out.commit()
    print(f"{chain.name}: {args.n} poses within the joint limits less {args.margin_deg:g} deg (seed {args.seed})")
    print(f"wrote {args.out}")
    return 0


def sensor_kinds(text: str) -> tuple[str, ...]:
    """Comma-separated registered sensor kinds, each once."""
    kinds = tuple(k.strip() for k in text.split(",") if k.strip())
    unknown = [k for k in kinds if k not in SENSORS]
    if not kinds or unknown:
        raise argparse.ArgumentTypeError(f"expected sensor kinds ({', '.join(SENSORS)}), comma-separated, got "
                                         f"'{text[:40]}'")
    if len(set(kinds)) != len(kinds):
        raise argparse.ArgumentTypeError(f"a sensor named twice in '{text[:40]}'")
    return kinds


def noise_list(text: str) -> tuple[float, ...]:
    """Comma-separated noises > 0, mm."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if not values or not all(np.isfinite(v) and 0 < v < 1e6 for v in values):
        raise argparse.ArgumentTypeError(f"expected noises > 0 in mm, comma-separated, got '{text[:40]}'")
    return values


def _focus(text: str) -> tuple[float, float]:
    """``--focus-mm NEAR,FAR``: two distances 0 < NEAR < FAR, mm."""
    try:
        near, far = (float(v) for v in text.split(","))
    except ValueError:
        near = far = float("nan")
    if not (np.isfinite(far) and 0 < near < far < 1e5):
        raise argparse.ArgumentTypeError(f"expected NEAR,FAR in mm with 0 < NEAR < FAR, got '{text[:40]}'")
    return near, far


def plan_poses_parser() -> argparse.ArgumentParser:
    """The ``calib-pin plan-poses`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "plan-poses")


def add_plan_poses_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """plan-poses' arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = "Choose poses that maximise the observability of the parameters (D-optimal)."
    add_robot_argument(p)
    p.add_argument("--n", type=count(MAX_POSES), default=40, help="poses to choose (40)")
    p.add_argument("--candidates", type=count(MAX_POSES), default=5000, help="random candidates to choose from (5000)")
    add_seed_argument(p)
    p.add_argument("--margin-deg", type=non_negative(float), default=5.0, help="distance from the joint limits, deg (5)")
    p.add_argument("--sensor", type=sensor_kinds, default=None,
                   help="the sensor(s) that will measure the poses, comma-separated for several reading at every "
                   f"pose (a mix): {', '.join(SENSORS)} (default {default_kind()}); a position device is planned "
                   "with the simulator's 3 markers")
    p.add_argument("--noise-mm", type=noise_list, default=None,
                   help="each sensor's noise (1 sigma), mm, comma-separated in --sensor's order: a mix weighs each "
                   "sensor's rows by it (default: equal)")
    p.add_argument("--focus-mm", type=_focus, metavar="NEAR,FAR",
                   help="a camera's focus range: the planned poses keep the board's middle this far from the camera, "
                   "mm (default half to twice the simulator's view distance: 225,900 eye in hand, 350,1400 eye to "
                   "hand)")
    p.add_argument("--geometry", metavar="FILE",
                   help="the sensor's set-up to plan for, a JSON file (as simulate --geometry; e.g. a contact "
                   "fixture layout); default: the sensor's own")
    add_sensor_arguments(p, {"anchor_mm": "default 600,200,-100", "tool_mm": "default 0,0,50",
                             "estimate": "that will be estimated too"}, skip=("length_offset_mm", "noise_deg"))
    add_end_frame_argument(p)
    add_model_argument(p)
    p.add_argument("--out", required=True, help="pose list CSV")
    add_force_argument(p, "--out file")
    add_quiet_argument(p)
    return p


def plan_poses_main(argv: Sequence[str] | None = None) -> int:
    """``plan_poses.py ROBOT --n 40 --candidates 5000 [--seed S] --out poses.csv``."""
    args = parse_args("plan-poses", argv)
    if args.candidates < args.n:
        return fail(f"--candidates ({args.candidates}) must be at least --n ({args.n})")
    with quiet_progress(args.quiet):
        return run(lambda: _plan_poses(args))


def _plan_poses(args: argparse.Namespace) -> int:
    from typing import Any

    from ..analysis.planning import SensorMix, plan_poses
    from ..measurements import write_poses
    from ..parameters import parameter_model
    from ..robot import load_chain
    from ..sensors import sensor_for, setup_from_args, setup_record

    kinds = args.sensor or (default_kind(),)
    if args.noise_mm is not None and len(args.noise_mm) != len(kinds):
        raise CalibPinError(f"--noise-mm: {len(args.noise_mm)} values for {len(kinds)} sensor(s) ({', '.join(kinds)})")
    out = _pose_output(args)
    chain = load_chain(args.robot, args.end_frame)
    params = parameter_model(chain, args.model)
    name = params.name
    setup = setup_record(**setup_from_args(args))
    sensors = [sensor_for(kind) for kind in kinds]
    if setup is not None and not any(type(setup) is s.setup_type for s in sensors):
        raise CalibPinError(f"{', '.join('--' + k.replace('_', '-') for k in setup.given())}: not an option of "
                            f"{', '.join(s.data_name for s in sensors)}")
    # the set-up options go to the sensor that takes them
    geometry: dict[str, Any] = {}
    if args.geometry:  # the set-up of one of the sensors, for a planner that takes one
        from ..sensors.geometry_file import read_geometry

        which, layout = read_geometry(args.geometry, kinds)
        if "geometry" not in inspect.signature(sensor_for(which).planning_model).parameters:
            raise CalibPinError(f"--geometry: {sensor_for(which).data_name} are planned for their own set-up "
                                "(give its options instead)")
        geometry = {which: layout}
    focus = {"focus_mm": args.focus_mm} if args.focus_mm is not None else {}
    if focus and not any("focus_mm" in inspect.signature(s.planning_model).parameters for s in sensors):
        raise CalibPinError(f"--focus-mm: a camera's focus range; not an option of "
                            f"{', '.join(s.data_name for s in sensors)}")
    parts = [s.planning_model(chain, params, setup if type(setup) is s.setup_type else None,
                              **({"geometry": geometry[k]} if k in geometry else {}),
                              **(focus if "focus_mm" in inspect.signature(s.planning_model).parameters else {}))
             for s, k in zip(sensors, kinds, strict=True)]
    if len(parts) > 1 and any(hasattr(part, "plan_candidates") for part in parts):
        raise CalibPinError(f"--sensor {','.join(kinds)}: a sensor that makes its own candidate poses (a contact "
                            "fixture's touches, a camera's views of its board) is planned alone: no other sensor "
                            "reads at its poses")
    noise = None if args.noise_mm is None else [v * 1e-3 for v in args.noise_mm]
    model: Any = parts[0] if len(parts) == 1 else SensorMix(parts, noise, kinds)
    try:
        plan = plan_poses(model, args.n, args.candidates, seed=args.seed, margin=np.deg2rad(args.margin_deg))
    except ValueError as e:
        raise CalibPinError(str(e)) from None
    what = " and ".join(f"the {s.setup_type.title}" for s in sensors) + (" sensor" if len(sensors) == 1 else " sensors")
    notes = {"source": f"plan_poses.py: {args.n} of {args.candidates} candidates (seed {args.seed}), "
                       f"D-optimal for the {name} model and {what}"
                       + (f" with {' and '.join(args.estimate)} estimated" if args.estimate else "")}
    if plan.points is not None and hasattr(model, "planned_set"):  # touches: the configurations with their fixture
        from ..measurements import write_measurements

        touches = model.planned_set(plan.q, plan.points)
        touches.notes.update(notes)
        out.add(args.out, lambda tmp: write_measurements(tmp, touches))
    else:
        out.add(args.out, lambda tmp: write_poses(tmp, plan.q, robot=chain.name, end_frame=chain.end_frame,
                                                  notes=notes))
    out.commit()
    print(f"{chain.name}: {args.n} poses chosen from {args.candidates} candidates (seed {args.seed}), "
          f"{name} model" + (f", {' and '.join(args.estimate)} estimated" if args.estimate else ""))
    print(f"observability O1 {plan.o1:.3g} (random poses: {plan.random_o1:.3g}), "
          f"O3 {plan.o3:.3g} (random: {plan.random_o3:.3g})")
    if len(parts) > 1:
        print(f"sensors at every pose: {model.describe()}")
    reach = f"the first {plan.reach}" if plan.reach else "none"
    print(f"information of {args.n} random poses is reached by {reach} of the planned poses")
    ident = plan.identifiability
    assert ident is not None
    shown = "; ".join(ident.combinations[:3]) + ("; ..." if len(ident.combinations) > 3 else "")
    print(f"the planned poses identify {ident.rank} of {len(ident.names)} directions; not identifiable: "
          f"{', '.join(ident.unidentifiable) or 'none'}; {len(ident.combinations)} combination(s) only together"
          + (f" ({shown})" if shown else ""))
    for name, seen, why in ident.directions:  # the directions the sensor names (a contact set's scale)
        print(f"{name}: {'seen' if seen else 'BLIND'}" + ("" if seen else f" ({why})"))
    if plan.points is not None and hasattr(model, "plan_summary"):  # a camera's corners in view
        print(model.plan_summary(plan.q, plan.points))
    if plan.points is not None and hasattr(model, "planned_set"):
        touched = model.planned_set(plan.q, plan.points)
        labels = [a or b for a, b in zip(touched.labels["contact_id"], touched.labels["plane_id"], strict=True)]
        print("configurations per fixture: " + ", ".join(f"{k} {labels.count(k)}" for k in sorted(set(labels))))
    print(f"wrote {args.out}")
    return 0



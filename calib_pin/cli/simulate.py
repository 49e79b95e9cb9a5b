"""``simulate``: a drawstring measurement set with known true deviations, and its truth."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import CalibPinError
from ..robot.description import robot_inputs
from ..simulation import NOISE_KINDS
from ..util.outputs import Outputs
from . import parse_args
from .common import (
    add_compliance_arguments,
    add_model_argument,
    add_robot_arguments,
    compliance_options,
    count,
    non_negative,
    run,
)
from .outputs import add_force_argument

if TYPE_CHECKING:
    from ..measurements import MeasurementSet

#: Most poses one simulated set may hold (a larger one would not fit in memory here).
MAX_POSES = 1_000_000


def simulate_parser() -> argparse.ArgumentParser:
    """The ``calib-pin simulate`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "simulate")


def add_simulate_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """simulate's arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = ("Simulate a drawstring measurement set with known true deviations; "
                     "writes FILE.csv and FILE.truth.json. With --sessions K: K sessions of one true robot, "
                     "each with its own anchor, as FILE_1.csv .. FILE_K.csv, and one FILE.truth.json (the robot "
                     "and every session's true anchor). With --kinds: sessions of other sensors, or of several "
                     "(--kinds cable,position: a drawstring session and a tracker session of the one robot).")
    add_robot_arguments(p, "default 600,200,-100; sessions 2.. drawn around it", "default 0,0,50",
                        skip=("estimate",), defaults={"length_offset_mm": 0.0}, anchor_per_session=True)
    p.add_argument("--sessions", type=count(1000), default=1,
                   help="number of sessions of the one true robot, each with its own anchor and poses "
                   "(seed, seed+1, ...); writes FILE_1.csv .. FILE_K.csv (default 1: FILE.csv)")
    p.add_argument("--kinds", type=_kinds,
                   help="sensor kind of each session, comma-separated, one per session or one for all "
                   "(e.g. cable,position: session 1 a drawstring, session 2 a tracker of 3 markers, its device "
                   "frame its own; default cable); --sessions defaults to their number")
    p.add_argument("--poses", type=_per_session(count(MAX_POSES)), default=120,
                   help="number of poses (default 120); with several sessions one, or one per session (60,10)")
    p.add_argument("--noise-mm", type=_per_session(non_negative(float, 100.0)), default=0.05,
                   help="reading noise, 1 sigma, mm (default 0.05; 0: a noise-free set, e.g. the values of a dry run); "
                   "with several sessions one, or one per session (0.05,0.02; a tracker's per axis)")
    p.add_argument("--noise-kind", choices=NOISE_KINDS, default="gauss",
                   help="gauss, student (t, 3 dof, heavy tails) or outliers (gauss + 5%% gross errors "
                   "of 1-3 mm) (default gauss)")
    p.add_argument("--nominal-rmse-mm", type=non_negative(float, 1000.0), default=2.0,
                   help="reading error of the nominal model the true deviations cause, mm (default 2)")
    p.add_argument("--poses-file", help="simulate at the poses of this pose list (make_poses.py) instead of random ones")
    p.add_argument("--geometry", metavar="FILE",
                   help="the true set-up of the sessions of one sensor, a JSON file (\"data_kind\" names the sensor; "
                   "e.g. a contact fixture layout: points_mm, planes, distances_mm, tool_mm; see the README's "
                   "'Measurement sets'; a FILE.truth.json of one session is one); default: the sensor's own")
    add_model_argument(p)
    add_compliance_arguments(p, "simulate")
    p.add_argument("--true-compliance-urad-per-nm", type=_values,
                   help="true compliance of each --compliance joint, comma-separated, urad/Nm (e.g. 25,40)")
    p.add_argument("--out", required=True, help="output CSV (FILE.truth.json is written beside it; "
                   "with --sessions K, FILE_1.csv .. FILE_K.csv)")
    p.add_argument("--images", metavar="DIR",
                   help="a camera set's images too: each pose's image of the board as the true robot's camera takes it "
                   "(8-bit PNG, a little blur and grey-level noise) into DIR, and DIR/joints.csv naming each pose's "
                   "image, for calib-pin detect (several camera sessions: DIR/<FILE_k>/)")
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


def _kinds(text: str) -> tuple[str, ...]:
    """Comma-separated sensor kinds (checked against the registry when simulated)."""
    kinds = tuple(k.strip() for k in text.split(","))
    if not all(kinds):
        raise argparse.ArgumentTypeError(f"expected sensor kinds 'a,b', got '{text[:40]}'")
    return kinds


def _per_session(one: Callable[[str], Any]) -> Callable[[str], Any]:
    """A value parsed by ``one``, or comma-separated values, one per session (a tuple)."""
    def parse(text: str) -> Any:
        values = tuple(one(v.strip()) for v in text.split(","))
        return values[0] if len(values) == 1 else values
    return parse


def _write_set(tmp: Path, data: MeasurementSet) -> None:
    """Write one simulated set to the staged file ``tmp``."""
    from ..measurements import write_measurements

    write_measurements(tmp, data)


def simulate_main(argv: Sequence[str] | None = None) -> int:
    """``simulate.py ROBOT --poses N --seed S --noise-mm SIGMA --out FILE.csv``."""
    args = parse_args("simulate", argv)
    return run(lambda: _simulate(args))


def _simulate(args: argparse.Namespace) -> int:
    from ..measurements.pose_list import read_pose_list
    from ..parameters import parameter_model
    from ..robot import load_chain
    from ..sensors import default_kind, sensor_for
    from ..sensors.cable import DEFAULT_ANCHOR_MM, DEFAULT_TOOL_MM
    from ..simulation import simulate, simulate_sessions

    out = Path(args.out)
    if not out.name or out.is_dir():
        raise OSError(f"--out '{args.out}' is not a file name")
    stem = out.name.removesuffix(".csv")
    truth_path = out.with_name(stem + ".truth.json")
    anchors = args.anchor_mm or []
    kinds = list(args.kinds) if args.kinds else None
    if kinds and len(kinds) > 1 and args.sessions == 1:
        args.sessions = len(kinds)
    if kinds and len(kinds) not in (1, args.sessions):
        raise CalibPinError(f"--kinds names {len(kinds)} kinds for {args.sessions} sessions: give one, or one per session")
    kinds = kinds * args.sessions if kinds and len(kinds) == 1 else kinds
    for name, value in (("--poses", args.poses), ("--noise-mm", args.noise_mm)):
        if isinstance(value, tuple) and len(value) != args.sessions:
            raise CalibPinError(f"{name} gives {len(value)} values for {args.sessions} session(s): give one, "
                                "or one per session")
    if kinds is None and len(anchors) not in ((0, 1) if args.sessions == 1 else (0, args.sessions)):
        raise CalibPinError(f"--anchor-mm is given {len(anchors)} times for {args.sessions} session(s): "
                            "give it once per session, or leave it out")
    from ..sensors import SENSORS
    from ..sensors.setup import flag_of

    simulated = kinds or [default_kind()]
    own = ("noise_deg", "camera_mount", "board", "intrinsics", "noise_px")  # set-up flags a simulated sensor reads
    for name in own:  # a set-up flag no simulated sensor takes is refused, not ignored
        if getattr(args, name, None) is not None and not any(
                name in sensor_for(k).setup_type.field_names() for k in simulated if k in SENSORS):
            takers = [s.kind for s in SENSORS.values() if name in s.setup_type.field_names()]
            raise CalibPinError(f"{flag_of(name)} is for --kinds {', '.join(takers)}; this simulates "
                                f"{', '.join(dict.fromkeys(simulated))}")
    csvs = [out] if args.sessions == 1 else [out.with_name(f"{stem}_{k}.csv") for k in range(1, args.sessions + 1)]
    outputs = Outputs(out.parent, force=args.force, inputs={**robot_inputs(args.robot),
                                                            "--poses-file": args.poses_file})
    for path in (*csvs, truth_path):  # refused before the work, and again when written
        outputs.check(path)
    chain = load_chain(args.robot, args.end_frame)
    params = parameter_model(chain, args.model)
    kind = {"dh": "DH", "hayati": "Hayati", "placement": "joint-placement"}[params.name]
    poses = read_pose_list(args.poses_file, chain).q if args.poses_file else None
    true_c = None if args.true_compliance_urad_per_nm is None else np.array(args.true_compliance_urad_per_nm) * 1e-6
    if args.compliance and true_c is None:
        raise CalibPinError("--compliance in simulate makes the true arm compliant: give its true compliances, "
                            "--true-compliance-urad-per-nm C,C (urad/Nm, one per compliant joint)")
    common = {"noise_mm": args.noise_mm, "nominal_rmse_mm": args.nominal_rmse_mm,
              "tool_mm": args.tool_mm or DEFAULT_TOOL_MM, "length_offset_mm": args.length_offset_mm,
              "noise_kind": args.noise_kind, "true_compliance": true_c, **compliance_options(args)}
    geometries = None
    if args.geometry:  # one sensor's true set-up, for each session of that sensor
        from ..sensors.geometry_file import read_geometry

        which, geometry = read_geometry(args.geometry, kinds or [default_kind()])
        geometries = [geometry if k == which else None for k in (kinds or [default_kind()] * args.sessions)]
    if args.sessions == 1 and kinds in (None, [default_kind()]) and geometries is None:
        data, truth = simulate(chain, params, args.poses, args.seed, anchor_mm=anchors[0] if anchors else DEFAULT_ANCHOR_MM,
                               poses=poses, **common)
        sets = [data]
    else:
        sets, truth = simulate_sessions(chain, params, args.poses, args.seed, args.sessions, kinds=kinds,
                                        anchors_mm=anchors or None, poses=poses, geometries=geometries, **common,
                                        setup={n: getattr(args, n) for n in own if getattr(args, n, None) is not None})
    for data in sets:
        refused = sensor_for(data.kind).schema.refuse_values(data.values)
        if refused is not None:
            raise CalibPinError(f"simulated row {refused[0] + 1}: {refused[1]}: --length-offset-mm or the sensor "
                                "geometry is wrong")
    for path, data in zip(csvs, sets, strict=True):
        outputs.add(path, partial(_write_set, data=data))
    outputs.add(truth_path, lambda tmp: truth.to_json(tmp))
    images = _add_images(outputs, Path(args.images), sets, csvs, truth, chain, params, args.seed) if args.images else []
    written = outputs.commit()
    if kinds is None and not isinstance(args.poses, tuple):
        what = f"{len(sets[0])} poses" if args.sessions == 1 else \
            f"{args.sessions} sessions of {len(sets[0])} poses (seeds {args.seed}..{args.seed + args.sessions - 1})"
    else:  # sessions of several kinds or sizes: each its own
        what = f"{args.sessions} session(s) ({'; '.join(f'{d.kind}: {d.describe_rows()}' for d in sets)}; " \
            f"seeds {args.seed}..{args.seed + args.sessions - 1})"
    noise = ", ".join(f"{v:g}" for v in args.noise_mm) if isinstance(args.noise_mm, tuple) else f"{args.noise_mm:g}"
    pixels = [d.notes["noise_px"] for d in sets if "noise_px" in d.notes]  # a camera's noise is its own, in px
    noise = f"{noise} mm" + (f", {pixels[0]} px" if pixels else "") if len(pixels) < len(sets) else f"{pixels[0]} px"
    print(f"{chain.name}: {what}, {kind} deviations (seed {args.seed}), "
          f"noise {noise} ({args.noise_kind})")
    for path in written:
        if path.suffix != ".png":
            print(f"wrote {path}")
    for folder, n_images in images:
        print(f"wrote {n_images} images to {folder} (the joints file {folder / JOINTS_FILE} names each pose's)")
    return 0


#: The pose list ``simulate --images`` writes beside the images.
JOINTS_FILE = "joints.csv"


def _add_images(outputs: Outputs, folder: Path, sets: list[MeasurementSet], csvs: list[Path], truth: Any, chain: Any,
                params: Any, seed: int) -> list[tuple[Path, int]]:
    """Stage each camera set's rendered images and joints file (``--images``); each folder and its image count."""
    from ..measurements.csv_writer import write_poses
    from ..sensors import SENSORS, sensor_for

    cameras = [k for k, d in enumerate(sets) if hasattr(sensor_for(d.kind), "render_images")]
    if not cameras:
        takers = ",".join(s.kind for s in SENSORS.values() if hasattr(s, "render_images"))
        raise CalibPinError(f"--images renders a camera set's images; this simulates {', '.join(d.kind for d in sets)} "
                            f"(--kinds {takers})")
    out = []
    for k in cameras:
        data, where = sets[k], folder if len(cameras) == 1 else folder / csvs[k].name.removesuffix(".csv")
        true = truth.session(k) if truth.sessions else truth
        pose_ids, first = np.unique(np.asarray(data.pose_ids), return_index=True)
        q = data.q[first]
        names = np.array([f"pose_{int(p):04d}.png" for p in pose_ids])
        for path in (where / JOINTS_FILE, *(where / n for n in names)):
            outputs.check(path)
        rendered = true.model(chain, params).render_images(true.x_model, q, np.random.default_rng(seed))
        for name, image in zip(names, rendered, strict=True):
            outputs.add(where / name, partial(_write_png, image=image))
        outputs.add(where / JOINTS_FILE, partial(write_poses, q=q, robot=data.robot, end_frame=data.end_frame,
                                                 pose_ids=pose_ids, extra={"image": names},
                                                 notes={"source": f"calib-pin simulate --images, seed {seed}"}))
        out.append((where, len(names)))
    return out


def _write_png(tmp: Path, image: np.ndarray) -> None:
    """Write an 8-bit grey image as PNG to the staged file ``tmp`` (whatever its name)."""
    import cv2

    ok, encoded = cv2.imencode(".png", image)
    if not ok:
        raise OSError(f"{tmp}: OpenCV could not encode the image")
    encoded.tofile(str(tmp))

"""``detect``: a camera set from a folder of images and the joints file that names each pose's image."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..exceptions import CalibPinError, DataError
from ..robot.description import robot_inputs
from ..util.outputs import Outputs
from . import parse_args
from .common import add_end_frame_argument, add_robot_argument, run, warn
from .outputs import add_force_argument

#: The joints file looked for in the images folder when ``--joints`` is not given.
JOINTS_FILE = "joints.csv"
#: Images named in a note before "...".
LISTED = 5


def detect_parser() -> argparse.ArgumentParser:
    """The ``calib-pin detect`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "detect")


def add_detect_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """detect's arguments, added to its subparser ``p``."""
    from ..sensors.camera_rig import _mount
    from ..sensors.lens_file import board_argument, intrinsics_argument

    p.description = ("Find a printed board's corners in each pose's image (OpenCV: a ChArUco board, or a chessboard) "
                     "and write the camera set calibrate reads: one row per corner found, with the pose's joint "
                     "angles. An image that cannot be read, is not of the lens's size or shows no board is left out "
                     "with a note; the others are used.")
    add_robot_argument(p)
    p.add_argument("--images", required=True, metavar="DIR", help="the folder of the images")
    p.add_argument("--joints", metavar="FILE",
                   help=f"the pose list naming each pose's image: pose, q1_deg.., image (a file name within DIR, or "
                   f"a path); default DIR/{JOINTS_FILE}")
    p.add_argument("--board", required=True, type=board_argument, metavar="SPEC|FILE.yaml",
                   help="the printed board: 'charuco,COLSxROWS,SQUARE_MM,MARKER_MM[,DICT]' or "
                   "'chessboard,COLSxROWS,SQUARE_MM' (squares, not inner corners), or a board file (FILE.yaml: "
                   "kind, columns, rows, square_mm, marker_mm, dictionary)")
    p.add_argument("--intrinsics", type=intrinsics_argument, metavar="FILE.yaml|K",
                   help="the camera's intrinsics (an OpenCV or ROS camera_info YAML file, or "
                   "'fx,fy,cx,cy,width,height[,k1,k2,p1,p2,k3]' px): each image's size is checked against them and "
                   "they are written into the set; needed for a chessboard")
    p.add_argument("--camera-mount", type=_mount, help="eye-in-hand or eye-to-hand, written into the set")
    add_end_frame_argument(p)
    p.add_argument("--out", required=True, help="the camera set's CSV")
    add_force_argument(p, "--out file")
    return p


def detect_main(argv: Sequence[str] | None = None) -> int:
    """``calib-pin detect ROBOT --images DIR --board SPEC --out cam.csv``."""
    args = parse_args("detect", argv)
    return run(lambda: _detect(args))


def _detect(args: argparse.Namespace) -> int:
    from ..measurements import write_measurements
    from ..measurements.pose_list import read_pose_list
    from ..robot import load_chain
    from ..sensors.camera_detect import IMAGE_SUFFIXES, ImageOutcome, detect_images, image_path

    folder = Path(args.images)
    if not folder.is_dir():
        raise DataError(str(folder), "--images: no such folder")
    joints = Path(args.joints) if args.joints else folder / JOINTS_FILE
    chain = load_chain(args.robot, args.end_frame)
    poses = read_pose_list(joints, chain)
    names = next((v for k, v in poses.extra.items() if k.strip().lower() == "image"), None)
    named = {image_path(str(n).strip(), folder).resolve() for n in names} if names is not None else set()
    images = {f"--images ({path.name})": path for path in named}
    out = Outputs(Path(args.out).parent, force=args.force,
                  inputs={**robot_inputs(args.robot), "--joints": joints, **images})
    out.check(args.out)
    unnamed = sorted(p.name for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.resolve() not in named)

    def show(o: ImageOutcome) -> None:
        if o.reason is None:
            print(f"  pose {o.pose}: {o.image}: {o.corners} corners")

    data, outcomes = detect_images(poses, folder, args.board, args.intrinsics, args.camera_mount, chain, show)
    by_reason: dict[str, list[ImageOutcome]] = {}
    for o in outcomes:
        if o.reason is not None:
            by_reason.setdefault(o.reason, []).append(o)
    for reason, left in by_reason.items():  # one note an image, or one for many images left out alike
        if len(left) <= LISTED:
            for o in left:
                warn(f"{joints}: pose {o.pose}: {o.image + ': ' if o.image else ''}{reason}; left out", "note")
        else:
            which = ", ".join(str(o.pose) for o in left[:LISTED])
            warn(f"{joints}: {len(left)} images left out: {reason} (poses {which}, ...)", "note")
    if unnamed:
        listed = ", ".join(unnamed[:LISTED]) + (", ..." if len(unnamed) > LISTED else "")
        warn(f"{folder}: {len(unnamed)} image(s) the joints file does not name, left out: {listed}", "note")
    if data is None:
        reasons = sorted({o.reason or "" for o in outcomes})
        raise CalibPinError(f"{folder}: no usable image among the {len(outcomes)} the joints file {joints} names "
                            f"({'; '.join(r for r in reasons[:3])})")
    used = [o for o in outcomes if o.reason is None]
    counts = np.array([o.corners for o in used])
    seconds = np.median([o.seconds for o in outcomes])
    out.add(args.out, lambda tmp: write_measurements(tmp, data))
    out.commit()
    print(f"{chain.name}: {len(used)} of {len(outcomes)} images used, {len(data)} corners ({counts.min()} to "
          f"{counts.max()} an image, median {np.median(counts):g}) of the {args.board.describe()}; "
          f"{seconds * 1e3:.0f} ms an image (median)")
    if args.intrinsics is None:
        print("the lens is not in the set: give it to calibrate (--intrinsics)")
    if args.board.kind == "charuco":
        print("calibrate it with --loss huber: in a real image a corner can be off (glare, a smudge, a crease in the "
              "print), and a robust loss does not follow it")
    if args.camera_mount is None:
        print("the mount is not in the set: give it to calibrate (--camera-mount eye-in-hand or eye-to-hand)")
    print(f"wrote {args.out}")
    return 0


__all__ = ["detect_main"]

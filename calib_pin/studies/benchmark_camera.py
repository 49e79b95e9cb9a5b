"""A camera set of 100 images of 50 corners each, calibrated as whole processes (``benchmark.py --camera``).

:func:`camera_images` simulates (untimed, seeded) an IRB120 with a camera on its flange and a
ChArUco board of 11x6 squares (50 inner corners, 20 mm squares) in the cell, keeping the
first 100 poses whose image shows all 50 corners: 5000 rows. :func:`time_camera` runs
``calibrate irb120 --data cam.csv`` as a user types it, in fresh processes, each variant
(:data:`VARIANTS`) and the floor (a process that only imports numpy, Pinocchio and
scipy.optimize) interleaved, and takes the medians.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..estimators import DEFAULT_METHOD
from ..measurements.csv_writer import write_measurements
from .benchmark_commands import script_argv, timed_process, warm_up
from .benchmark_figaroh import FLOOR_PROCESS

#: Images and corners per image of the timed set; the board (squares x squares, square and marker mm).
IMAGES, CORNERS = 100, 50
BOARD = (11, 6, 20.0, 15.0)
#: The calibrate commands timed: name -> the arguments after ``calibrate irb120 --data cam.csv``.
VARIANTS = {
    "lm --no-html": ["--method", "lm", "--no-html"],
    "lm, report.html": ["--method", "lm"],
    "lm --estimate intrinsics --no-html": ["--method", "lm", "--estimate", "intrinsics", "--no-html"],
    f"default method ({DEFAULT_METHOD}) --no-html": ["--no-html"],
}


@dataclass(frozen=True)
class CameraRun:
    """One variant's median wall time and peak resident memory over its runs, and the floor's median [s]."""

    variant: str
    wall_s: float
    peak_mib: float
    floor_s: float
    code: int


def camera_images(path: Path, seed: int = 0, images: int = IMAGES, noise_px: float = 0.1) -> tuple[int, int]:
    """Write the timed camera set to ``path`` (module docstring); returns its images and rows."""
    from ..parameters import parameter_model
    from ..robot import load_chain
    from ..sensors.lens import Board
    from ..simulation.simulator import simulate_set
    from .hand_eye import camera_sensor

    chain = load_chain("irb120")
    columns, rows, square, marker = BOARD
    setup = {"camera_mount": "eye-in-hand", "noise_px": noise_px,
             "board": Board(columns, rows, square, marker, "DICT_5X5_100", "charuco")}
    data, _ = simulate_set(camera_sensor(), chain, parameter_model(chain), 6 * images, seed, setup=setup)
    pose_ids = np.asarray(data.pose_ids)
    poses, counts = np.unique(pose_ids, return_counts=True)
    full = poses[counts == CORNERS][:images]
    if len(full) < images:
        raise RuntimeError(f"only {len(full)} of {6 * images} simulated images show all {CORNERS} corners")
    kept = data.subset(np.flatnonzero(np.isin(pose_ids, full)))
    write_measurements(path, kept)
    return len(full), len(kept)


def time_camera(repeats: int = 5, seed: int = 0, variants: dict[str, list[str]] | None = None,
                images: int = IMAGES) -> tuple[list[CameraRun], int, int]:
    """Each variant's ``calibrate`` and the floor as whole processes, interleaved ``repeats`` times; medians.

    Returns the runs, the set's images and its rows.
    """
    variants = VARIANTS if variants is None else variants
    with tempfile.TemporaryDirectory(prefix="calib-pin-camera-") as name:
        folder = Path(name)
        images, rows = camera_images(folder / "cam.csv", seed, images)
        argvs = {v: [*script_argv("calibrate"), "irb120", "--data", "cam.csv", *extra, "--seed", str(seed),
                     "--out", f"out_{k}"] for k, (v, extra) in enumerate(variants.items())}
        argvs["floor"] = [sys.executable, "-c", FLOOR_PROCESS]
        for argv in argvs.values():
            warm_up(argv, folder)
        measured: dict[str, list[tuple[float, float, int]]] = {k: [] for k in argvs}
        for _ in range(repeats):
            for k, argv in argvs.items():
                measured[k].append(timed_process(argv, folder))
    floor = statistics.median(m[0] for m in measured.pop("floor"))
    runs = [CameraRun(v, statistics.median(m[0] for m in ms), max(m[1] for m in ms), floor, max(m[2] for m in ms))
            for v, ms in measured.items()]
    return runs, images, rows


def format_camera(runs: list[CameraRun]) -> str:
    """The camera table: each variant's median wall time, above the floor, peak memory."""
    lines = [f"{'calibrate irb120 --data cam.csv ...':40s}{'median s':>10s}{'above floor s':>15s}{'peak MiB':>10s}"]
    for r in runs:
        failed = f"  exit {r.code}" if r.code else ""
        lines.append(f"{r.variant:40s}{r.wall_s:10.2f}{r.wall_s - r.floor_s:15.2f}{r.peak_mib:10.0f}{failed}")
    lines.append(f"{'floor (import numpy, pinocchio, scipy)':40s}{runs[0].floor_s:10.2f}")
    return "\n".join(lines)


__all__ = ["BOARD", "CORNERS", "IMAGES", "VARIANTS", "CameraRun", "camera_images", "format_camera", "time_camera"]

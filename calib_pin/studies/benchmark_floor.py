"""calibrate as a whole process against the floor of numpy, Pinocchio and scipy.optimize.

The floor is what any tool built on those three libraries pays (``benchmark.py --floor``).

What a user waits for is a whole process; what calib-pin adds is that process less one
that only imports those three libraries (:data:`~calib_pin.studies.benchmark_figaroh.FLOOR_PROCESS`).
:func:`above_floor` runs ``calibrate ur5 --model placement --test-fraction 0 --no-html`` on
a seeded simulated UR5 marker session, each method and the floor interleaved, and takes
the medians; the goals (:data:`FLOOR_GOALS`) are ratios to the floor.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..measurements.csv_writer import write_measurements
from .benchmark_commands import script_argv, timed_process, warm_up
from .benchmark_figaroh import FLOOR_PROCESS, ur5_session

#: Samples (one marker each) of the floor comparison's simulated UR5 session.
FLOOR_SAMPLES = 1000
#: The floor comparison's goals: calibrate's whole process at most this many times the floor.
FLOOR_GOALS = {"lm": 1.3, "ekf-qibas": 1.5}


@dataclass(frozen=True)
class FloorRun:
    """One command against the floor: its median wall time and the floor's [s]."""

    method: str
    wall_s: float
    floor_s: float

    @property
    def ratio(self) -> float:
        """The command's median over the floor's."""
        return self.wall_s / self.floor_s


def above_floor(methods: tuple[str, ...] = tuple(FLOOR_GOALS), repeats: int = 7, seed: int = 0,
                samples: int = FLOOR_SAMPLES) -> list[FloorRun]:
    """Each method's ``calibrate ur5`` process against the floor process, interleaved; medians.

    ``calibrate ur5 --model placement --test-fraction 0 --no-html`` on ``samples`` simulated
    marker positions, each method as a whole process, interleaved ``repeats`` times with a
    process that only imports numpy, Pinocchio and scipy.optimize (the floor any such tool
    pays, :data:`calib_pin.studies.benchmark_figaroh.FLOOR_PROCESS`).
    """
    calibration, _, _ = ur5_session(samples, seed)
    with tempfile.TemporaryDirectory(prefix="calib-pin-floor-") as name:
        folder = Path(name)
        write_measurements(folder / "ur5.csv", calibration.data)
        argvs = {m: [*script_argv("calibrate"), "ur5", "--data", "ur5.csv", "--model", "placement", "--method", m,
                     "--test-fraction", "0", "--no-html", "--seed", str(seed), "--out", f"out_{m}"] for m in methods}
        argvs["floor"] = [sys.executable, "-c", FLOOR_PROCESS]
        for argv in argvs.values():
            warm_up(argv, folder)
        times: dict[str, list[float]] = {k: [] for k in argvs}
        for _ in range(repeats):
            for k, argv in argvs.items():
                wall, _, code = timed_process(argv, folder)
                if code:
                    raise RuntimeError(f"{' '.join(argv[1:3])} ... --method {k} exited {code}")
                times[k].append(wall)
    floor = statistics.median(times["floor"])
    return [FloorRun(m, statistics.median(times[m]), floor) for m in methods]


def format_floor(runs: list[FloorRun]) -> str:
    """The floor table: each method's median, the floor's, their ratio and the goal."""
    lines = [f"{'method':12s}{'median s':>10s}{'floor s':>9s}{'ratio':>8s}{'above s':>9s}  goal"]
    for r in runs:
        goal = FLOOR_GOALS.get(r.method)
        verdict = "" if goal is None else f"<= {goal:g}x ({'met' if r.ratio <= goal else 'not met'})"
        lines.append(f"{r.method:12s}{r.wall_s:10.3f}{r.floor_s:9.3f}{r.ratio:7.2f}x{r.wall_s - r.floor_s:9.3f}  {verdict}")
    return "\n".join(lines)

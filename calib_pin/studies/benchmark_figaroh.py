"""calib-pin against FIGAROH on the same simulated UR5 position data.

Run by ``benchmark.py --against figaroh``.

FIGAROH (https://github.com/thanhndv212/figaroh, ``pip install figaroh``) is not a
dependency: :func:`against_figaroh` returns None when it is not installed. For each size
one seeded simulated UR5 session (one marker on tool0 measured in a device frame 2 m
away, 0.05 mm noise per axis, nominal error 2 mm RMSE) is calibrated by both tools,
interleaved (calib-pin, FIGAROH, calib-pin, FIGAROH, ...), in one process with the same
BLAS threads, each run as :mod:`timeit` times (the garbage of the runs before collected
first, untimed; Python's cyclic collector off while it runs). Timed, both from the data in memory:

* calib-pin: the problem on every row (the device frame and marker fitted: Kabsch
  rounds, then scipy's LM) and the estimator (history recording off), the parameter
  model a user gets by default (``placement`` for the UR5).
* FIGAROH: ``create_param_list()`` (parameter selection; ``structural``, its default:
  from random configurations, then the frame-absorbed ones dropped on the measured
  poses; ``excitation``: from the measured poses, also run because on this data the
  default selection leaves a model that cannot fit the noise floor) and
  ``solve_optimisation()`` (its closed-form frame guess and scipy LM with its outlier
  rounds), with ``BaseCalibration``'s default cost function and settings
  (``full_params``, unknown base and tip frames as its examples set them). Not timed:
  its YAML parsing and CSV reading, and ``solve()``'s evaluation and printed report.

Accuracy of both: Euclidean position RMSE [mm] against the noise-free truth at the
training poses and at 1000 fresh poses.

As whole processes (:func:`whole_processes`), what a user runs, from the files on disk:
calib-pin's ``calibrate.py ur5 --data FILE --method M --no-html --test-fraction 0``
(every row trains; it also writes the URDF, the calibration file and report.json), and
FIGAROH in a fresh Python process that builds the robot from the same URDF, reads its
YAML and CSV, selects the parameters (its default, ``structural``) and solves; each
process's wall time from start to exit, interleaved, medians. Both tools are run alike:
with bytecode, as a user's install has it (``PYTHONDONTWRITEBYTECODE`` unset), after one
untimed warm-up run each; beside them the floor, a process that only imports numpy,
Pinocchio and scipy.optimize, with the collector as calib-pin's process has it
(:data:`FLOOR_PROCESS`), so the table shows how much of
calib-pin's process is its own.
"""

from __future__ import annotations

import contextlib
import gc
import io
import statistics
import tempfile
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..calibration.prepare import Calibration, prepare
from ..calibration.solve import fit, method_record
from ..parameters import parameter_model
from ..robot import load_chain
from ..robot.poses import random_poses
from ..simulation import simulate_positions

#: Samples (poses, one marker each) of the comparison.
SIZES = (100, 1000)
#: The one marker of the simulated sessions, tool0 frame [mm].
MARKER_MM = ((60.0, 0.0, 40.0),)
#: Fresh poses of the held-out score.
FRESH_POSES = 1000
#: Reading noise, 1 sigma per axis [mm].
NOISE_MM = 0.05
#: FIGAROH's parameter selections (``estimation.method``): its default, and the one from the measured poses.
SELECTIONS = ("structural", "excitation")
#: The speed goal: at least this many times faster than FIGAROH with its default selection.
GOAL_RATIO = 30.0
#: What each timing includes (printed under the table).
TIMED = ("calib-pin: problem on the rows (device frame and marker fitted: Kabsch rounds, then LM) + estimator, "
         "history off; "
         "FIGAROH: create_param_list() + solve_optimisation() (parameter selection, frame guess, LM with "
         "outlier rounds), not its YAML/CSV reading nor solve()'s report; each run as timeit times it (the runs "
         "before collected first, the cyclic collector off while it runs)")


@dataclass(frozen=True)
class Race:
    """One size and one calib-pin method against FIGAROH: times [s], RMSE [mm] against the truth."""

    samples: int
    method: str
    selection: str
    calib_s: float
    figaroh_s: float
    calib_train_mm: float
    calib_fresh_mm: float
    figaroh_train_mm: float
    figaroh_fresh_mm: float
    calib_params: int
    figaroh_params: int

    @property
    def ratio(self) -> float:
        """FIGAROH's median time over calib-pin's."""
        return self.figaroh_s / self.calib_s


def _rmse_mm(predicted: np.ndarray, true: np.ndarray) -> float:
    """Euclidean position RMSE [mm] of (n, 3) positions [m]."""
    return float(np.sqrt(np.mean(np.sum((predicted - true) ** 2, axis=1))) * 1e3)


def _write_figaroh_files(folder: Path, setup: Calibration) -> Path:
    """FIGAROH's unified YAML config and its CSV (x1, y1, z1 [m], joint angles [rad]); the config path."""
    import pandas as pd
    import yaml

    data, chain = setup.data, setup.chain
    columns = {"x1": data.values[:, 0], "y1": data.values[:, 1], "z1": data.values[:, 2]}
    columns.update({name: data.q[:, i] for i, name in enumerate(chain.joint_names)})
    pd.DataFrame(columns).to_csv(folder / "data.csv", index=False)
    marker = {"reference_joint": chain.joint_names[-1], "measurable_dof": [True] * 3 + [False] * 3}
    config = {"robot": {"name": chain.name}, "tasks": {"calibration": {
        "type": "kinematic_calibration",
        "kinematics": {"base_frame": "universe", "tool_frame": chain.end_frame},
        "measurements": {"markers": [marker]},
        "data": {"source_file": str(folder / "data.csv"), "number_of_samples": len(data)}}}}
    path = folder / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


class _Figaroh:
    """FIGAROH's BaseCalibration on one session's files, a fresh calibrator per run."""

    def __init__(self, setup: Calibration, config: Path) -> None:
        import pinocchio as pin

        self.robot = pin.RobotWrapper(setup.chain.model.copy())
        self.config = config

    def loaded(self, selection: str) -> Any:
        """A calibrator with its config and data read (untimed), frames unknown as in FIGAROH's examples.

        ``selection`` is its ``estimation.method`` (``structural``: FIGAROH's default).
        """
        from figaroh.calibration.base_calibration import BaseCalibration

        calibrator = BaseCalibration(self.robot, str(self.config))
        calibrator.calib_config["known_baseframe"] = False
        calibrator.calib_config["known_tipframe"] = False
        calibrator.calib_config["estimation"] = {"method": selection}
        calibrator.load_data_set()
        return calibrator

    @staticmethod
    def calibrate(calibrator: Any) -> tuple[np.ndarray, float]:
        """The estimate and the seconds of parameter selection + fit."""
        start = time.perf_counter()
        calibrator.create_param_list()
        result, _ = calibrator.solve_optimisation()
        return result.x, time.perf_counter() - start

    @staticmethod
    def positions(calibrator: Any, x: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Marker positions [m] in the measurement frame at joint angles q [rad], shape (n, 3)."""
        from figaroh.calibration.calibration_tools import calc_updated_fkm

        config = dict(calibrator.calib_config, NbSample=len(q))
        return np.asarray(calc_updated_fkm(calibrator.model, calibrator.data, x, q, config)).reshape(3, len(q)).T


def _calib_pin(calibration: Calibration, method: str, seed: int) -> tuple[Any, Any, float]:
    """(model, estimate, seconds) of calib-pin's fit on every row of the session.

    The fit is :func:`calib_pin.calibration.solve.fit`; the sensor's start is fitted anew in
    every timed run (the one ``prepare`` made and kept is not reused).
    """
    rows = np.arange(len(calibration.data))
    record = method_record(method, "linear")
    start = time.perf_counter()
    done = fit(calibration, record, rows, seed=seed, loss="linear", history=False, reuse=False)
    return done.problem.model, done.estimate, time.perf_counter() - start


def ekf_qibas_stages(samples: int = SIZES[0], repeats: int = 5, seed: int = 0) -> tuple[dict[str, float], int]:
    """Where the race's timed EKF-QIBAS run goes at ``samples``, and its QIBAS stage's iterations.

    The median seconds of its problem (the device frame and marker fitted anew), of the
    registered ``ekf`` on it (the filter EKF-QIBAS starts with) and of the rest of the
    ``ekf-qibas`` run (its QIBAS stage), each timed as the race times it (collector off).
    """
    calibration, _, _ = ur5_session(samples, seed)
    rows = np.arange(len(calibration.data))
    times: dict[str, list[float]] = {"problem": [], "ekf": [], "qibas": []}
    iterations = 0
    ekf, ekf_qibas = method_record("ekf", "linear"), method_record("ekf-qibas", "linear")
    for _ in range(repeats):
        with _collected_then_off():
            start = time.perf_counter()
            calibration.problem_on(rows, reuse=False)
            fitted = time.perf_counter()
            whole = fit(calibration, ekf_qibas, rows, seed=seed, loss="linear", history=False).estimate
            done = time.perf_counter()
            fit(calibration, ekf, rows, seed=seed, loss="linear", history=False)
            filtered = time.perf_counter()
        times["problem"].append(fitted - start)
        times["ekf"].append(filtered - done)
        times["qibas"].append(done - fitted - (filtered - done))
        iterations = whole.extras["stages"]["qibas"]
    return {k: statistics.median(v) for k, v in times.items()}, iterations


def format_stages(stages: dict[str, float], iterations: int, samples: int = SIZES[0]) -> str:
    """One line: the EKF-QIBAS run's stages at ``samples`` in ms."""
    return (f"calib-pin's ekf-qibas at {samples} samples by stage, medians [ms]: problem (device frame and marker "
            f"fitted) {stages['problem'] * 1e3:.2f}, EKF {stages['ekf'] * 1e3:.2f}, QIBAS {stages['qibas'] * 1e3:.2f} "
            f"({iterations} iterations)")


@contextlib.contextmanager
def _collected_then_off() -> Iterator[None]:
    """Around one tool's timed run in the race, as :mod:`timeit` times.

    The garbage of the runs before is collected first (untimed), Python's cyclic collector
    off while it runs, so neither tool is charged for a collection of the other's objects.
    """
    gc.collect()
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def ur5_session(samples: int, seed: int) -> tuple[Calibration, Any, np.ndarray]:
    """The seeded UR5 session ready to calibrate, its truth, and the fresh poses [rad]."""
    chain = load_chain("ur5")
    data, truth = simulate_positions(chain, parameter_model(chain), samples, seed=seed, noise_mm=NOISE_MM,
                                     markers_mm=MARKER_MM)
    fresh = random_poses(chain, FRESH_POSES, np.random.default_rng(seed + 10_000))
    return prepare("ur5", data), truth, fresh


def race(samples: int, methods: list[str], repeats: int, seed: int,
         selections: tuple[str, ...] = SELECTIONS) -> list[Race]:
    """Both tools on one seeded session of ``samples`` poses, interleaved ``repeats`` times; medians.

    Each calib-pin method, then FIGAROH with each parameter selection.
    """
    setup, truth, fresh = ur5_session(samples, seed)
    true_model = truth.model(setup.chain, setup.params)
    points = np.zeros(len(setup.data), dtype=int)
    true_train = true_model.predict(truth.x_model, setup.data.q, points)
    true_fresh = true_model.predict(truth.x_model, fresh, np.zeros(len(fresh), dtype=int))
    times: dict[str, list[float]] = {m: [] for m in methods + list(selections)}
    scores: dict[str, tuple[float, float, int]] = {}
    with tempfile.TemporaryDirectory(prefix="calib-pin-figaroh-") as folder:
        tool = _Figaroh(setup, _write_figaroh_files(Path(folder), setup))
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")  # BaseCalibration's default cost function warns on every call
            for _ in range(repeats):
                for m in methods:
                    with _collected_then_off():
                        model, estimate, seconds = _calib_pin(setup, m, seed)
                    times[m].append(seconds)
                    scores[m] = (_rmse_mm(estimate.predict(model, setup.data.q, points), true_train),
                                 _rmse_mm(estimate.predict(model, fresh, np.zeros(len(fresh), dtype=int)), true_fresh),
                                 len(estimate.x))
                for selection in selections:
                    calibrator = tool.loaded(selection)
                    with _collected_then_off():
                        x, seconds = tool.calibrate(calibrator)
                    times[selection].append(seconds)
                    scores[selection] = (_rmse_mm(tool.positions(calibrator, x, setup.data.q), true_train),
                                         _rmse_mm(tool.positions(calibrator, x, fresh), true_fresh), len(x))
    median = {k: statistics.median(v) for k, v in times.items()}
    return [Race(samples, m, v, median[m], median[v], scores[m][0], scores[m][1], scores[v][0], scores[v][1],
                 scores[m][2], scores[v][2]) for m in methods for v in selections]


def against_figaroh(methods: list[str], repeats: int = 5, seed: int = 0,
                    sizes: tuple[int, ...] = SIZES) -> list[Race] | None:
    """The comparison at each size, or None when FIGAROH is not installed."""
    try:
        import figaroh  # noqa: F401
    except ImportError:
        return None
    return [r for n in sizes for r in race(n, methods, repeats, seed)]


#: FIGAROH as a whole process: argv[1:4] = URDF, config YAML, parameter selection.
_FIGAROH_PROCESS = """
import contextlib, io, sys, warnings
warnings.simplefilter("ignore")
import pinocchio as pin
from figaroh.calibration.base_calibration import BaseCalibration
urdf, config, selection = sys.argv[1:4]
with contextlib.redirect_stdout(io.StringIO()):
    calibrator = BaseCalibration(pin.RobotWrapper(pin.buildModelFromUrdf(urdf)), config)
    calibrator.calib_config["known_baseframe"] = False
    calibrator.calib_config["known_tipframe"] = False
    calibrator.calib_config["estimation"] = {"method": selection}
    calibrator.load_data_set()
    calibrator.create_param_list()
    calibrator.solve_optimisation()
"""


@dataclass(frozen=True)
class ProcessRace:
    """One size and one calib-pin method against FIGAROH's default, as whole processes: median wall s."""

    samples: int
    method: str
    calib_s: float
    figaroh_s: float
    #: The median of a process that only imports numpy, Pinocchio and scipy.optimize
    #: (:data:`FLOOR_PROCESS`): what any tool built on them pays before its own work; None: not measured.
    floor_s: float | None = None

    @property
    def ratio(self) -> float:
        """FIGAROH's median over calib-pin's."""
        return self.figaroh_s / self.calib_s


#: The floor of a whole process (Python code run with ``-c``): the imports calib-pin's LM
#: and FIGAROH both need, nothing else, with Python's cyclic collector as calib-pin's
#: command process has it (off while a one-pass command runs, every object frozen at exit:
#: :mod:`calib_pin.cli.process`), so that calib-pin's time above it is its own imports and work.
FLOOR_PROCESS = "import gc; gc.disable(); import numpy, pinocchio, scipy.optimize; gc.freeze()"


def whole_processes(methods: list[str], repeats: int = 5, seed: int = 0,
                    sizes: tuple[int, ...] = SIZES) -> list[ProcessRace] | None:
    """Both tools as whole processes on each size's seeded session, interleaved ``repeats`` times.

    See the module docstring; None when FIGAROH is not installed.
    """
    import sys

    from ..measurements.csv_writer import write_measurements
    from ..robot.chain import resolve_robot
    from .benchmark_commands import script_argv, timed_process, warm_up

    try:
        import figaroh  # noqa: F401
    except ImportError:
        return None
    out = []
    for samples in sizes:
        setup, _, _ = ur5_session(samples, seed)
        with tempfile.TemporaryDirectory(prefix="calib-pin-figaroh-") as name:
            folder = Path(name)
            config = _write_figaroh_files(folder, setup)
            write_measurements(folder / "ur5.csv", setup.data)
            figaroh_argv = [sys.executable, "-c", _FIGAROH_PROCESS, str(resolve_robot("ur5").urdf), str(config),
                            SELECTIONS[0]]
            argvs = {m: [*script_argv("calibrate"), "ur5", "--data", str(folder / "ur5.csv"), "--method", m,
                         "--no-html", "--test-fraction", "0", "--seed", str(seed), "--out", str(folder / m)]
                     for m in methods}
            argvs["figaroh"] = figaroh_argv
            argvs["floor"] = [sys.executable, "-c", FLOOR_PROCESS]
            for argv in argvs.values():  # both tools alike: one untimed run each first
                warm_up(argv, folder)
            times: dict[str, list[float]] = {m: [] for m in argvs}
            for _ in range(repeats):
                for m, argv in argvs.items():
                    wall, _, code = timed_process(argv, folder)
                    if code:
                        what = f"calibrate.py ur5 --method {m}" if m in methods else f"the {m} process"
                        raise RuntimeError(f"{what} exited {code}")
                    times[m].append(wall)
        figaroh_s, floor_s = statistics.median(times["figaroh"]), statistics.median(times["floor"])
        out += [ProcessRace(samples, m, statistics.median(times[m]), figaroh_s, floor_s) for m in methods]
    return out


def format_processes(rows: list[ProcessRace]) -> str:
    """The whole-process table: median wall time [s] of each tool and their ratio.

    With the floor (:data:`FLOOR_PROCESS`) measured, its median and calib-pin's time above
    it (its own).
    """
    floor = any(r.floor_s is not None for r in rows)
    extra = f"{'floor s':>9s}{'above s':>9s}" if floor else ""
    lines = [f"{'samples':>7s} {'calib-pin':10s}{'median s':>9s}{'FIGAROH s':>10s}{'ratio':>8s}{extra}"]
    for r in rows:
        cells = ("" if not floor else f"{'-':>9s}{'-':>9s}" if r.floor_s is None
                 else f"{r.floor_s:9.3f}{r.calib_s - r.floor_s:9.3f}")
        lines.append(f"{r.samples:7d} {r.method:10s}{r.calib_s:9.3f}{r.figaroh_s:10.3f}{r.ratio:7.1f}x{cells}")
    return "\n".join(lines)


#: The whole-process goals at the largest size: at least this many times FIGAROH's default.
PROCESS_GOALS = {"lm": 20.0, "ekf-qibas": 10.0}


def format_process_goal(rows: list[ProcessRace]) -> str:
    """One line: each goal method's whole-process ratio at the largest size, met or not."""
    largest = max(r.samples for r in rows)
    parts = [f"{r.method} {r.ratio:.1f}x at {r.samples} (goal >= {PROCESS_GOALS[r.method]:g}x, "
             f"{'met' if r.ratio >= PROCESS_GOALS[r.method] else 'not met'})"
             for r in rows if r.samples == largest and r.method in PROCESS_GOALS]
    return "whole-process goals against FIGAROH's default: " + ("; ".join(parts) or "no goal method ran")


def figaroh_version() -> str:
    """The installed FIGAROH's version (package metadata)."""
    from importlib.metadata import version

    return version("figaroh")


def format_races(rows: list[Race]) -> str:
    """The side-by-side table: median times [s], their ratio, RMSE against the truth [mm]."""
    lines = [f"{'samples':>7s} {'calib-pin':10s}{'FIGAROH':12s}{'median s':>9s}{'FIGAROH s':>10s}{'ratio':>8s}"
             f"{'train mm':>10s}{'FIG train':>10s}{'fresh mm':>10s}{'FIG fresh':>10s}{'params':>9s}"]
    for r in rows:
        lines.append(f"{r.samples:7d} {r.method:10s}{r.selection:12s}{r.calib_s:9.4f}{r.figaroh_s:10.4f}{r.ratio:7.1f}x"
                     f"{r.calib_train_mm:10.4f}{r.figaroh_train_mm:10.4f}{r.calib_fresh_mm:10.4f}"
                     f"{r.figaroh_fresh_mm:10.4f}{r.calib_params:>5d}/{r.figaroh_params:<3d}")
    return "\n".join(lines)


def format_goal(rows: list[Race]) -> str:
    """One line: each method's ratio against FIGAROH's default selection at each size.

    And whether all reach :data:`GOAL_RATIO`.
    """
    default = SELECTIONS[0]
    parts = []
    for method in dict.fromkeys(r.method for r in rows):
        mine = [r for r in rows if r.method == method and r.selection == default]
        verdict = "met" if all(r.ratio >= GOAL_RATIO for r in mine) else "not met"
        parts.append(f"{method} " + ", ".join(f"{r.ratio:.1f}x at {r.samples}" for r in mine) + f" ({verdict})")
    return f"goal >= {GOAL_RATIO:g}x FIGAROH's default ({default}) at every size: " + "; ".join(parts)

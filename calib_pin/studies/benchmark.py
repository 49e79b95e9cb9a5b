"""Timing calib-pin's estimators on a seeded simulated IRB120 session.

For each method, fitted as :func:`calib_pin.solve` fits it (the session's noise stated, as
the simulation knows it): median (and min/max) wall time of the estimate on the training
poses over repeated runs (history recording off: the method, not its bookkeeping),
iterations, evaluations of the training residual, peak Python memory of one fit
(tracemalloc, in a separate untimed run), and the error predicting 1000 fresh poses
against the noise-free truth. The machine may be shared and noisy: compare medians and
ratios, not single runs.
"""

from __future__ import annotations

import statistics
import tracemalloc
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..calibration.holdout import Fraction
from ..calibration.prepare import Calibration, prepare
from ..calibration.solve import fit, method_record, solve
from ..parameters import parameter_model
from ..robot import load_chain
from ..simulation import simulate
from .comparison import fresh_scorer

#: The simulated sessions' noise, 1 sigma [mm], stated to the fit as the simulation knows it.
NOISE_MM = 0.05


def _session(poses: int, seed: int) -> tuple[Calibration, Any]:
    """A seeded simulated IRB120 drawstring session, prepared, and its truth."""
    chain = load_chain("irb120")
    data, truth = simulate(chain, parameter_model(chain), poses, seed=seed, noise_mm=NOISE_MM)
    return prepare("irb120", data, noise_mm=NOISE_MM), truth


@dataclass(frozen=True)
class Timing:
    """One method's benchmark row: times [s], work, peak memory [MiB], fresh RMSE [mm]."""

    method: str
    median_s: float
    min_s: float
    max_s: float
    iterations: int
    evaluations: float
    peak_mib: float
    fresh_rmse_mm: float


def benchmark(methods: list[str], repeats: int = 5, seed: int = 0, poses: int = 120) -> tuple[str, list[Timing]]:
    """Time ``methods`` on a simulated IRB120 session of ``poses`` poses (80 % train).

    Returns:
        A one-line description of the set, and one :class:`Timing` per method.
    """
    calibration, truth = _session(poses, seed)
    train, _ = calibration.split(0.2, seed)
    fresh = fresh_scorer(calibration, [truth], seed - 10_000 + 1)
    rows = []
    for name in methods:
        record = method_record(name, "linear")
        times, result = [], None
        for _ in range(repeats):
            result = solve(calibration, record, holdout=Fraction(0.2), seed=seed, history=False)
            times.append(result.estimate.time_s)
        assert result is not None
        tracemalloc.start()
        fit(calibration, record, train, seed=seed, loss="linear", history=False)
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        error = fresh(result, False)
        assert error is not None
        rows.append(Timing(name, statistics.median(times), min(times), max(times), result.estimate.iterations,
                           result.estimate.nfev, peak, error))
    return f"IRB120, {len(train)} training poses, sigma 0.05 mm, seed {seed}, {repeats} repeats", rows


def format_timings(rows: list[Timing]) -> str:
    """The benchmark table, and each median relative to LM's when LM ran."""
    lines = [f"{'method':12s}{'median s':>10s}{'min s':>9s}{'max s':>9s}{'iters':>7s}"
             f"{'evals':>8s}{'peak MiB':>10s}{'fresh RMSE mm':>15s}"]
    for r in rows:
        lines.append(f"{r.method:12s}{r.median_s:10.4f}{r.min_s:9.4f}{r.max_s:9.4f}{r.iterations:7d}"
                     f"{r.evaluations:8.0f}{r.peak_mib:10.2f}{r.fresh_rmse_mm:15.4f}")
    medians = {r.method: r.median_s for r in rows}
    if "lm" in medians and len(medians) > 1:
        ratios = ", ".join(f"{m} {t / medians['lm']:.1f}x" for m, t in medians.items() if m != "lm")
        lines.append(f"median time relative to LM: {ratios}")
    return "\n".join(lines)


#: Poses of the scaling table (80 % train).
SCALING_SIZES = (100, 1000, 10_000)
#: Methods of the scaling table.
SCALING_METHODS = ("lm", "ekf", "ekf-qibas", "qibas")


def _training_problem(poses: int, seed: int) -> Any:
    """The training rows (80 %) of a seeded session of ``poses`` poses, as the fit sees them."""
    calibration, _ = _session(poses, seed)
    train, _ = calibration.split(0.2, seed)
    return calibration.problem_on(train).subset(train)


def scaling(methods: tuple[str, ...] = SCALING_METHODS, sizes: tuple[int, ...] = SCALING_SIZES,
            seed: int = 0) -> list[tuple[int, str, float, float]]:
    """(poses, method, time [s], peak Python memory [MiB]) of one fit each.

    The time from a plain fit, the memory from a second fit under tracemalloc.
    """
    rows = []
    for poses in sizes:
        calibration, _ = _session(poses, seed)
        train, _ = calibration.split(0.2, seed)
        for name in methods:
            record = method_record(name, "linear")
            time_s = fit(calibration, record, train, seed=seed, loss="linear", history=False).estimate.time_s
            tracemalloc.start()
            fit(calibration, record, train, seed=seed, loss="linear", history=False)
            peak = tracemalloc.get_traced_memory()[1] / 2**20
            tracemalloc.stop()
            rows.append((poses, name, time_s, peak))
    return rows


def format_scaling(rows: list[tuple[int, str, float, float]]) -> str:
    """The scaling table: seconds (peak MiB) per method and size, and the time per pose."""
    sizes = sorted({r[0] for r in rows})
    methods = list(dict.fromkeys(r[1] for r in rows))
    cell = {(r[0], r[1]): r for r in rows}
    lines = [f"{'poses':>7s}" + "".join(f"{m + ' s (MiB)':>22s}" for m in methods)]
    for n in sizes:
        lines.append(f"{n:7d}" + "".join(f"{cell[n, m][2]:12.3f} ({cell[n, m][3]:6.1f})" for m in methods))
    lines.append(f"{'ms/pose':>7s}" + "".join(f"{cell[sizes[-1], m][2] / (0.8 * sizes[-1]) * 1e3:22.3f}" for m in methods))
    return "\n".join(lines)


def floor(poses: int = 120, seed: int = 0, repeats: int = 50) -> dict[str, float]:
    """Medians [ms] over the training poses of a residual, a Jacobian and Pinocchio's own calls.

    One residual, one Jacobian, the Pinocchio
    floor (FK; FK + computeFrameKinematicRegressor, in a Python loop, the results
    dropped: what any Pinocchio program of the same Jacobian calls, FIGAROH's
    ``calculate_kinematics_model`` among them), and the Jacobian's own Pinocchio pass
    (the floor's calls on the working model, each regressor and end frame copied into
    the batch arrays: :meth:`~calib_pin.robot.kinematics.Kinematics.regressors`).
    """
    import time

    import pinocchio as pin

    from ..robot.kinematics import Kinematics

    problem = _training_problem(poses, seed)
    x = np.zeros(problem.n_params)
    model = problem.model.chain.model
    data, fid = model.createData(), problem.model.chain.frame_id
    configs = problem.model.chain.configuration(problem.q)

    def fk() -> None:
        for q in configs:
            pin.forwardKinematics(model, data, q)
            pin.updateFramePlacement(model, data, fid)

    def fk_regressor() -> None:
        for q in configs:
            pin.forwardKinematics(model, data, q)
            pin.computeFrameKinematicRegressor(model, data, fid, pin.LOCAL)

    kinematics = Kinematics(problem.model.chain)
    out = {}
    for name, fn in (("residual", lambda: problem.residual(x)), ("jacobian", lambda: problem.jacobian(x)),
                     ("floor FK", fk), ("floor FK+regressor", fk_regressor),
                     ("jacobian's Pinocchio pass", lambda: kinematics.regressors(problem.q))):
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            fn()
            times.append(time.perf_counter() - start)
        out[name] = statistics.median(times) * 1e3
    return out


def jacobian_profile(cost: dict[str, float]) -> str:
    """Where one Jacobian's time goes, from :func:`floor`'s medians.

    Pinocchio's own calls (the floor), copying their results into the batch arrays, and the
    rest (the chain rule: the lever product per pose, the parameter model's derivative and
    transforms, the sensor's projection).
    """
    total, calls, kept = cost["jacobian"], cost["floor FK+regressor"], cost["jacobian's Pinocchio pass"]
    return (f"Jacobian's time: Pinocchio's FK + regressor calls {calls / total:.0%} (the floor), copying their "
            f"results out {max(kept - calls, 0.0) / total:.0%}, the chain rule and the sensor's projection "
            f"{max(total - kept, 0.0) / total:.0%}")

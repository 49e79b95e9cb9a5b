"""The gauge of a calibration: what the data does not determine stays at the robot's start.

Some directions of the unknowns change no residual: a turn of the whole arm about a
cable's anchor, the anchor and the base moved together, d_2 - d_3 of parallel joints, a
turn of the arm with every contact fixture; others change it less than the noise does for
a move of a whole prior standard deviation. Along them any estimate fits about as well as
any other, and an estimator may end anywhere (a Kalman filter or a population drifts; a
least-squares step keeps its start only to first order). The export must not carry that
arbitrary part into the robot.

:func:`resolve_gauge` moves an estimate along those directions
(:mod:`calib_pin.analysis.determined`: the robot's, with the sensor's unknowns projected
out, in units of the :class:`~calib_pin.parameters.prior.Prior`) until the robot equals
its start (zero, or ``--nominal``) along them; the sensor's unknowns (anchor, device frame,
fixtures) are fitted again with the robot held, and take the rest. It works on the
Jacobian at the estimate, so freedoms that only appear there (curved symmetries, a
degeneracy the start breaks) are found too; it repeats at the point reached until the
robot no longer moves.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..analysis.determined import Determined, determined
from ..parameters.prior import Prior

#: Passes over the directions not determined (each at the Jacobian of the point reached).
MAX_STEPS = 6
#: A pass may raise the training residual's sum of squares by at most twice what its step
#: costs to first order and this many noise variances (a change no test could tell from noise).
CHI2_BUDGET = 1.0
#: Halvings of a pass's step before it is given up.
HALVINGS = 8
#: Gauss-Newton steps that restore the fit after a step along a curved freedom.
RESTORE_STEPS = 5
#: Gauss-Newton steps that fit the sensor's unknowns again after a step.
REFIT_STEPS = 3
#: A pass moving the robot by less than this (in prior units, largest entry) ends the search.
SMALL = 1e-9


@dataclass(frozen=True)
class Gauge:
    """How an estimate was moved along what the data does not determine.

    Attributes:
        undetermined: Robot directions the data does not determine, at the estimate
            (unknowns held by ``--fix`` left out).
        robot_moved: The largest change of a robot unknown, in units of its prior.
        steps: Passes taken.
        chi2_change: The training residual's sum of squares after minus before, in noise
            variances (at most about one per direction not determined).
        noise: The residual's noise the directions were judged against (1 sigma), [m].
    """

    undetermined: int
    robot_moved: float
    steps: int
    chi2_change: float
    noise: float = 0.0

    def as_dict(self) -> dict[str, float | int]:
        return {"undetermined_directions": self.undetermined, "robot_moved_prior_units": self.robot_moved,
                "steps": self.steps, "chi2_change": self.chi2_change, "noise_mm": self.noise * 1e3}


def resolve_gauge(problem: Any, x: np.ndarray, start: np.ndarray, free: np.ndarray, prior: Prior,
                  noise: float | None) -> tuple[np.ndarray, Gauge]:
    """``x`` with the robot at ``start`` along every direction ``problem``'s rows do not determine.

    The sensor's unknowns are fitted again (they take what the robot no longer explains).

    Args:
        problem: The training rows' problem (residual in units of ``noise``).
        x: The estimate, shape (n_params,), SI.
        start: Where the estimate started, shape (n_params,), SI (its robot part is the target).
        free: Indices of the unknowns that may move (the others are held), shape (n_free,).
        prior: The prior whose units measure the robot's directions.
        noise: The residual's noise (1 sigma), [m]; None: from the residual at x (RSS / (m - r)).

    Returns:
        The moved estimate, shape (n_params,), and how it moved.
    """
    model = problem.model
    free = np.asarray(free, dtype=int)
    sensor = free[free >= model.sensor_start]
    scale = np.asarray(model.scale, dtype=float)
    x = np.array(x, dtype=float)
    original = x.copy()
    rss0 = rss = _rss(problem, x)
    steps = 0
    split = determined(problem, x, free, prior, noise)
    judged = split.noise  # a noise from the residual is judged once, at the estimate
    count, sigma = split.n_undetermined, split.sigma
    # In all, no more than the chi-square of that many directions could rise by chance: an
    # estimate far out along one the data barely sees is then what the data says.
    total = rss0 + (count + 2.0 * np.sqrt(2.0 * count) + CHI2_BUDGET) * judged**2
    for k in range(MAX_STEPS):
        if k:
            split = determined(problem, x, free, prior, judged)
        if not split.n_undetermined:
            break
        step = split.toward(x, start)
        if np.abs(step / split.sigma).max(initial=0.0) < SMALL:
            break
        for _ in range(HALVINGS):  # a long way along a curved freedom: shorter steps follow it
            trial = x.copy()
            trial[split.robot] += step
            # what the step costs to first order (a direction seen less than the noise costs
            # less than one noise variance per prior sigma), and a margin for the curvature
            along = split.vt[split.rank:] @ (step / split.sigma) * split.singular_values[split.rank:]
            ceiling = min(rss + (2.0 * float(along @ along) + CHI2_BUDGET * judged**2), total)
            trial = _refit(problem, trial, split, sensor, scale, ceiling)
            if _rss(problem, trial) <= ceiling:
                break
            step = step / 2
        else:
            break
        x, rss = trial, _rss(problem, trial)
        steps += 1
    robot = free[free < model.sensor_start]
    moved = np.abs(x[robot] - original[robot]) / sigma if len(robot) else np.zeros(0)
    return x, Gauge(undetermined=count, robot_moved=float(moved.max(initial=0.0)), steps=steps,
                    chi2_change=(_rss(problem, x) - rss0) / judged**2, noise=float(judged))


def _rss(problem: Any, x: np.ndarray) -> float:
    r = problem.residual(x)
    return float(r @ r)


def _refit(problem: Any, x: np.ndarray, split: Determined, sensor: np.ndarray, scale: np.ndarray,
           ceiling: float) -> np.ndarray:
    """x with the sensor refitted, and the fit a curved freedom lost restored.

    x with the sensor's unknowns fitted again (the robot held), then, while the residual's
    sum of squares is above ``ceiling``, Gauss-Newton steps along the directions the data
    determines (the robot's, in prior units, and the sensor's): the fit a move along a curved
    freedom lost, restored without moving back along it.
    """
    if len(sensor):
        x = _refit_sensor(problem, x, sensor)
    basis = split.sigma[:, None] * split.vt[: split.rank].T  # (n_robot, rank): SI change per unit
    for _ in range(RESTORE_STEPS):
        r = problem.residual(x)
        if float(r @ r) <= ceiling:
            break
        jacobian = problem.jacobian(x)
        a = np.hstack([jacobian[:, split.robot] @ basis, jacobian[:, sensor] * scale[sensor]])
        d = np.linalg.lstsq(a, -r, rcond=1e-10)[0]
        trial = x.copy()
        trial[split.robot] += basis @ d[: split.rank]
        trial[sensor] += scale[sensor] * d[split.rank:]
        if _rss(problem, trial) >= float(r @ r):
            break
        x = trial
    return x


def _refit_sensor(problem: Any, x: np.ndarray, sensor: np.ndarray) -> np.ndarray:
    """x with the sensor's unknowns ``sensor`` fitted again, the robot held.

    Gauss-Newton on the sensor's columns alone (a gauge step moves the robot a little, so a
    few steps reach the sensor's new best fit), each step kept only while it lowers the
    residual's sum of squares.
    """
    scale = np.asarray(problem.model.scale, dtype=float)[sensor]
    r = problem.residual(x)
    for _ in range(REFIT_STEPS):
        columns = problem.jacobian(x)[:, sensor] * scale
        step = np.linalg.lstsq(columns, -r, rcond=1e-10)[0]
        trial = x.copy()
        trial[sensor] += scale * step
        r_trial = problem.residual(trial)
        if float(r_trial @ r_trial) >= float(r @ r):
            break
        x, r = trial, r_trial
        if np.abs(step).max(initial=0.0) < 1e-9:
            break
    return x

"""Robust losses: gross outliers of a reading (cable snag, sag) must not drag the model.

A robust loss replaces the squared residual r^2 by s^2 rho((r / s)^2), with scipy's
``least_squares`` definitions of rho (z = (r / s)^2):

- ``huber``: z for z <= 1, else 2 sqrt(z) - 1;
- ``soft_l1``: 2 (sqrt(1 + z) - 1);
- ``cauchy``: ln(1 + z).

The scale s comes from the data: 1.4826 x the median absolute deviation of the
residuals of the previous fit (sigma for Gaussian noise, barely moved by a few gross
errors). :class:`Robust` (through :func:`refit`) turns any estimator that minimises
``problem.cost`` (BAS, QIBAS, PSO, DE, and the QIBAS stage of EKF-QIBAS) into a robust
one: a plain fit first, then refits with the robust cost started from the previous
estimate, while the scale estimate shrinks by more than 10 % (at most 3). LM does the same with scipy's own
losses (:mod:`.lm`). Rows with a residual beyond ``OUTLIER_SCALES`` scales are reported.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import CalibrationProblem
from .base import EstimateResult, rmse

#: Robust losses (scipy.optimize.least_squares names); "linear" is plain least squares.
LOSSES = ("linear", "huber", "soft_l1", "cauchy")

#: A residual beyond this many noise scales marks an outlier.
OUTLIER_SCALES = 3.0

#: At most this many robust refits.
MAX_REFITS = 3

_RHO: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "linear": lambda z: z,
    "huber": lambda z: np.where(z <= 1.0, z, 2.0 * np.sqrt(z) - 1.0),
    "soft_l1": lambda z: 2.0 * (np.sqrt(1.0 + z) - 1.0),
    "cauchy": np.log1p,
}


def robust_scale(residual: np.ndarray) -> float:
    """1.4826 x median absolute deviation [unit of the residual]: sigma for Gaussian
    noise, barely moved by a few gross errors."""
    return float(1.4826 * np.median(np.abs(residual - np.median(residual))))


@dataclass
class RobustProblem(CalibrationProblem):
    """A calibration problem whose cost uses a robust loss at a fixed scale [m]."""

    loss: str = "linear"
    scale: float = 1.0

    def subset(self, rows: np.ndarray) -> RobustProblem:
        base = super().subset(rows)
        return RobustProblem(base.model, base.q, base.readings, base.markers, self.loss, self.scale)

    def cost(self, x: np.ndarray) -> float:
        """Mean of s^2 rho((r / s)^2) over the residual, [m^2]."""
        z = np.square(self.residual(x) / self.scale)
        return float(self.scale**2 * np.mean(_RHO[self.loss](z)))


def outlier_rows(problem: CalibrationProblem, residual: np.ndarray, scale: float) -> tuple[int, ...]:
    """Rows of ``problem`` with a residual beyond OUTLIER_SCALES x scale."""
    return tuple(int(i) for i in problem.rows_of(np.flatnonzero(np.abs(residual) > OUTLIER_SCALES * scale)))


def refit(estimator, problem: CalibrationProblem, x0: np.ndarray, loss: str, *, seed: int, noise: float) -> EstimateResult:
    """``estimator`` (which minimises ``problem.cost``) made robust as the module docstring says.

    The plain fit's history is kept; each robust refit adds one history entry (the
    training RMSE it ends at) and its evaluations; ``stages`` gives the plain fit's
    iterations and the refits' (under the loss's name).
    """
    if loss not in LOSSES:
        raise ValueError(f"unknown loss {loss!r} (valid: {', '.join(LOSSES)})")
    first = estimator(problem, x0, seed=seed, noise=noise)
    history, evaluations = list(first.history), list(first.evaluations)
    nfev, x, scale, refits, inner = first.nfev, first.x, np.inf, 0, 0
    messages = [first.message]
    for _ in range(MAX_REFITS):
        new_scale = max(robust_scale(problem.residual(x)), 1e-9)
        if new_scale > 0.9 * scale:
            break
        scale = new_scale
        robust = RobustProblem(problem.model, problem.q, problem.readings, problem.markers, loss, scale)
        step = estimator(robust, x, seed=seed, noise=noise)
        x, refits, inner, nfev = step.x, refits + 1, inner + step.iterations, nfev + step.nfev
        history.append(rmse(problem.residual(x)))
        evaluations.append(nfev)
        messages.append(step.message)
    return EstimateResult(
        x=x, history=history, evaluations=evaluations, iterations=first.iterations + refits, nfev=nfev,
        message=f"{messages[0]}; {refits} {loss} refit(s) (scale {scale * 1e3:.3g} mm): {messages[-1]}",
        covariance=first.covariance,
        stages={**(first.stages or {"linear": first.iterations}), loss: inner},
        outliers=outlier_rows(problem, problem.residual(x), scale),
    )


@dataclass(frozen=True)
class Robust:
    """An estimator that minimises ``problem.cost``, with a robust ``loss``: the same
    call signature as every estimator (see :func:`refit`)."""

    estimator: object
    loss: str

    def __call__(
        self, problem: CalibrationProblem, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5
    ) -> EstimateResult:
        return refit(self.estimator, problem, x0, self.loss, seed=seed, noise=noise)

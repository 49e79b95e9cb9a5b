"""Robust losses: gross outliers of a value (cable snag, sag) must not drag the model.

A robust loss replaces the squared residual r^2 by s^2 rho((r / s)^2), with scipy's
``least_squares`` definitions of rho (z = (r / s)^2):

- ``huber``: z for z <= 1, else 2 sqrt(z) - 1;
- ``soft_l1``: 2 (sqrt(1 + z) - 1);
- ``cauchy``: ln(1 + z).

The scale s comes from the data: 1.4826 x the median absolute deviation of the
residuals of the previous fit (sigma for Gaussian noise, barely moved by a few gross
errors). :func:`refit` is the one robust scheme: a plain fit first, then refits with the
robust cost started from the previous estimate, while the scale estimate shrinks by more
than 10 % (at most ``MAX_REFITS``). :class:`Robust` applies it to any estimator that
minimises ``problem.cost`` (BAS, QIBAS, PSO, DE, the QIBAS stage of EKF-QIBAS); LM
applies it with scipy's own losses (:mod:`.lm`), through :func:`refit_scales`. Rows with
a residual beyond ``OUTLIER_SCALES`` scales are reported.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from .base import Callback, EstimateResult, rmse
from .problem import LeastSquares

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


def value_unit(problem: Any) -> str:
    """The unit of a problem's values as its model names it (``px`` for a camera), else ``mm``."""
    return str(getattr(getattr(problem, "model", None), "value_unit", "mm"))


def robust_scale(residual: np.ndarray) -> float:
    """1.4826 x median absolute deviation [unit of the residual].

    It is sigma for Gaussian noise, barely moved by a few gross errors.
    """
    return float(1.4826 * np.median(np.abs(residual - np.median(residual))))


#: The influence function psi(u) of each loss and its derivative, u = r / s (rho' and what it gives d/du).
_PSI: dict[str, tuple[Callable[[np.ndarray], np.ndarray], Callable[[np.ndarray], np.ndarray]]] = {
    "linear": (lambda u: u, lambda u: np.ones_like(u)),
    "huber": (lambda u: np.clip(u, -1.0, 1.0), lambda u: (np.abs(u) <= 1.0).astype(float)),
    "soft_l1": (lambda u: u / np.sqrt(1.0 + u**2), lambda u: (1.0 + u**2) ** -1.5),
    "cauchy": (lambda u: u / (1.0 + u**2), lambda u: (1.0 - u**2) / (1.0 + u**2) ** 2),
}


def robust_noise(residual: np.ndarray, loss: str) -> float:
    """The noise [unit of the residual] whose Gaussian covariance a fit with ``loss`` has: Huber's sandwich.

    An M-estimate with scale s and influence psi has the covariance of a least-squares fit
    of noise s^2 mean(psi(u)^2) / mean(psi'(u))^2, u = r / s (Huber 1981, 7.6): on Gaussian
    residuals about sigma, on heavy-tailed ones larger than sigma and smaller than their RMS.
    ``linear``: the RMS (its own least squares). ``s`` is :func:`robust_scale`'s.
    """
    r = np.asarray(residual, dtype=float)
    if loss == "linear" or not len(r):
        return float(np.sqrt(np.mean(r**2))) if len(r) else 0.0
    scale = robust_scale(r)
    if scale <= 0:
        return 0.0
    psi, slope = _PSI[loss]
    u = r / scale
    return float(scale * np.sqrt(np.mean(psi(u) ** 2)) / max(float(np.mean(slope(u))), 1e-12))


def refit_scales(residual_of: Callable[[], np.ndarray]) -> Iterator[float]:
    """The scales of the refit scheme, at most MAX_REFITS.

    Each from the residual of the previous fit (``residual_of()``), while it shrinks by
    more than 10 %.
    """
    scale = np.inf
    for _ in range(MAX_REFITS):
        new_scale = max(robust_scale(residual_of()), 1e-9)
        if new_scale > 0.9 * scale:
            return
        scale = new_scale
        yield scale


@dataclass
class RobustProblem:
    """A least-squares problem whose cost uses a robust loss at a fixed scale [m]."""

    base: Any
    loss: str
    scale_m: float

    def __getattr__(self, name: str) -> Any:
        return getattr(self.base, name)

    def subset(self, rows: np.ndarray) -> RobustProblem:
        return RobustProblem(self.base.subset(rows), self.loss, self.scale_m)

    def cost(self, x: np.ndarray) -> float:
        """Mean of s^2 rho((r / s)^2) over the residual, [m^2]."""
        z = np.square(self.base.residual(x) / self.scale_m)
        return float(self.scale_m**2 * np.mean(_RHO[self.loss](z)))


def outlier_rows(problem: LeastSquares, residual: np.ndarray, scale: float) -> tuple[int, ...]:
    """Rows of ``problem`` with a residual beyond OUTLIER_SCALES x scale."""
    return tuple(int(i) for i in problem.rows_of(np.flatnonzero(np.abs(residual) > OUTLIER_SCALES * scale)))


def refit(estimator: Any, problem: LeastSquares, x0: np.ndarray, loss: str, *, seed: int, noise: float,
          callback: Callback | None = None) -> EstimateResult:
    """``estimator`` (which minimises ``problem.cost``) made robust as the module docstring says.

    The plain fit reports its own history; each robust refit adds one entry (the training
    RMSE it ends at); ``stages`` gives the plain fit's iterations and the refits'.
    """
    first = estimator(problem, x0, seed=seed, noise=noise, callback=callback)
    nfev, x, scale, refits, inner = first.nfev, first.x, np.inf, 0, 0
    messages = [first.message]
    for scale in refit_scales(lambda: problem.residual(x)):  # noqa: B023 (the latest x)
        step = estimator(RobustProblem(problem, loss, scale), x, seed=seed, noise=noise)
        x, refits, inner, nfev = step.x, refits + 1, inner + step.iterations, nfev + step.nfev
        if callback is not None:
            callback(rmse(problem.residual(x)), nfev)
        messages.append(step.message)
    return EstimateResult(
        x=x, success=first.success, status=first.status, iterations=first.iterations + refits, nfev=nfev,
        message=f"{messages[0]}; {refits} {loss} refit(s) (scale {scale * 1e3:.3g} {value_unit(problem)}): "
                f"{messages[-1]}",
        extras={**first.extras, "stages": {**(first.stages or {"linear": first.iterations}), loss: inner},
                "outliers": outlier_rows(problem, problem.residual(x), scale)},
    )


@dataclass(frozen=True)
class Robust:
    """An estimator that minimises ``problem.cost``, with a robust ``loss``.

    The same call signature as every estimator (see :func:`refit`).
    """

    estimator: Any
    loss: str

    def __call__(self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
                 callback: Callback | None = None) -> EstimateResult:
        return refit(self.estimator, problem, x0, self.loss, seed=seed, noise=noise, callback=callback)

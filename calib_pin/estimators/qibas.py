"""Quadratic interpolated beetle antennae search (QIBAS, paper M8, eq. 14-16).

The BAS loop of :mod:`.bas` with one more candidate per iteration: per dimension k,
the vertex of the parabola through (z_l[k], f(z_l)), (z_r[k], f(z_r)) and
(z_best[k], f(z_best)) (eq. 16, reading note 5). Where that parabola is degenerate or
opens downward, the BAS step's coordinate is used instead. The beetle is greedy, so it
sits at z_best; the per-dimension vertices together are then the vertex of the
parabola along b: the interpolation turns each iteration into a parabolic line search.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .bas import BAS
from .base import Callback, EstimateResult
from .problem import LeastSquares

#: upsilon_0 of eq. 16: guards the parabola's denominator, in coordinates normalised by
#: the antenna length and the best cost.
UPSILON0 = 1e-12


def parabola_vertex(
    x1: np.ndarray, x2: np.ndarray, x3: np.ndarray | float, f1: float, f2: float, f3: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per-dimension vertex of the parabola through (x1, f1), (x2, f2), (x3, f3) (eq. 16).

    An abscissa given as a number is the same in every dimension.

    Returns:
        vertex: shape like x1.
        valid: True where the three abscissae are distinct and the parabola is convex.
    """
    num = (x1**2 - x3**2) * f2 + (x3**2 - x2**2) * f1 + (x2**2 - x1**2) * f3
    den = (x1 - x3) * f2 + (x3 - x2) * f1 + (x2 - x1) * f3
    d12, d23, d31 = x1 - x2, x2 - x3, x3 - x1
    distinct = (np.abs(d12) > 1e-9) & (np.abs(d23) > 1e-9) & (np.abs(d31) > 1e-9)
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = num / (2.0 * den + UPSILON0)
        # Leading coefficient c2 of h (eq. 14), Lagrange form: the vertex is a minimum iff c2 > 0.
        c2 = -(f1 * d23 + f2 * d31 + f3 * d12) / (d12 * d23 * d31)
    valid = distinct & (c2 > 0) & np.isfinite(vertex)
    return vertex, valid


def interpolated_point(
    z: np.ndarray, m: float, b: np.ndarray, f: float, f_l: float, f_r: float, z_bas: np.ndarray
) -> np.ndarray:
    """Eq. 16 per dimension around the best point z, falling back to the BAS step.

    Normalised coordinates (z - z_best) / m and costs f / f_best keep the vertex
    well-conditioned whatever the units.
    """
    unit = f if f > 0 else 1.0  # a perfect fit (f = 0) keeps the costs as they are
    vertex, valid = _vertex_about_best(b, f_l / unit, f_r / unit, f / unit)  # z_best at 0 in every dimension
    return np.where(valid, z + m * vertex, z_bas)


def _vertex_about_best(b: np.ndarray, f1: float, f2: float, f3: float) -> tuple[np.ndarray, np.ndarray]:
    """``parabola_vertex(-b, b, 0.0, f1, f2, f3)`` for a finite b, the same bits with fewer operations.

    By identities exact in floating point: (-b)**2 == b**2, so
    x2**2 - x1**2 is +0 and its term the number 0.0 * f3; x - 0.0 == x (also for -0.0), so
    x1 - x3 is x1 and d23 is b; |0.0 - x1| == |b|, so d31's test is d23's; |x1 - x2| ==
    |-b - b| == 2 |b| (exact), above 1e-9 wherever |b| is, so d12's test is implied by it
    (``tests/test_problem_batched.py`` checks it against the reference, to the bit).
    """
    x1 = -b
    sq = b**2
    num = (sq * f2 + (0.0 - sq) * f1) + 0.0 * f3
    den = x1 * f2 + (0.0 - b) * f1 + (b - x1) * f3
    d12, d31 = x1 - b, 0.0 - x1
    distinct = np.abs(b) > 1e-9  # d23's test, and d31's; d12's too: |d12| = |-b - b| = 2 |b| exactly
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = num / (2.0 * den + UPSILON0)
        c2 = -(f1 * b + f2 * d31 + f3 * d12) / (d12 * b * d31)
    valid = distinct & (c2 > 0) & np.isfinite(vertex)
    return vertex, valid


@dataclass(frozen=True)
class QIBAS(BAS):
    """QIBAS: the settings of :class:`.bas.BAS`, with a faster decay and a smaller budget.

    The interpolated point does the fine steps, so step and antennae may shrink
    faster (mu = tau = 0.95) and 400 iterations suffice.
    """

    max_iter: int = 400
    mu: float = 0.95
    tau: float = 0.95

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        return self._search(problem, x0, seed, interpolated_point, callback)

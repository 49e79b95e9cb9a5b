"""Beetle antennae search with quadratic interpolation (QIBAS, paper M8, eq. 8-16).

The beetle sits at z (search coordinates, see :mod:`.search_space`) and, each iteration:

1. draws a random unit direction b (eq. 10) and smells the cost at its antennae
   z_r = z + m b and z_l = z - m b (eq. 11);
2. BAS step (eq. 9/13, for minimising): z_bas = z - delta b sign(f(z_r) - f(z_l));
3. quadratic interpolation (eq. 14-16), per dimension k: the vertex of the parabola
   through (z_l[k], f(z_l)), (z_r[k], f(z_r)), (z_best[k], f(z_best)); where that
   parabola is degenerate or opens downward, the BAS step's coordinate is used;
4. moves to the best of the antennae, the interpolated point and (only if that did not
   improve) the BAS point, when it improves the cost: greedy, so z is always the best
   point so far. With z = z_best, the per-dimension vertices together are the vertex
   of the parabola along b: QI turns each iteration into a parabolic line search;
5. decays step and antenna length (eq. 12): delta <- mu delta + delta0,
   m <- tau m + m0.

The cost is eq. 6, the mean squared residual. It stops after ``max_iter`` iterations,
or when the RMSE improved by less than ``rtol`` (relative) over the last ``window``
iterations (``window`` 0: twice the search dimension).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CalibrationProblem
from .base import EstimateResult
from .search_space import SearchSpace

#: upsilon_0 of eq. 16: guards the parabola's denominator, in coordinates normalised by
#: the antenna length and the best cost.
UPSILON0 = 1e-12


def parabola_vertex(
    x1: np.ndarray, x2: np.ndarray, x3: np.ndarray, f1: float, f2: float, f3: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per-dimension vertex of the parabola through (x1, f1), (x2, f2), (x3, f3) (eq. 16).

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


@dataclass(frozen=True)
class QIBAS:
    """QIBAS settings.

    Attributes:
        max_iter: Iteration budget.
        step: Initial step delta_1 and antenna length m_1, as a fraction of the start
            residual's norm (in whitened coordinates, the distance to the optimum is
            at most that norm).
        mu, tau: Decay factors of step and antenna length (eq. 12).
        floor: delta0 and m0 of eq. 12, as a fraction of the initial step.
        rtol, window: Stopping rule (see module docstring).
        quadratic: Use the interpolation of eq. 16 (False gives greedy BAS).
    """

    max_iter: int = 400
    step: float = 0.5
    mu: float = 0.95
    tau: float = 0.95
    floor: float = 1e-4
    rtol: float = 1e-4
    window: int = 0
    quadratic: bool = True

    def __call__(
        self, problem: CalibrationProblem, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5
    ) -> EstimateResult:
        rng = np.random.default_rng(seed)
        space = SearchSpace.whitened(problem, np.asarray(x0, dtype=float))
        nfev = 1

        def cost(z: np.ndarray) -> float:
            nonlocal nfev
            nfev += 1
            return problem.cost(space.to_x(z))

        z = np.zeros(space.dim)
        f = problem.cost(space.x0)
        delta = m = self.step * np.sqrt(f * problem.n_poses)
        delta0, m0 = self.floor * delta, self.floor * m
        window = self.window or 2 * space.dim
        history = [np.sqrt(f)]
        iterations = 0
        message = f"iteration budget {self.max_iter} used"
        for iterations in range(1, self.max_iter + 1):
            b = rng.standard_normal(space.dim)
            b /= np.linalg.norm(b)
            z_r, z_l = z + m * b, z - m * b
            f_r, f_l = cost(z_r), cost(z_l)
            z_bas = z - delta * b * np.sign(f_r - f_l)
            candidates = [(f_r, z_r), (f_l, z_l)]
            if self.quadratic:
                # Normalised coordinates (z - z_best) / m and costs f / f_best keep the
                # vertex well-conditioned whatever the units.
                vertex, valid = parabola_vertex(
                    (z_l - z) / m, (z_r - z) / m, np.zeros_like(z), f_l / f, f_r / f, 1.0
                )
                z_qi = np.where(valid, z + m * vertex, z_bas)
                candidates.append((cost(z_qi), z_qi))
            if min(candidates, key=lambda c: c[0])[0] >= f:
                candidates.append((cost(z_bas), z_bas))
            f_new, z_new = min(candidates, key=lambda c: c[0])
            if f_new < f:
                f, z = f_new, z_new
            history.append(np.sqrt(f))
            delta = self.mu * delta + delta0
            m = self.tau * m + m0
            if iterations >= window and history[-window - 1] - history[-1] <= self.rtol * history[-1]:
                message = f"RMSE improved by less than {self.rtol:g} (relative) in {window} iterations"
                break
        return EstimateResult(
            x=space.to_x(z), history=[float(h) for h in history], iterations=iterations,
            nfev=nfev, message=message,
        )

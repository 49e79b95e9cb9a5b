"""Beetle antennae search (BAS, paper M2, eq. 9-13), the loop QIBAS builds on.

The beetle sits at z (search coordinates, see :mod:`calib_pin.estimators.subspace`) and, each iteration:

1. draws a random unit direction b (eq. 10) and smells the cost at its antennae
   z_r = z + m b and z_l = z - m b (eq. 11);
2. BAS step (eq. 9/13, written for minimising): z_bas = z - delta b sign(f(z_r) - f(z_l));
3. QIBAS only (:mod:`.qibas`): adds the quadratically interpolated point of eq. 16;
4. moves to the best of the candidates (the antennae, already evaluated, the
   interpolated point and, only if none of those improved, the BAS point) when it
   improves the cost. This is the *greedy* variant: z is always the best point so far,
   so the history never rises. (The paper's BAS moves by eq. 13 whatever the cost and
   only remembers the best point; with a decaying step in 20 dimensions that wanders
   and converges worse.)
5. decays step and antenna length (eq. 12): delta <- mu delta + delta0,
   m <- tau m + m0.

Both antennae are evaluated in one batched call of the problem's ``costs``. QIBAS
evaluates its interpolated point in one batched call with the next iteration's
antennae around it (the next direction b is drawn then, from the same random stream,
and the next antenna length is known): when the beetle moves to the interpolated point,
as it nearly always does, those are the next iteration's antennae and that iteration
makes no call of its own; otherwise they are dropped and the antennae evaluated around
the beetle. The evaluations counted are the points the search uses (a dropped look-ahead
is not counted), so iterations, evaluations, history and estimate are those of the search
that evaluates every point on its own, to the bit (``tests/test_problem_batched.py``).
A problem without batched costs (a robust one) gets no look-ahead.

Antennae are at +-m around z (not at the BAS step's end point). The cost is eq. 6,
the mean squared residual. It stops after ``max_iter`` iterations, or when the RMSE
improved by less than ``rtol`` (relative) over the last ``window`` iterations
(``window`` 0: twice the search dimension).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .base import Callback, EstimateResult, Tracker
from .problem import LeastSquares

#: Proposes an extra candidate from (z, m, b, f, f_l, f_r, z_bas); None for plain BAS.
Interpolation = Callable[[np.ndarray, float, np.ndarray, float, float, float, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class BAS:
    """Greedy beetle antennae search.

    Its step decays more slowly than QIBAS's (mu = tau = 0.98 against 0.95, with a
    larger budget): without the interpolation the beetle needs more iterations, and
    with 0.95 its step dies out before it reaches the optimum.

    Attributes:
        max_iter: Iteration budget.
        step: Initial step delta_1 and antenna length m_1, as a fraction of the start
            residual's norm (in whitened coordinates, the distance to the optimum is
            at most that norm).
        mu, tau: Decay factors of step and antenna length (eq. 12).
        floor: delta0 and m0 of eq. 12, as a fraction of the initial step.
        rtol, window: Stopping rule (see module docstring).
    """

    max_iter: int = 1500
    step: float = 0.5
    mu: float = 0.98
    tau: float = 0.98
    floor: float = 1e-4
    rtol: float = 1e-4
    window: int = 0

    #: It minimises ``problem.cost``: the registry can make it robust (:class:`.robust.Robust`).
    minimises_cost: ClassVar[bool] = True

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        return self._search(problem, x0, seed, None, callback)

    def _search(
        self, problem: LeastSquares, x0: np.ndarray, seed: int, interpolate: Interpolation | None,
        callback: Callback | None = None,
    ) -> EstimateResult:
        rng = np.random.default_rng(seed)
        track = Tracker(problem, callback)
        space = track.whitened(x0)

        def cost(z: np.ndarray) -> float:
            return track.cost(space.to_x(z))

        z = np.zeros(space.dim)
        f = cost(z)
        delta = m = self.step * np.sqrt(f * problem.n_values)
        delta0, m0 = self.floor * delta, self.floor * m
        window = self.window or 2 * space.dim
        h = [np.sqrt(f)]  # best RMSE after each iteration: the stopping rule's record
        track.record(h[0])
        iterations = 0
        message, status = f"iteration budget {self.max_iter} used", 1
        look_ahead = interpolate is not None and track.batched
        b_next = None
        ahead: tuple[np.ndarray, np.ndarray, np.ndarray, float, float] | None = None  # (z, z_r, z_l, f_r, f_l) ahead
        for iterations in range(1, self.max_iter + 1):
            if b_next is None:
                b = rng.standard_normal(space.dim)
                b /= math.sqrt(b.dot(b))  # np.linalg.norm(b), its own operations, without its checks
            else:
                b, b_next = b_next, None
            if ahead is not None and ahead[0] is z:  # these antennae came with the last call
                _, z_r, z_l, f_r, f_l = ahead
                track.count(2)
            else:
                z_r, z_l = z + m * b, z - m * b
                f_r, f_l = track.costs([space.to_x(z_r), space.to_x(z_l)])  # both antennae in one batched pass
            ahead = None
            z_bas = z - delta * b * np.sign(f_r - f_l)
            if interpolate is not None:
                z_qi = interpolate(z, m, b, f, f_l, f_r, z_bas)
                if look_ahead:
                    # The next iteration's antennae around z_qi (its direction and antenna
                    # length are already known) in the same batched call: used, and counted,
                    # when the beetle moves to z_qi, as it nearly always does.
                    b_next = rng.standard_normal(space.dim)
                    b_next /= math.sqrt(b_next.dot(b_next))  # as b above (math.sqrt: the same correctly rounded root)
                    m_next = self.tau * m + m0  # the decay below
                    z_nr, z_nl = z_qi + m_next * b_next, z_qi - m_next * b_next
                    f_qi, f_nr, f_nl = track.costs([space.to_x(z_qi), space.to_x(z_nr), space.to_x(z_nl)], used=1)
                    ahead = (z_qi, z_nr, z_nl, f_nr, f_nl)
                else:
                    f_qi = cost(z_qi)
            # The antennae and the interpolated point, then the BAS point only if none of them is below f.
            f_new, z_new = _best(f_r, z_r, f_l, z_l, *((f_qi, z_qi) if interpolate is not None else ()))
            if f_new >= f:
                f_new, z_new = _best(f_new, z_new, cost(z_bas), z_bas)
            if f_new < f:
                f, z = f_new, z_new
            h.append(np.sqrt(f))
            track.record(h[-1])
            delta = self.mu * delta + delta0
            m = self.tau * m + m0
            if iterations >= window and h[-window - 1] - h[-1] <= self.rtol * h[-1]:
                message, status = f"RMSE improved by less than {self.rtol:g} (relative) in {window} iterations", 0
                break
        return track.result(space.to_x(z), iterations, message, status=status)


def _best(*pairs: float | np.ndarray) -> tuple[float, np.ndarray]:
    """The (cost, point) that ``min(candidates, key=cost)`` picks, of pairs given flat.

    The pairs come as (cost, point, cost, point, ...); the first of the lowest wins (a
    later one replaces it only when lower, so a NaN never does), without building the list
    and key calls.
    """
    f, z = pairs[0], pairs[1]
    for k in range(2, len(pairs), 2):
        if pairs[k] < f:
            f, z = pairs[k], pairs[k + 1]
    return f, z  # type: ignore[return-value]

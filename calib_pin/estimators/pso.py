"""Particle swarm optimisation (paper M4): a small swarm, vectorised over particles."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .base import Callback, EstimateResult, Tracker
from .problem import LeastSquares


@dataclass(frozen=True)
class PSO:
    """Global-best particle swarm in the whitened search coordinates.

    The coordinates are those of :mod:`calib_pin.estimators.subspace`.
    Every iteration each particle's velocity becomes
    ``inertia * v + c1 * r1 * (own best - z) + c2 * r2 * (swarm best - z)``
    (r1, r2 uniform in [0, 1) per coordinate), clamped to the box size, and the particle
    moves by it, clipped to the box. The constants are Clerc and Kennedy's constriction
    values (inertia 0.7298, c1 = c2 = 1.49618). The box is +-``bound`` times the start
    residual's norm in every coordinate (in whitened coordinates the linearised optimum
    lies within that norm of the start). Particle 0 starts at x0, the others uniformly
    in the box; velocities start at zero.

    One iteration moves the whole swarm and costs ``particles`` evaluations. It stops
    after ``max_iter`` iterations, or when the swarm's best RMSE improved by less than
    ``rtol`` (relative) over the last ``window`` iterations.
    """

    particles: int = 30
    max_iter: int = 300
    inertia: float = 0.7298
    c1: float = 1.49618
    c2: float = 1.49618
    bound: float = 1.0
    rtol: float = 1e-3
    window: int = 30
    minimises_cost: ClassVar[bool] = True  # see :class:`.robust.Robust`
    #: Records once at the start, then once per generation: a progress bar of max_iter.
    reports_generations: ClassVar[bool] = True

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        rng = np.random.default_rng(seed)
        track = Tracker(problem, callback)
        space = track.whitened(x0)

        def costs(z: np.ndarray) -> np.ndarray:
            return np.array(track.costs([space.to_x(p) for p in z]))  # the swarm in batched passes

        start = track.cost(space.x0)
        h = [np.sqrt(start)]  # the swarm's best RMSE per iteration: the stopping rule's record
        track.record(h[0])
        half = self.bound * np.sqrt(start * problem.n_values)
        z = rng.uniform(-half, half, size=(self.particles, space.dim))
        z[0] = 0.0
        v = np.zeros_like(z)
        f = costs(z)
        own, own_f = z.copy(), f.copy()
        best = int(np.argmin(own_f))
        iterations = 0
        message, status = f"iteration budget {self.max_iter} used", 1
        for iterations in range(1, self.max_iter + 1):
            r1, r2 = rng.random(z.shape), rng.random(z.shape)
            v = self.inertia * v + self.c1 * r1 * (own - z) + self.c2 * r2 * (own[best] - z)
            v = np.clip(v, -2 * half, 2 * half)
            z = np.clip(z + v, -half, half)
            f = costs(z)
            better = f < own_f
            own[better], own_f[better] = z[better], f[better]
            best = int(np.argmin(own_f))
            h.append(np.sqrt(min(own_f[best], start)))
            track.record(h[-1])
            if iterations >= self.window and h[-self.window - 1] - h[-1] <= self.rtol * h[-1]:
                message, status = f"RMSE improved by less than {self.rtol:g} (relative) in {self.window} iterations", 0
                break
        x = space.to_x(own[best]) if own_f[best] < start else space.x0
        return track.result(x, iterations, message, status=status)

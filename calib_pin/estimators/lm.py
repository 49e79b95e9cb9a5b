"""Levenberg-Marquardt (paper M6): scipy.optimize.least_squares, the reference method."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..errors import CalibrationProblem
from .base import EstimateResult, Tracker, rmse


@dataclass(frozen=True)
class LevenbergMarquardt:
    """MINPACK's Levenberg-Marquardt through ``scipy.optimize.least_squares(method="lm")``.

    It solves for the identifiable directions only (the whitened coordinates of
    :mod:`.search_space`, with the analytic Jacobian mapped onto them); the others stay
    at x0. Stops on scipy's ``ftol``/``xtol``/``gtol`` or ``max_nfev`` evaluations.

    One iteration is one Jacobian evaluation (MINPACK evaluates it once per outer
    step); ``history`` holds the best training RMSE at the start and at the end of each
    iteration.
    """

    ftol: float = 1e-8
    xtol: float = 1e-8
    gtol: float = 1e-8
    max_nfev: int = 100

    def __call__(
        self, problem: CalibrationProblem, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5
    ) -> EstimateResult:
        track = Tracker(problem)
        space = track.whitened(x0)
        best = [np.inf]

        def residual(z: np.ndarray) -> np.ndarray:
            r = track.residual(space.to_x(z))
            best[0] = min(best[0], rmse(r))
            if not track.history:
                track.record(best[0])
            return r

        last = [None]

        def jacobian(z: np.ndarray) -> np.ndarray:
            # scipy checks the Jacobian at the start before MINPACK asks for it there.
            if last[0] is not None and not np.array_equal(z, last[0]):
                track.record(best[0])  # end of the previous iteration
            last[0] = z.copy()
            return track.jacobian(space.to_x(z)) @ space.basis

        fit = least_squares(
            residual, np.zeros(space.dim), jac=jacobian, method="lm",
            ftol=self.ftol, xtol=self.xtol, gtol=self.gtol, max_nfev=self.max_nfev,
        )
        track.record(best[0])
        return track.result(space.to_x(fit.x), len(track.history) - 1, str(fit.message))

"""Levenberg-Marquardt (paper M6): scipy.optimize.least_squares, the reference method."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..errors import CalibrationProblem
from .base import EstimateResult, rmse
from .search_space import SearchSpace


@dataclass(frozen=True)
class LevenbergMarquardt:
    """MINPACK's Levenberg-Marquardt through ``scipy.optimize.least_squares(method="lm")``.

    It solves for the identifiable directions only (the whitened coordinates of
    :mod:`.search_space`, with the analytic Jacobian mapped onto them); the others stay
    at x0. Stops on scipy's ``ftol``/``xtol``/``gtol`` or ``max_nfev`` evaluations.

    ``iterations`` counts Jacobian evaluations (one per accepted LM step);
    ``history`` holds the training RMSE after each residual evaluation that improved it.
    """

    ftol: float = 1e-8
    xtol: float = 1e-8
    gtol: float = 1e-8
    max_nfev: int = 100

    def __call__(
        self, problem: CalibrationProblem, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5
    ) -> EstimateResult:
        space = SearchSpace.whitened(problem, np.asarray(x0, dtype=float))
        history = [rmse(problem.residual(space.x0))]

        def residual(z: np.ndarray) -> np.ndarray:
            r = problem.residual(space.to_x(z))
            history.append(min(history[-1], rmse(r)))
            return r

        fit = least_squares(
            residual,
            np.zeros(space.dim),
            jac=lambda z: problem.jacobian(space.to_x(z)) @ space.basis,
            method="lm",
            ftol=self.ftol,
            xtol=self.xtol,
            gtol=self.gtol,
            max_nfev=self.max_nfev,
        )
        return EstimateResult(
            x=space.to_x(fit.x),
            history=history,
            iterations=int(fit.njev),
            nfev=int(fit.nfev + fit.njev) + 2,
            message=str(fit.message),
        )

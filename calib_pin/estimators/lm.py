"""Levenberg-Marquardt (paper M6): scipy.optimize.least_squares, the reference method.

With a robust ``loss`` it becomes a two-stage robust fit: the plain LM fit first, then
scipy's trust-region least squares (``method="trf"``) with that loss, started from it,
with the loss's scale set from the data: 1.4826 x the median absolute deviation of the
previous fit's residuals (a noise estimate that gross outliers barely inflate),
refitted while that estimate shrinks by more than 10 % (at most 3 robust fits).
Rows with a value whose final residual exceeds ``OUTLIER_SCALES`` x that scale are reported as
outliers (``EstimateResult.outliers``). The search methods get the same scheme through
:func:`.robust.refit`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from .base import Callback, EstimateResult, Tracker, rmse
from .problem import LeastSquares
from .robust import outlier_rows, refit_scales, value_unit


@dataclass(frozen=True)
class LevenbergMarquardt:
    """MINPACK's Levenberg-Marquardt through ``scipy.optimize.least_squares(method="lm")``.

    It solves for the identifiable directions only (the whitened coordinates of
    :mod:`calib_pin.estimators.subspace`, with the analytic Jacobian mapped onto them); the others stay
    at x0. Stops on scipy's ``ftol``/``xtol``/``gtol`` or ``max_nfev`` evaluations.
    ``loss`` other than ``linear`` adds the robust stage of the module docstring.

    One iteration is one Jacobian evaluation (MINPACK evaluates it once per outer
    step); ``history`` holds the best training RMSE at the start and at the end of each
    iteration.
    """

    ftol: float = 1e-8
    xtol: float = 1e-8
    gtol: float = 1e-8
    max_nfev: int = 100
    loss: str = "linear"

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        track = Tracker(problem, callback)
        space = track.whitened(x0)
        best = [np.inf]
        started = [False]

        def residual(z: np.ndarray) -> np.ndarray:
            r = track.residual(space.to_x(z))
            if track.recording:
                best[0] = min(best[0], rmse(r))
                if not started[0]:
                    started[0] = True
                    track.record(best[0])
            return r

        last: list[np.ndarray | None] = [None]
        iterations = [0]
        recording = [True]  # the robust stage is recorded as one iteration at its end

        def jacobian(z: np.ndarray) -> np.ndarray:
            # scipy checks the Jacobian at the start before MINPACK asks for it there.
            if recording[0] and last[0] is not None and not np.array_equal(z, last[0]):
                iterations[0] += 1
                track.record(best[0])  # end of the previous iteration
            last[0] = z.copy()
            return track.jacobian(space.to_x(z)) @ space.basis

        tolerances = {"ftol": self.ftol, "xtol": self.xtol, "gtol": self.gtol, "max_nfev": self.max_nfev}
        fit = least_squares(residual, np.zeros(space.dim), jac=jacobian, method="lm", **tolerances)
        iterations[0] += 1
        track.record(best[0])
        status = 0 if fit.status > 0 else (1 if fit.status == 0 else 2)
        if self.loss == "linear":
            return track.result(space.to_x(fit.x), iterations[0], str(fit.message), status=status)
        recording[0] = False
        robust, scale = fit, np.inf
        for scale in refit_scales(lambda: robust.fun):  # noqa: B023 (reads the latest fit)
            robust = least_squares(residual, robust.x, jac=jacobian, method="trf", loss=self.loss,
                                   f_scale=scale, **tolerances)
        # The robust stage trades training RMSE for robustness: record its own RMSE.
        iterations[0] += 1
        track.record(rmse(robust.fun))
        return track.result(
            space.to_x(robust.x), iterations[0],
            f"LM: {fit.message}; {self.loss} (scale {scale * 1e3:.3g} {value_unit(problem)}): "
            f"{robust.message}",
            status=status, outliers=outlier_rows(problem, robust.fun, scale),
        )

"""Radial-basis-function network (paper M5): learns the reading error, not the robot.

A thin-plate-spline RBF network (scipy's RBFInterpolator, with a degree-1 polynomial
tail) maps joint angles [rad] to the reading error of the model at x0 (measured minus
predicted, [m]) on the training poses. Predictions are then the model's readings plus
the network's output. Its smoothing (the regularisation added to the kernel matrix) is
chosen by ``folds``-fold cross-validation on the training poses from ``smoothing``.

It yields **no kinematic parameters**: ``x`` stays at x0, the result carries a
``correction`` instead, and calib-pin exports no URDF for it. It corrects only the
reading of this one sensor at this one anchor, and only near the training poses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RBFInterpolator

from ..problem import LeastSquares
from .base import Callback, EstimateResult, Tracker, rmse


@dataclass(frozen=True)
class RBF:
    """RBF network settings.

    Attributes:
        kernel: scipy RBFInterpolator kernel.
        degree: Degree of the polynomial tail.
        smoothing: Candidate smoothing values tried by cross-validation.
        folds: Cross-validation folds (at most the number of poses).
    """

    kernel: str = "thin_plate_spline"
    degree: int = 1
    smoothing: tuple[float, ...] = (0.0, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0)
    folds: int = 5

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        track = Tracker(problem, callback)
        x0 = np.asarray(x0, dtype=float)
        error = -track.residual(x0)  # measured minus predicted, [m]
        track.record(rmse(error))
        q = problem.q  # type: ignore[attr-defined]  # RBF learns over the joint angles
        fold = np.random.default_rng(seed).permutation(len(q)) % min(self.folds, len(q))

        def cv_error(smoothing: float) -> float:
            sq = 0.0
            for k in range(fold.max() + 1):
                held = fold == k
                net = RBFInterpolator(q[~held], error[~held], kernel=self.kernel,
                                      degree=self.degree, smoothing=smoothing)
                sq += float(np.sum((net(q[held]) - error[held]) ** 2))
            return sq

        chosen = min(self.smoothing, key=cv_error)
        net = RBFInterpolator(q, error, kernel=self.kernel, degree=self.degree, smoothing=chosen)
        result = track.result(
            x0, 1, f"{self.kernel} network, smoothing {chosen:g} by {fold.max() + 1}-fold "
            "cross-validation", correction=lambda q_new: net(np.atleast_2d(q_new)),
        )
        if track.recording:
            track.record(rmse(result.residual(problem)))
        return result

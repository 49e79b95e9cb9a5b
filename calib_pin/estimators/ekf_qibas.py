"""EKF-QIBAS (paper M9, the paper's method): QIBAS refining the EKF's estimate."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .base import Callback, EstimateResult, offset
from .ekf import EKF
from .problem import LeastSquares
from .qibas import QIBAS
from .robust import Robust


@dataclass(frozen=True)
class EKFQIBAS:
    """One EKF pass over the training poses, then QIBAS started from its estimate.

    The QIBAS stage starts with a smaller step (a tenth of the start residual's norm)
    since the EKF already brought the estimate near the optimum. With a robust
    ``loss`` the QIBAS stage refits with it (:class:`.robust.Robust`); the EKF stays
    plain (a Kalman filter has no robust loss here). ``iterations`` is the
    sum of both stages' (EKF updates + QIBAS iterations), itemised in ``stages``;
    ``covariance`` is the EKF's P.
    """

    ekf: EKF = field(default_factory=EKF)
    qibas: QIBAS = field(default_factory=lambda: QIBAS(step=0.1))
    loss: str = "linear"

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        first = self.ekf(problem, x0, seed=seed, noise=noise, callback=callback)
        qibas = self.qibas if self.loss == "linear" else Robust(self.qibas, self.loss)
        second = qibas(problem, first.x, seed=seed, noise=noise, callback=offset(callback, first.nfev))
        stages = ({"ekf": first.iterations, **{f"qibas {k}": v for k, v in second.stages.items()}}
                  if second.stages else {"ekf": first.iterations, "qibas": second.iterations})
        return EstimateResult(
            x=second.x, success=second.success, status=second.status,
            message=f"EKF: {first.message}; QIBAS: {second.message}",
            iterations=first.iterations + second.iterations, nfev=first.nfev + second.nfev,
            extras={"covariance": first.covariance, "stages": stages, "outliers": second.outliers,
                    **{k: first.extras[k] for k in ("history_iterations",) if k in first.extras}},
        )

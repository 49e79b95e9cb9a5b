"""EKF-QIBAS (paper M9, the paper's method): QIBAS refining the EKF's estimate."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import CalibrationProblem
from .base import EstimateResult
from .ekf import EKF
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
        self, problem: CalibrationProblem, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5
    ) -> EstimateResult:
        first = self.ekf(problem, x0, seed=seed, noise=noise)
        qibas = self.qibas if self.loss == "linear" else Robust(self.qibas, self.loss)
        second = qibas(problem, first.x, seed=seed, noise=noise)
        return EstimateResult(
            x=second.x,
            history=first.history + second.history[1:],
            evaluations=first.evaluations + [first.nfev + e for e in second.evaluations[1:]],
            iterations=first.iterations + second.iterations,
            nfev=first.nfev + second.nfev,
            message=f"EKF: {first.message}; QIBAS: {second.message}",
            covariance=first.covariance,
            stages={"ekf": first.iterations, **{f"qibas {k}": v for k, v in second.stages.items()}}
            if second.stages else {"ekf": first.iterations, "qibas": second.iterations},
            outliers=second.outliers,
        )

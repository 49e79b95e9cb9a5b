"""LM, then an RBF network on what it leaves (M6+M5): geometry by physics, the rest learnt.

The geometric fit (:mod:`.lm`, with every unknown of the problem: joint compliances and
the sensor's geometry too when the problem has them) gives ``x``; the network of
:mod:`.rbf` then learns the error left by the model at ``x`` on the training rows and
becomes the result's ``correction``. Cross-validation picks heavy smoothing when the
residual is only noise, so on purely geometric data it changes little.

``x`` alone is a valid calibration, but not the whole model: like M5 the result counts
as not kinematic, and calib-pin writes no URDF or calibration file for it (the report
says so) rather than a URDF that leaves out the learnt part.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .base import Callback, EstimateResult, offset
from .lm import LevenbergMarquardt
from .problem import LeastSquares
from .rbf import RBF


@dataclass(frozen=True)
class LMRBF:
    """Levenberg-Marquardt, then an RBF network on its residual.

    ``iterations`` is the sum of both stages' (itemised in ``stages``); the history is
    LM's, then the network's one step.
    """

    geometric: LevenbergMarquardt = field(default_factory=LevenbergMarquardt)
    network: RBF = field(default_factory=RBF)

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        first = self.geometric(problem, x0, seed=seed, noise=noise, callback=callback)
        second = self.network(problem, first.x, seed=seed, noise=noise, callback=offset(callback, first.nfev))
        return EstimateResult(
            x=first.x, success=first.success, status=first.status,
            message=f"LM: {first.message}; RBF: {second.message}",
            iterations=first.iterations + second.iterations, nfev=first.nfev + second.nfev,
            extras={"correction": second.correction, "stages": {"lm": first.iterations, "rbf": second.iterations}},
        )

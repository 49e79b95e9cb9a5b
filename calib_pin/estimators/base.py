"""What every estimator shares: the call signature and the result type.

An estimator is a small frozen dataclass whose fields are its settings (with documented
defaults) and whose call is::

    estimator(problem, x0, *, seed=0, noise=5e-5) -> EstimateResult

``problem`` is a :class:`calib_pin.errors.CalibrationProblem` (the one residual and
the one Jacobian), ``x0`` the start deviations (SI units), ``seed`` seeds any
randomness, ``noise`` is the sensor's noise (1 sigma, [m]) for methods that weigh
measurements by it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class EstimateResult:
    """Outcome of one estimate.

    Attributes:
        x: Estimated deviations, shape (n_params,), SI units ([m], [rad]).
        history: Training-set RMSE [m] at the start and after each iteration.
        iterations: Iterations of the method's main loop (see each method).
        nfev: Evaluations of the residual over the whole training set (a Jacobian
            evaluation counts as one too).
        time_s: Wall time of the estimate, [s].
        message: Why the method stopped.
        covariance: Covariance of x where the method gives one (the EKF's P), or None.
        stages: For a pipeline, the iterations of each stage by name.
    """

    x: np.ndarray
    history: list[float]
    iterations: int
    nfev: int
    time_s: float = 0.0
    message: str = ""
    covariance: np.ndarray | None = None
    stages: dict[str, int] = field(default_factory=dict)


def rmse(residual: np.ndarray) -> float:
    """Root mean square of a residual vector, in its unit."""
    return float(np.sqrt(np.mean(np.square(residual))))

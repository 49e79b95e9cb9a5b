"""What every estimator shares: the call signature, the result type and its bookkeeping.

An estimator is a small frozen dataclass whose fields are its settings (with documented
defaults) and whose call is::

    estimator(problem, x0, *, seed=0, noise=5e-5) -> EstimateResult

``problem`` is a :class:`calib_pin.errors.CalibrationProblem` (the one residual and
the one Jacobian), ``x0`` the start deviations (SI units), ``seed`` seeds any
randomness, ``noise`` is the sensor's noise (1 sigma, [m]) for methods that weigh
measurements by it.

Work is counted in *evaluations*: one evaluation is the residual (or the Jacobian) of
the whole training set; a Kalman update that predicts one pose counts 1/n_poses of an
evaluation per prediction.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import CableModel, CalibrationProblem
from .search_space import SearchSpace


@dataclass
class EstimateResult:
    """Outcome of one estimate.

    Attributes:
        x: Estimated deviations, shape (n_params,), SI units ([m], [rad]).
        history: Training-set RMSE [m] at the start and after each iteration, so
            ``iterations + 1`` entries.
        evaluations: Evaluations used when each ``history`` entry was reached, same
            length as ``history`` (0 at the start, non-decreasing).
        iterations: Iterations of the method's main loop (see each method).
        nfev: Evaluations used in all (see the module docstring).
        time_s: Wall time of the estimate, [s].
        message: Why the method stopped.
        covariance: Covariance of x where the method gives one (the EKF's P), or None.
        stages: For a pipeline, the iterations of each stage by name.
        correction: For a method that learns the readings' error instead of kinematic
            parameters (RBF): a function of joint angles (n_poses, n_joints) [rad]
            giving the amount (n_poses,) [m] to add to the readings predicted at x.
        outliers: Rows of the training problem a robust method judged outliers.
    """

    x: np.ndarray
    history: list[float]
    evaluations: list[float]
    iterations: int
    nfev: float
    time_s: float = 0.0
    message: str = ""
    covariance: np.ndarray | None = None
    stages: dict[str, int] = field(default_factory=dict)
    correction: Callable[[np.ndarray], np.ndarray] | None = None
    outliers: tuple[int, ...] = ()

    @property
    def kinematic(self) -> bool:
        """True when x alone is the calibration (it can be exported as a URDF)."""
        return self.correction is None

    def predict(self, model: CableModel, q: np.ndarray) -> np.ndarray:
        """Readings [m], shape (n_poses,), that this estimate predicts at joint angles q [rad]."""
        readings = model.predict(self.x, q)
        if self.correction is not None:
            readings = readings + self.correction(np.atleast_2d(q))
        return readings

    def residual(self, problem: CalibrationProblem) -> np.ndarray:
        """Predicted minus measured readings of ``problem``'s poses, shape (n_poses,), [m]."""
        if self.correction is None:
            return problem.residual(self.x)
        return problem.residual(self.x) + self.correction(problem.q)

    def converged(self, tolerance: float = 0.05) -> tuple[int, float]:
        """Iterations and evaluations used until the training RMSE first came within
        ``tolerance`` (relative) of its final value."""
        h = np.asarray(self.history)
        k = int(np.argmax(h <= h[-1] * (1.0 + tolerance)))
        return k, float(self.evaluations[k])


class Tracker:
    """Counts evaluations and records the convergence history of one estimate.

    Args:
        problem: The calibration problem.
    """

    def __init__(self, problem: CalibrationProblem) -> None:
        self.problem = problem
        self.nfev = 0.0
        self.history: list[float] = []
        self.evaluations: list[float] = []

    def whitened(self, x0: np.ndarray) -> SearchSpace:
        """The whitened search space at x0 (see :mod:`.search_space`); its Jacobian
        counts as one evaluation."""
        self.nfev += 1
        return SearchSpace.whitened(self.problem, np.asarray(x0, dtype=float))

    def cost(self, x: np.ndarray) -> float:
        """Mean squared residual (eq. 6) [m^2], counted as one evaluation."""
        self.nfev += 1
        return self.problem.cost(x)

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Residual [m], counted as one evaluation."""
        self.nfev += 1
        return self.problem.residual(x)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Identification Jacobian, counted as one evaluation."""
        self.nfev += 1
        return self.problem.jacobian(x)

    def record(self, rmse_m: float) -> None:
        """Append a training RMSE [m] reached with the evaluations counted so far."""
        self.history.append(float(rmse_m))
        self.evaluations.append(self.nfev)

    def result(self, x: np.ndarray, iterations: int, message: str, **extra) -> EstimateResult:
        return EstimateResult(
            x=np.asarray(x, dtype=float).copy(), history=self.history,
            evaluations=self.evaluations, iterations=iterations, nfev=self.nfev,
            message=message, **extra,
        )


def rmse(residual: np.ndarray) -> float:
    """Root mean square of a residual vector, in its unit."""
    return float(np.sqrt(np.mean(np.square(residual))))

"""Extended Kalman filter (paper M1, eq. 17-21) on filterpy's ExtendedKalmanFilter."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter

from ..errors import CalibrationProblem
from .base import EstimateResult, Tracker, rmse
from .search_space import SearchSpace


def filter_moments(
    problem: CalibrationProblem, space: SearchSpace, prior: float, process: float, noise: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """P0, Q and R of the Kalman filters (EKF, UKF) in the search coordinates z.

    In x: P0 = diag((prior * scale)^2) with the model's typical deviation sizes and
    Q = diag((process * scale)^2) per row; both are carried to z = pinv(basis) (x - x0).
    R = noise^2 I for each of a row's values ([m^2]).
    """
    to_z = np.linalg.pinv(space.basis)
    scale = problem.model.scale
    p0 = to_z @ np.diag((prior * scale) ** 2) @ to_z.T
    q = to_z @ np.diag((process * scale) ** 2) @ to_z.T
    return p0, q, noise**2 * np.eye(problem.model.values_per_row)


@dataclass(frozen=True)
class EKF:
    """Recursive estimate of the deviations, one measurement update per pose.

    State: the deviations (eq. 17), constant between poses (F = I), in the whitened
    coordinates of :mod:`.search_space` like every estimator: directions the data
    cannot see are not estimated and stay at x0. P0 = (prior * scale)^2: the model's
    typical deviation sizes (1 mm, 2 mrad for DH) times ``prior``. Q = (process *
    scale)^2 per pose (eq. 18), zero by default since the robot's geometry does not
    change during a session. R = noise^2, the sensor's stated noise. Each update
    relinearises the pose's values at the current state (H_k: the pose's rows of the
    identification Jacobian, eq. 19-21).

    One iteration is one measurement update (``passes`` x poses in all); each costs
    1/n_poses of an evaluation. ``history`` holds the training RMSE before the first
    and after every update (computed for the record, not counted as work);
    ``covariance`` is the final P carried back to x.
    """

    passes: int = 1
    prior: float = 3.0
    process: float = 0.0

    def __call__(
        self, problem: CalibrationProblem, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5
    ) -> EstimateResult:
        track = Tracker(problem)
        space = track.whitened(x0)
        kf = ExtendedKalmanFilter(dim_x=space.dim, dim_z=problem.model.values_per_row)
        kf.x = np.zeros((space.dim, 1))
        kf.P, kf.Q, kf.R = filter_moments(problem, space, self.prior, self.process, noise)
        track.record(rmse(problem.residual(x0)))
        for _ in range(self.passes):
            for k in range(problem.n_poses):
                row = problem.subset(slice(k, k + 1))
                value, jac = row.predict_with_jacobian(space.to_x(kf.x[:, 0]))
                track.nfev += 1.0 / problem.n_poses
                kf.predict()
                kf.update(
                    row.readings.reshape(-1, 1),  # a column, as Hx returns
                    HJacobian=lambda z, h=jac @ space.basis: h,
                    Hx=lambda z, value=value: value.reshape(-1, 1),
                )
                track.record(rmse(problem.residual(space.to_x(kf.x[:, 0]))))
        return track.result(
            space.to_x(kf.x[:, 0]), self.passes * problem.n_poses,
            f"{self.passes} pass(es) over {problem.n_poses} poses",
            covariance=space.basis @ kf.P @ space.basis.T,
        )

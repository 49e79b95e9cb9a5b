"""Extended Kalman filter (paper M1, eq. 17-21) on filterpy's ExtendedKalmanFilter."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter

from ..errors import CalibrationProblem
from .base import EstimateResult, Tracker, rmse


def filter_moments(
    problem: CalibrationProblem, prior: float, process: float, noise: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """P0, Q and R of the Kalman filters (EKF, UKF).

    P0 = diag((prior * scale)^2) with the parameter model's typical deviation sizes,
    Q = diag((process * scale)^2) per pose, R = [[noise^2]] ([m^2]).
    """
    scale = problem.model.params.scale
    return np.diag((prior * scale) ** 2), np.diag((process * scale) ** 2), np.array([[noise**2]])


@dataclass(frozen=True)
class EKF:
    """Recursive estimate of the deviations, one measurement update per pose.

    State: the deviation vector (eq. 17), constant between poses (F = I).
    P0 = diag((prior * scale)^2): the parameter model's typical deviation sizes
    (1 mm, 2 mrad for DH) times ``prior``. Q = (process * scale)^2 per pose (eq. 18),
    zero by default since the robot's geometry does not change during a session.
    R = noise^2, the sensor's stated noise. Each update relinearises the reading at
    the current state (H_k: the pose's row of the identification Jacobian, eq. 19-21).

    One iteration is one measurement update (``passes`` x poses in all); each costs
    1/n_poses of an evaluation. ``history`` holds the training RMSE before the first
    and after every update (computed for the record, not counted as work);
    ``covariance`` is the final P.
    """

    passes: int = 1
    prior: float = 3.0
    process: float = 0.0

    def __call__(
        self, problem: CalibrationProblem, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5
    ) -> EstimateResult:
        n = problem.n_params
        kf = ExtendedKalmanFilter(dim_x=n, dim_z=1)
        kf.x = np.asarray(x0, dtype=float).reshape(n, 1).copy()
        kf.P, kf.Q, kf.R = filter_moments(problem, self.prior, self.process, noise)
        track = Tracker(problem)
        track.record(rmse(problem.residual(kf.x[:, 0])))
        cable = problem.model
        for _ in range(self.passes):
            for k in range(problem.n_poses):
                q = problem.q[k : k + 1]
                value, row = cable.predict_with_jacobian(kf.x[:, 0], q)
                track.nfev += 1.0 / problem.n_poses
                kf.predict()
                kf.update(
                    problem.readings[k : k + 1],
                    HJacobian=lambda x, row=row: row,
                    Hx=lambda x, value=value: value.reshape(1, 1),
                )
                track.record(rmse(problem.residual(kf.x[:, 0])))
        return track.result(
            kf.x[:, 0], self.passes * problem.n_poses,
            f"{self.passes} pass(es) over {problem.n_poses} poses", covariance=kf.P.copy(),
        )

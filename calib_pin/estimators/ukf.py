"""Unscented Kalman filter (paper M3) on filterpy's UnscentedKalmanFilter."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import Callback, EstimateResult, Tracker
from .ekf import filter_moments
from .filterpy_import import kalman
from .problem import LeastSquares, row_offsets
from .subspace import Subspace

# Imported with this module (only when the method is asked for), without scipy.stats.
MerweScaledSigmaPoints = kalman().MerweScaledSigmaPoints
UnscentedKalmanFilter = kalman().UnscentedKalmanFilter


def _symmetric_sqrt(p: np.ndarray) -> np.ndarray:
    """S with S^T S = P for a symmetric P, negative round-off eigenvalues clipped to 0.

    Used instead of filterpy's default Cholesky factor: after many precise updates P is
    nearly singular along the observed directions and Cholesky can fail on round-off.
    """
    w, v = np.linalg.eigh(0.5 * (p + p.T))
    return (v * np.sqrt(np.clip(w, 0.0, None))) @ v.T


class _Predictions:
    """The measurement function of one update: each sigma point's row residual.

    Computed for all of them in one batched call before filterpy's update asks for them.

    filterpy's update calls ``hx(sigma_point)`` once per point; :meth:`__call__` hands
    back the row predicted at that point, found by its bytes. A point not among them
    (none, in filterpy's update) is evaluated on its own: the same numbers either way.
    """

    def __init__(self, row: LeastSquares, space: Subspace, sigmas: np.ndarray) -> None:
        self.row, self.space = row, space
        xs = [space.to_x(s) for s in sigmas]
        batched = getattr(type(row), "residuals", None)  # a problem class that batches points
        values = batched(row, xs) if batched is not None else [row.residual(x) for x in xs]
        self.at = {s.tobytes(): v for s, v in zip(sigmas, values, strict=True)}

    def __call__(self, z: np.ndarray) -> np.ndarray:
        found = self.at.get(np.asarray(z, dtype=float).tobytes())
        return found if found is not None else self.row.residual(self.space.to_x(z))


@dataclass(frozen=True)
class UKF:
    """Recursive estimate of the deviations with sigma points instead of a Jacobian.

    Same state (the whitened coordinates, dimension n), P0, Q and R as
    :class:`.ekf.EKF` (P0 = (prior * scale)^2, Q = (process * scale)^2, R = noise^2);
    the values of pose k are predicted at the 2 n + 1 sigma points of Van der
    Merwe's scaled set (``alpha``, ``beta``, ``kappa``;
    with alpha = 1 and kappa = 0 the centre point has no weight in the mean and the
    others sit at +-sqrt(n) standard deviations), all of them in one batched
    forward-kinematics call (the problem's ``residuals``, where its class has one),
    handed to filterpy's update through its measurement function. No derivative is used.

    One iteration is one measurement update (``passes`` x poses in all); each costs
    (2 n + 1) / n_poses evaluations. ``history`` holds the training RMSE before the
    first and after every update (at most :data:`.base.HISTORY_POINTS` of them, spread
    evenly); ``covariance`` is the final P.
    """

    passes: int = 1
    prior: float = 3.0
    process: float = 0.0
    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        track = Tracker(problem, callback)
        space = track.whitened(x0)
        n = space.dim

        points = MerweScaledSigmaPoints(n, alpha=self.alpha, beta=self.beta, kappa=self.kappa,
                                        sqrt_method=_symmetric_sqrt)
        sizes = np.diff(row_offsets(problem))
        kf = UnscentedKalmanFilter(
            dim_x=n, dim_z=int(sizes[0]), dt=1.0, points=points,
            fx=lambda z, dt: z, hx=lambda z, predicted: predicted(z),
        )
        kf.x = np.zeros(n)
        kf.P, kf.Q, r2 = filter_moments(problem, space, self.prior, self.process, noise)
        noise_of = {int(m): r2 * np.eye(int(m)) for m in np.unique(sizes)}  # R of a row of m values
        kf.R = noise_of[int(sizes[0])]
        track.thin(self.passes * problem.n_rows)
        track.record_at(x0)
        zero_of = {m: np.zeros(m) for m in noise_of}  # the residual is the prediction of a zero measurement
        update = 0
        for _ in range(self.passes):
            for k in range(problem.n_rows):
                kf.predict()
                m = int(sizes[k])
                predicted = _Predictions(problem.subset(slice(k, k + 1)), space, kf.sigmas_f)
                kf.update(zero_of[m], R=noise_of[m], predicted=predicted)
                kf.P = 0.5 * (kf.P + kf.P.T)
                track.nfev += (2 * n + 1) / problem.n_rows
                update += 1
                if track.recording:
                    track.record_update(space.to_x(kf.x), update)
        return track.result(
            space.to_x(kf.x), self.passes * problem.n_rows,
            f"{self.passes} pass(es) over {problem.n_rows} rows",
            covariance=space.basis @ kf.P @ space.basis.T,
        )

"""Extended Kalman filter (paper M1, eq. 17-21) on filterpy's ExtendedKalmanFilter."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import Callback, EstimateResult, Tracker
from .filterpy_import import kalman
from .problem import LeastSquares, data_rows, row_offsets
from .subspace import Subspace

# Imported with this module (only when the method is asked for), without scipy.stats.
ExtendedKalmanFilter = kalman().ExtendedKalmanFilter


def filter_moments(
    problem: LeastSquares, space: Subspace, prior: float, process: float, noise: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """P0, Q and R of the Kalman filters (EKF, UKF) in the search coordinates z.

    In x: P0 = diag((prior * scale)^2) with the model's typical deviation sizes and
    Q = diag((process * scale)^2) per row; both are carried to z = pinv(basis) (x - x0).
    R = noise^2 for each of a row's values ([m^2]): the scalar; a row of k values
    uses noise^2 I_k (rows of several sensors differ in size, see ``row_offsets``).
    """
    to_z = np.linalg.pinv(space.basis)
    scale = problem.scale
    p0 = to_z @ np.diag((prior * scale) ** 2) @ to_z.T
    q = to_z @ np.diag((process * scale) ** 2) @ to_z.T
    return p0, q, np.asarray(noise**2)


#: The largest block of rows linearised together (:func:`row_blocks`).
BLOCK_ROWS = 1024


def row_blocks(n_rows: int) -> list[tuple[int, int]]:
    """The EKF's blocks of rows linearised together, (first, end) each.

    Sizes 1, 2, 4, ... up to :data:`BLOCK_ROWS`, the last one cut at ``n_rows``.
    """
    out, first, size = [], 0, 1
    while first < n_rows:
        out.append((first, min(first + size, n_rows)))
        first += size
        size = min(2 * size, BLOCK_ROWS)
    return out


@dataclass(frozen=True)
class EKF:
    """Recursive estimate of the deviations, one measurement update per pose.

    State: the deviations (eq. 17), constant between poses (F = I), in the whitened
    coordinates of :mod:`calib_pin.estimators.subspace` like every estimator: directions the data
    cannot see are not estimated and stay at x0. P0 = (prior * scale)^2: the model's
    typical deviation sizes (1 mm, 2 mrad for DH) times ``prior``. Q = (process *
    scale)^2 per pose (eq. 18), zero by default since the robot's geometry does not
    change during a session. R = noise^2, the sensor's stated noise. H_k (eq. 19-21)
    is the pose's rows of the identification Jacobian, computed for blocks of rows in
    one batched pass (:func:`row_blocks`: rows 0, 1-2, 3-6, 7-14, ..., the blocks
    doubling up to :data:`BLOCK_ROWS` rows): every row of a block is linearised at the
    estimate z_b left by the update before the block's first row, and its predicted
    residual is carried to the current estimate to first order, h_k(z) = r_k(z_b) +
    H_k(z_b) (z - z_b) (exact for a linear model). Row 0 is linearised at x0; the
    estimate moves most in the first rows, where the blocks are smallest. One Python
    call per block, not one per row (per row, the call overhead is most of the
    Jacobian's cost).

    One iteration is one measurement update (``passes`` x poses in all); each costs
    1/n_poses of an evaluation. ``history`` holds the training RMSE before the first
    and after every update, or after at most :data:`.base.HISTORY_POINTS` of them spread
    evenly (computed for the record, not counted as work);
    ``covariance`` is the final P carried back to x.
    """

    passes: int = 1
    prior: float = 3.0
    process: float = 0.0

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        track = Tracker(problem, callback)
        space = track.whitened(x0)

        sizes = np.diff(row_offsets(problem))
        kf = ExtendedKalmanFilter(dim_x=space.dim, dim_z=int(sizes[0]))
        kf.x = np.zeros((space.dim, 1))
        kf.P, kf.Q, r2 = filter_moments(problem, space, self.prior, self.process, noise)
        noise_of = {int(m): r2 * np.eye(int(m)) for m in np.unique(sizes)}  # R of a row of m values
        kf.R = noise_of[int(sizes[0])]
        track.thin(self.passes * problem.n_rows)
        track.record_at(x0)
        offsets = row_offsets(problem)
        batched = len(data_rows(problem)) == problem.n_rows  # subset(rows) takes data rows only
        # Per row, as Python numbers: its size, and the measurement and noise of that size.
        row_noise = [noise_of[int(m)] for m in sizes]
        share = 1.0 / problem.n_rows
        update = 0
        for _ in range(self.passes):
            for first, end in row_blocks(problem.n_rows):
                # One batched residual and Jacobian for the block, at the current estimate (z_b).
                z_b = kf.x.copy()
                x_b = space.to_x(z_b[:, 0])
                if batched:
                    block = problem.subset(np.arange(first, end))
                    residual, jac = block.residual(x_b), block.jacobian(x_b) @ space.basis
                else:  # rows that are no data rows (a contact set's distances): row by row, at the same z_b
                    pairs = [problem.row_residual_with_jacobian(x_b, k) for k in range(first, end)]
                    residual = np.concatenate([r for r, _ in pairs])
                    jac = np.vstack([j for _, j in pairs]) @ space.basis
                at = (offsets[first : end + 1] - offsets[first]).tolist()
                for k, start, stop in zip(range(first, end), at[:-1], at[1:], strict=True):
                    track.nfev += share
                    if self.process:  # F = I: with Q = 0 the prediction leaves x and P as they are
                        kf.predict()
                    h, r = jac[start:stop], residual[start:stop, None]
                    # The residual (predicted - measured) is the prediction of a zero measurement,
                    # given as the number 0.0: filterpy's innovation 0.0 - h(x) has the bits of
                    # zeros((m, 1)) - h(x), and its deepcopy of the measurement is then cheap.
                    kf.update(0.0, HJacobian=lambda z, h=h: h,
                              Hx=lambda z, h=h, r=r, z_b=z_b: r + h @ (z - z_b), R=row_noise[k])
                    update += 1
                    if track.recording:
                        track.record_update(space.to_x(kf.x[:, 0]), update)
        return track.result(
            space.to_x(kf.x[:, 0]), self.passes * problem.n_rows,
            f"{self.passes} pass(es) over {problem.n_rows} rows",
            covariance=space.basis @ kf.P @ space.basis.T,
        )

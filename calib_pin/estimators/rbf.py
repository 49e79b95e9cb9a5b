"""Radial-basis-function network (paper M5): learns the error of the values, not the robot.

scipy's RBFInterpolator (with a degree-1 polynomial tail) maps each row's inputs to the
error of the model at x0 (measured minus predicted, [m]; a vector for a position) on the
training rows. Predictions are then the model's values plus the network's output.

Inputs (``features``): ``sincos``, the sine and cosine of every joint angle (the forward
kinematics is a sum of products of them, and 0 and 2 pi are the same angle), or
``angles``, the raw joint angles [rad]. For a sensor that
measures several points per pose (markers), the row's point index enters as dummy
columns of size ``point_scale``. Input columns constant on the training rows are dropped.

The kernel, its shape parameter epsilon (for the kernels that take one) and the
smoothing (the regularisation added to the kernel matrix) are chosen together by
``folds``-fold cross-validation over the training poses (all rows of one configuration
in the same fold): the grid point with the least held-out squared error wins, unless
no grid point beats a zero correction (then the correction is zero: nothing learnable).

Above :data:`MAX_CENTRES` training rows the network is fitted, and its settings
cross-validated, on a seeded subset of whole poses holding at most that many rows (every
row still counts in the result's residual): a dense network costs the cube of its
centres; with the bound the cost is a constant plus one prediction per row (linear in
the rows). At or below it every row is a centre.

It yields **no kinematic parameters**: ``x`` stays at x0 and the result carries a
``correction(q, points)`` instead, so calib-pin exports no URDF for it. It corrects only
this sensor's values (at the points it was trained on), and only near the training
poses. :mod:`.lm_rbf` runs it on what a geometric fit leaves.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RBFInterpolator

from ..exceptions import EstimatorError
from .base import Callback, EstimateResult, Tracker, rmse
from .problem import LeastSquares

#: Most training rows that become the network's centres (see the module docstring).
MAX_CENTRES = 800

#: scipy kernels that need a shape parameter epsilon.
EPSILON_KERNELS = ("gaussian", "multiquadric", "inverse_multiquadric", "inverse_quadratic")


@dataclass(frozen=True)
class Inputs:
    """How joint angles [rad] and point indices become the network's input rows."""

    features: str
    n_points: int
    point_scale: float
    keep: np.ndarray | None = None  # input columns kept (None: all)

    def __call__(self, q: np.ndarray, points: np.ndarray | None) -> np.ndarray:
        q = np.atleast_2d(q)
        columns = [np.hstack([np.sin(q), np.cos(q)]) if self.features == "sincos" else q]
        if self.n_points > 1:
            if points is None or np.any((points < 0) | (points >= self.n_points)):
                raise EstimatorError(f"the RBF correction knows points 0..{self.n_points - 1} only")
            columns.append(self.point_scale * (np.asarray(points)[:, None] == np.arange(1, self.n_points)))
        rows = np.hstack(columns)
        return rows if self.keep is None else rows[:, self.keep]


@dataclass(frozen=True)
class RBF:
    """RBF network settings.

    Attributes:
        features: ``sincos`` (sin and cos of the joint angles) or ``angles`` (raw [rad]).
        kernels: scipy RBFInterpolator kernels tried by cross-validation.
        epsilons: Shape parameters tried for the kernels of ``EPSILON_KERNELS``
            [1 / input unit].
        smoothing: Smoothing values tried by cross-validation.
        degree: Degree of the polynomial tail.
        point_scale: Size of the point-index dummy columns (input units).
        folds: Cross-validation folds (at most the number of poses).
    """

    features: str = "sincos"
    kernels: tuple[str, ...] = ("thin_plate_spline", "cubic", "gaussian", "multiquadric")
    epsilons: tuple[float, ...] = (0.2, 0.5, 1.0, 2.0)
    smoothing: tuple[float, ...] = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0, 1000.0)
    degree: int = 1
    point_scale: float = 1.0
    folds: int = 5

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        track = Tracker(problem, callback)
        x0 = np.asarray(x0, dtype=float)
        error = -track.residual(x0).reshape(problem.n_rows, -1)  # measured minus predicted, [m]
        track.record(rmse(error))
        q = problem.q  # type: ignore[attr-defined]  # RBF learns over the joint angles
        points = getattr(problem, "points", None)
        inputs = self.inputs(q, points)
        features = inputs(q, points)
        _, pose = np.unique(q, axis=0, return_inverse=True)  # rows of one configuration share a fold
        pose = pose.ravel()
        centres = centre_rows(pose, seed)
        subset = len(centres) < len(pose)
        if subset:
            features, error, pose = features[centres], error[centres], np.unique(pose[centres], return_inverse=True)[1]
        n_poses = int(pose.max()) + 1
        fold = np.random.default_rng(seed).permutation(n_poses)[pose] % min(self.folds, n_poses)
        scores = {g: _cv_error(features, error, fold, g, self.degree) for g in self.grid()}
        kernel, epsilon, smoothing = min(scores, key=scores.__getitem__)
        cv = f"by {fold.max() + 1}-fold cross-validation" + (
            f" ({len(centres)} of {problem.n_rows} rows as centres)" if subset else "")
        if scores[kernel, epsilon, smoothing] >= float(np.sum(error**2)):  # no network beats adding nothing
            width = error.shape[1]
            result = track.result(x0, 1, f"no network: none beat a zero correction {cv}",
                                  correction=lambda q_new, points_new: np.zeros((len(np.atleast_2d(q_new)), width)))
        else:
            net = RBFInterpolator(features, error, kernel=kernel, epsilon=epsilon, degree=self.degree,
                                  smoothing=smoothing)
            shape = f", epsilon {epsilon:g}" if kernel in EPSILON_KERNELS else ""
            result = track.result(
                x0, 1, f"{kernel} network on {self.features} inputs{shape}, smoothing {smoothing:g} {cv}",
                correction=lambda q_new, points_new: net(inputs(q_new, points_new)),
            )
        if track.recording:
            track.record(rmse(result.residual(problem)))
        return result

    def inputs(self, q: np.ndarray, points: np.ndarray | None) -> Inputs:
        """The input map fitted to the training rows: constant columns dropped.

        Args:
            q: The training rows' joint angles, shape (n_rows, n_joints), [rad].
            points: Their point indices, shape (n_rows,), or None for a one-point sensor.

        Raises:
            EstimatorError: unknown ``features``.
        """
        if self.features not in ("sincos", "angles"):
            raise EstimatorError(f"unknown RBF features '{self.features}' (valid: sincos, angles)")
        n_points = 1 if points is None else int(np.max(points)) + 1
        every = Inputs(self.features, n_points, self.point_scale)
        return Inputs(self.features, n_points, self.point_scale, np.ptp(every(q, points), axis=0) > 1e-12)

    def grid(self) -> list[tuple[str, float, float]]:
        """Every (kernel, epsilon, smoothing) tried; epsilon 1 for kernels without one."""
        return [(k, e, s) for k in self.kernels
                for e, s in itertools.product(self.epsilons if k in EPSILON_KERNELS else (1.0,), self.smoothing)]


def centre_rows(pose: np.ndarray, seed: int) -> np.ndarray:
    """The rows that become centres: all of them, or whole poses up to :data:`MAX_CENTRES` rows.

    All when there are at most :data:`MAX_CENTRES`, else the rows of whole poses, taken in
    a seeded random order while they fit in that many.

    Args:
        pose: Each row's pose index, shape (n_rows,).
    """
    if len(pose) <= MAX_CENTRES:
        return np.arange(len(pose))
    n_poses = int(pose.max()) + 1
    order = np.random.default_rng(seed).permutation(n_poses)
    counts = np.bincount(pose, minlength=n_poses)[order]
    chosen = np.zeros(n_poses, dtype=bool)
    chosen[order[np.cumsum(counts) <= MAX_CENTRES]] = True
    return np.flatnonzero(chosen[pose])


def _cv_error(features: np.ndarray, error: np.ndarray, fold: np.ndarray, setting: tuple[str, float, float],
              degree: int) -> float:
    """Held-out squared error [m^2] summed over the folds; inf where a fit is singular."""
    kernel, epsilon, smoothing = setting
    total = 0.0
    for k in range(fold.max() + 1):
        held = fold == k
        try:
            net = RBFInterpolator(features[~held], error[~held], kernel=kernel, epsilon=epsilon,
                                  degree=degree, smoothing=smoothing)
        except (ValueError, np.linalg.LinAlgError):
            return np.inf
        total += float(np.sum((net(features[held]) - error[held]) ** 2))
    return total

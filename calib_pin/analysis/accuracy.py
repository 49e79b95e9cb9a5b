"""How accurate the calibrated robot is where it works: the predicted position error of named points.

A user asks "how far is my tool from where the calibrated model puts it?", at poses all
over the workspace, not at the point the sensor measured. For each point fixed in the end
frame (the measured points, the flange origin, a tool), the predicted error in the base
frame is the sum of three independent parts, each shown:

- **noise**: the reading noise carried through the estimate along the directions the data
  determines (:mod:`calib_pin.analysis.determined`): the residual's noise, or, where the
  residual is known to be above the sensor's repeatability, the repeatability (the rest is
  the model's part, not counted twice);
- **model**: what the model does not explain. Each set's residual per value (on its
  held-out rows when there are enough, else its training rows with their degrees of
  freedom) above the sensor's repeatability (:mod:`calib_pin.analysis.repeatability`) is an
  error the robot makes at every pose, taken as isotropic: sqrt(3) times it in 3-D. With
  the repeatability unknown it is not counted, and the whole residual is shown as its
  upper bound (``model_bound``);
- **blind**: the directions the data does not determine, where the calibrated robot is the
  start: the robot's true deviation along them, bounded by the stated
  :class:`~calib_pin.parameters.prior.Prior`.

Each is an RMS over random workspace poses; the total's 95th percentile is of the error's
length, drawn from the three at each pose. Much of the blind part is often where the whole
arm sits (a turn about a cable's anchor, the base under a tracker whose frame is
estimated): ``registered`` is the RMS once the best rigid motion of the point's positions
over the workspace is taken out, which is what a user who registers the robot in the cell
(as the sensor's own frame did) sees.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..estimators.subspace import RCOND
from ..parameters.prior import Prior
from ..robot.poses import random_poses
from .determined import Determined, pinv_gram
from .repeatability import Repeatability

#: A named point: its name, where it is in the end frame (3,) [m], and its derivative with
#: respect to the unknowns (3, n_params) when the sensor estimates it, else None.
NamedPoint = tuple[str, np.ndarray, np.ndarray | None]

#: Random workspace poses the accuracy is averaged over.
WORKSPACE_POSES = 500
#: Draws per pose for the 95th percentile of the error's length.
DRAWS = 64
#: A point whose blind part carries more than this share of its error variance is not
#: determined by the data: its accuracy is mostly the prior's.
BLIND_SHARE = 0.5
#: Held-out values below this count: the training rows' residual is used instead.
MIN_HELD_OUT = 10
#: A residual counts as above the repeatability only beyond this many standard errors of its square.
SIGNIFICANT = 2.0
#: A residual this many times the repeatability is "far above" it (a warning).
FAR_ABOVE = 2.0


@dataclass(frozen=True)
class Unexplained:
    """A set's residual per value against its sensor's repeatability.

    Attributes:
        label: The set.
        residual: RMS per value, [m]: held-out rows (divided by sqrt(1 + r/m) for the
            estimate's own error there) or training rows (sqrt(RSS / (m - r))).
        source: Which rows, for people.
        values: How many values it is from.
        repeatability: The sensor's repeatability.
        model: The part of ``residual`` above the repeatability, [m] per value (0 when not
            significantly above, or when the repeatability is unknown).
    """

    label: str
    residual: float
    source: str
    values: int
    repeatability: Repeatability
    model: float

    @property
    def bound(self) -> float:
        """The most the model may leave unexplained, [m] per value.

        The most the model may leave unexplained, [m] per value: :attr:`model`, or the whole
        residual when the repeatability is unknown.
        """
        return self.residual if self.repeatability.sigma is None else self.model

    @property
    def far_above(self) -> bool:
        """The residual is far above a known repeatability: not reading noise."""
        rep = self.repeatability.sigma
        return rep is not None and self.model > 0 and self.residual > FAR_ABOVE * rep

    def warning(self) -> str | None:
        """One line when the residual is far above the repeatability, with the likely causes."""
        if not self.far_above:
            return None
        rep = self.repeatability
        assert rep.sigma is not None
        return (f"{self.label}: the residual ({self.residual * 1e3:.3g} mm per value, {self.source}) is "
                f"{self.residual / rep.sigma:.0f} times the sensor's repeatability ({rep.sigma * 1e3:.3g} mm, "
                f"{rep.source}): the model leaves {self.model * 1e3:.3g} mm unexplained; likely causes: joint "
                "readings not in step with the measurement, compliance not modelled (--compliance), the wrong "
                "tool point or marker, thermal drift")

    def as_dict(self) -> dict[str, object]:
        return {"label": self.label, "residual_mm": self.residual * 1e3, "source": self.source,
                "values": self.values, "repeatability": self.repeatability.as_dict(),
                "unexplained_mm": self.model * 1e3, "unexplained_bound_mm": self.bound * 1e3,
                "far_above_repeatability": self.far_above}


def unexplained(label: str, train_residual: np.ndarray, test_residual: np.ndarray, rank: int,
                train_values: int, rep: Repeatability) -> Unexplained:
    """A set's :class:`Unexplained` from its residuals in metres (unweighted, flattened).

    Args:
        rank: Directions the fit estimated (its share of the training degrees of freedom
            is taken in proportion to the set's values, ``train_values`` of the fit's).
    """
    test = np.asarray(test_residual, dtype=float)
    train = np.asarray(train_residual, dtype=float)
    share = rank * len(train) / max(train_values, 1)
    if len(test) >= MIN_HELD_OUT:
        residual = float(np.sqrt(np.mean(test**2) / (1.0 + share / max(len(train), 1))))
        source, n = f"{len(test)} held-out values", len(test)
    else:
        residual = float(np.sqrt(train @ train / max(len(train) - share, 1.0)))
        source, n = f"{len(train)} training values, RSS / (m - r)", len(train)
    sigma, model = rep.sigma, 0.0
    if sigma is not None:
        excess = residual**2 - sigma**2
        model = float(np.sqrt(excess)) if excess > SIGNIFICANT * sigma**2 * np.sqrt(2.0 / max(n, 1)) else 0.0
    return Unexplained(label, residual, source, n, rep, model)


@dataclass(frozen=True)
class PointAccuracy:
    """The predicted position error of one point of the end frame over the workspace.

    Attributes:
        name: What the point is (``hook``, ``flange origin``, ``tool``, ``marker 2``).
        point: The point in the end frame, shape (3,), [m].
        rms, p95: RMS and 95th percentile of the error's length, [m], base frame.
        noise, model, blind: RMS of each part (module docstring), [m].
        registered: The RMS error after the best rigid motion of the point's positions over
            the workspace is taken out, [m].
        model_bound: The most the model part may be, [m] (above ``model`` when a sensor's
            repeatability is unknown: the total may then be up to
            sqrt(rms^2 - model^2 + model_bound^2)).
    """

    name: str
    point: np.ndarray
    rms: float
    p95: float
    noise: float
    model: float
    blind: float
    registered: float
    model_bound: float = 0.0

    @property
    def rms_bound(self) -> float:
        """The RMS error with the model part at its bound, [m]."""
        return float(np.sqrt(self.rms**2 - self.model**2 + max(self.model_bound, self.model) ** 2))

    @property
    def determined(self) -> bool:
        """The data, not the prior, sets most of this point's error."""
        return self.blind**2 <= BLIND_SHARE * self.rms**2

    def as_dict(self) -> dict[str, object]:
        return {"name": self.name, "point_mm": (self.point * 1e3).tolist(), "rms_mm": self.rms * 1e3,
                "p95_mm": self.p95 * 1e3, "registered_rms_mm": self.registered * 1e3, "noise_mm": self.noise * 1e3,
                "model_mm": self.model * 1e3,
                "blind_mm": self.blind * 1e3, "model_bound_mm": self.model_bound * 1e3,
                "rms_bound_mm": self.rms_bound * 1e3, "determined": self.determined}


@dataclass(frozen=True)
class Accuracy:
    """Predicted accuracy of the calibrated robot at named points over the workspace.

    Attributes:
        points: Each point's :class:`PointAccuracy`.
        poses: Random workspace poses averaged over.
        prior: The prior bounding the blind part.
        model_error: The unexplained error per value shared by every point, [m] (1 sigma
            per coordinate); ``model_bound``: the most it may be (a repeatability unknown).
        sets: Each set's residual against its repeatability.
        workspace_points: The first point at each workspace pose, shape (poses, 3), [m],
            base frame (calibrated robot).
        workspace_error: Its predicted RMS error at each pose, shape (poses,), [m].
    """

    points: tuple[PointAccuracy, ...]
    poses: int
    prior: Prior
    model_error: float
    model_bound: float
    sets: tuple[Unexplained, ...]
    workspace_points: np.ndarray = field(repr=False)
    workspace_error: np.ndarray = field(repr=False)

    def as_dict(self) -> dict[str, object]:
        return {"points": [p.as_dict() for p in self.points], "poses": self.poses, "prior": self.prior.as_dict(),
                "model_error_mm_per_coordinate": self.model_error * 1e3,
                "model_bound_mm_per_coordinate": self.model_bound * 1e3,
                "sets": [s.as_dict() for s in self.sets]}

    def warnings(self) -> list[str]:
        """Lines a user must read: a residual far above the repeatability."""
        return [w for w in (s.warning() for s in self.sets) if w]


def _reading_share(sets: Sequence[Unexplained], noise: float) -> float:
    """How much of the residual's noise ``noise`` is the sensor's reading noise: its known
    repeatability over it (at most 1), for one set whose repeatability is known and whose
    residual is significantly above it; 1 otherwise (the whole residual drives the estimate's
    error, and the model part is then only a bound or zero)."""
    if len(sets) != 1 or sets[0].repeatability.sigma is None or sets[0].model <= 0 or noise <= 0:
        return 1.0
    return float(min(sets[0].repeatability.sigma / noise, 1.0))


def _rms(cov: np.ndarray) -> float:
    """The RMS length of errors with covariances ``cov`` (n, 3, 3) over the poses, [m]."""
    return float(np.sqrt(max(float(np.trace(cov, axis1=1, axis2=2).mean()), 0.0)))


def _rigid_share(points: np.ndarray, jac: np.ndarray, cov: np.ndarray) -> float:
    """Mean squared error over the poses that a rigid motion of the positions explains, [m^2].

    Mean over the poses of the squared error that a rigid motion of the positions
    ``points`` (n, 3) [m] explains, for errors J dx with dx ~ (0, cov): the projection of the
    stacked error field onto the six rigid fields v + w x p.
    """
    n = len(points)
    centre = points - points.mean(axis=0)
    fields = np.zeros((n, 3, 6))
    fields[:, :, :3] = np.eye(3)
    fields[:, 0, 4], fields[:, 0, 5] = centre[:, 2], -centre[:, 1]   # w x p: x = wy pz - wz py
    fields[:, 1, 3], fields[:, 1, 5] = -centre[:, 2], centre[:, 0]   # y = wz px - wx pz
    fields[:, 2, 3], fields[:, 2, 4] = centre[:, 1], -centre[:, 0]   # z = wx py - wy px
    basis, _ = np.linalg.qr(fields.reshape(3 * n, 6))
    projected = basis.T @ jac.reshape(3 * n, -1)  # (6, n_params)
    return float(np.trace(projected @ cov @ projected.T)) / n


def predict_accuracy(problem: Any, x: np.ndarray, split: Determined, points: Sequence[NamedPoint],
                     sets: Sequence[Unexplained], prior: Prior, poses: int = WORKSPACE_POSES, seed: int = 0,
                     rcond: float = RCOND) -> Accuracy:
    """The predicted accuracy at ``points`` of the robot calibrated to x.

    Args:
        problem: The training rows' problem (residual in units of ``split.noise``).
        x: The estimate, shape (n_params,), SI.
        split: What the training rows determine at x.
        points: Each point: its name, where it is in the end frame (3,) [m], and its
            derivative with respect to x, shape (3, n_params), for a point the sensor
            estimates (a marker, a contact set's tool point), else None.
        sets: Each set's residual against its repeatability (the model part).
        prior: The prior that bounds the blind part (the one ``split`` was made with).
        poses, seed: Random workspace poses and their seed.
        rcond: The estimators' relative cut.
    """
    model = problem.model
    noise_cov, blind_cov = split.covariance()
    reading = _reading_share(sets, split.noise)
    noise_cov = noise_cov * reading**2  # the reading noise's part; the model's is its own part
    values = sum(s.values for s in sets)
    model_error = float(np.sqrt(sum(s.model**2 * s.values for s in sets) / values)) if values else 0.0
    model_bound = float(np.sqrt(sum(s.bound**2 * s.values for s in sets) / values)) if values else 0.0
    q = random_poses(model.chain, poses, np.random.default_rng(seed))
    rotations, _ = model.end_frames(x, q)
    rng = np.random.default_rng(seed + 1)
    moved = (_sensor_response(problem, split, noise_cov, split.noise * reading, rcond)
             if any(d is not None for _, _, d in points) else None)
    out, first_points, first_error = [], np.zeros((poses, 3)), np.zeros(poses)
    for k, (name, point, derivative) in enumerate(points):
        where, jac = model.point_jacobian(x, q, np.asarray(point, dtype=float))
        if derivative is None:
            parts = [(jac, noise_cov), (jac, blind_cov)]
        else:  # the point moves with the sensor's unknowns: what the robot leaves, the sensor takes
            assert moved is not None
            full_cov, response = moved
            full = jac + rotations @ derivative  # (n, 3, n_params)
            effective = jac[:, :, split.robot] + rotations @ (derivative @ response)  # (n, 3, n_robot)
            parts = [(full, full_cov), (effective, blind_cov[np.ix_(split.robot, split.robot)])]
        a, b = (j @ c @ j.transpose(0, 2, 1) for j, c in parts)
        cov = a + b + model_error**2 * np.eye(3)
        per_pose = np.trace(cov, axis1=1, axis2=2)
        rigid = sum(_rigid_share(np.asarray(where).reshape(-1, 3), j, c) for j, c in parts)
        vals, vecs = np.linalg.eigh(cov)
        draws = rng.standard_normal((poses, DRAWS, 3)) * np.sqrt(np.clip(vals, 0.0, None))[:, None, :]
        lengths = np.linalg.norm(draws @ vecs.transpose(0, 2, 1), axis=2)
        out.append(PointAccuracy(
            name=name, point=np.asarray(point, dtype=float), rms=float(np.sqrt(per_pose.mean())),
            p95=float(np.percentile(lengths, 95)), noise=_rms(a), model=float(np.sqrt(3.0) * model_error), blind=_rms(b),
            registered=float(np.sqrt(max(per_pose.mean() - rigid, 0.0))), model_bound=float(np.sqrt(3.0) * model_bound)))
        if k == 0:
            first_points, first_error = np.asarray(where).reshape(-1, 3), np.sqrt(per_pose)
    return Accuracy(points=tuple(out), poses=poses, prior=prior, model_error=model_error, model_bound=model_bound,
                    sets=tuple(sets), workspace_points=first_points, workspace_error=first_error)


def _sensor_response(problem: Any, split: Determined, noise_cov: np.ndarray, noise: float,
                     rcond: float) -> tuple[np.ndarray, np.ndarray]:
    """The free unknowns' noise covariance, and how the sensor's unknowns follow the robot's.

    The second, G ((n_params, n_robot)), is the sensor's least-squares refit after a move of
    the free robot unknowns. The first (SI, (n_params, n_params)) is the robot's noise
    covariance along the directions the data determines (``noise_cov``, in the gauge: the
    others are the blind part) carried to the sensor by G, plus the sensor's own given the
    robot (the pseudo-inverse of its scaled Gram matrix, cut at ``rcond``, for residual noise
    ``noise`` [m]).
    """
    n = problem.n_params
    free, gram = split.free, split.gram
    scale = np.asarray(problem.model.scale, dtype=float)[free]
    on_robot = np.isin(free, split.robot)
    sensor = free[~on_robot]
    response = np.zeros((n, len(split.robot)))
    own = np.zeros((n, n))
    if len(sensor):
        inverse = pinv_gram(gram[np.ix_(~on_robot, ~on_robot)], rcond)
        solved = inverse @ gram[np.ix_(~on_robot, on_robot)]
        response[sensor] = -(scale[~on_robot][:, None] * solved) / scale[on_robot][None, :]
        own[np.ix_(sensor, sensor)] = noise**2 * scale[~on_robot][:, None] * inverse * scale[~on_robot][None, :]
    carry = np.zeros((n, n))
    carry[:, split.robot] = response
    carry[split.robot, split.robot] = 1.0
    robot_cov = noise_cov[np.ix_(split.robot, split.robot)]
    full_cov = carry[:, split.robot] @ robot_cov @ carry[:, split.robot].T + own
    return full_cov, response

"""Choosing poses that make the parameters observable (D-optimal greedy design).

From ``candidates`` random poses within the joint limits (tool point above the mounting
plane), the planner picks ``n`` one at a time, each the candidate that most increases
log det of the information matrix of the identifiable directions (the scaled
identification Jacobian projected on the directions the whole candidate set can see).
That maximises the observability index O1 (the geometric mean of the singular values).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..problem import CalibrationProblem
from ..progress import progress
from ..robot.poses import random_poses
from ..sensors.base import MeasurementModel
from .identifiability import analyze
from .subspace import Subspace

#: Regularisation of the starting information matrix (relative to the largest row norm^2).
RIDGE = 1e-6


@dataclass(frozen=True)
class Plan:
    """A pose plan.

    Attributes:
        q: Chosen poses in order of choice, shape (n, n_joints), [rad].
        o1, o3: Observability indices of the chosen set (:mod:`.identifiability`).
        random_o1, random_o3: The same for the first n candidates (random poses).
        reach: Poses of the plan whose total information (geometric mean of the
            singular values, O1 x sqrt(poses)) reaches ``target``, or None.
        target: That total information of the n random poses, unless given.
    """

    q: np.ndarray
    o1: float
    o3: float
    random_o1: float
    random_o3: float
    reach: int | None
    target: float


def _above_base(model: MeasurementModel, q: np.ndarray) -> np.ndarray:
    """The poses that put the sensor's reference point above the mounting plane (z > 0)."""
    return q[model.points_at(None, q, model.reference_point)[:, 2] > 0.0]


def _rows(model: MeasurementModel, q: np.ndarray) -> np.ndarray:
    """Scaled identification rows of each pose, shape (n_poses, rows per pose, n_params):
    every point the sensor measures, every value of each."""
    rows, points = model.grid_points(len(q))
    jac = model.predict_with_jacobian(np.zeros(model.n_params), q[rows], points)[1] * model.scale
    return jac.reshape(len(q), -1, model.n_params)


def _greedy(z: np.ndarray, n: int) -> list[int]:
    """D-optimal greedy choice of n poses from per-pose blocks z (n_poses, k, r): each
    step adds the pose with the largest log det gain (a rank-k update of the inverse)."""
    inverse = np.eye(z.shape[2]) / (RIDGE * np.max(np.sum(z**2, axis=(1, 2))))
    chosen: list[int] = []
    available = np.ones(len(z), dtype=bool)
    for _ in progress(range(n), desc="choosing poses"):
        inner = np.eye(z.shape[1]) + np.einsum("nij,jk,nlk->nil", z, inverse, z)
        gain = np.linalg.slogdet(inner)[1]
        gain[~available] = -np.inf
        k = int(np.argmax(gain))
        chosen.append(k)
        available[k] = False
        v = inverse @ z[k].T
        inverse -= v @ np.linalg.solve(np.eye(z.shape[1]) + z[k] @ v, v.T)
    return chosen


def plan_poses(
    model: MeasurementModel, n: int, candidates: int = 5000, *, seed: int = 0,
    margin: float = np.deg2rad(5.0), target: float | None = None,
) -> Plan:
    """Pick ``n`` of ``candidates`` random poses that maximise O1 for ``model``'s sensor.

    Args:
        model: The measurement model (robot, parameter model, sensor geometry).
        n: Poses to choose.
        candidates: Random poses to choose from.
        seed: Seed of the candidates.
        margin: Distance kept from every joint limit, [rad].
        target: Report how many chosen poses reach this total information (geometric
            mean of the singular values; default: that of n random poses).
    """
    rng = np.random.default_rng(seed)
    pool = _above_base(model, random_poses(model.chain, candidates, rng, margin=margin))
    if len(pool) < n:
        raise ValueError(f"only {len(pool)} of {candidates} candidates put the tool point above the base; ask for more")
    blocks = _rows(model, pool)
    basis = Subspace.of(blocks.reshape(-1, model.n_params), np.ones(model.n_params)).vt.T
    q = pool[_greedy(blocks @ basis, n)]  # candidates in the identifiable directions

    def indices(qs: np.ndarray) -> tuple[float, float, float]:
        rows, points = model.grid_points(len(qs))
        predicted = model.predict(None, qs[rows], points)  # the readings do not matter here, only the Jacobian
        result = analyze(CalibrationProblem(model, qs[rows], predicted, points))
        return result.o1, result.o3, result.o1 * np.sqrt(len(qs))

    o1, o3, _ = indices(q)
    random_o1, random_o3, random_total = indices(pool[:n])
    target = random_total if target is None else target
    reach = next((k for k in range(basis.shape[1], n + 1) if indices(q[:k])[2] >= target), None)
    return Plan(q, o1, o3, random_o1, random_o3, reach, target)

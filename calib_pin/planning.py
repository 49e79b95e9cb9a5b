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

from .identifiability import analyze
from .problem import CalibrationProblem
from .progress import progress
from .sensors import CableModel
from .simulation import random_poses
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


def _tool_above_base(model: CableModel, q: np.ndarray) -> np.ndarray:
    return q[model.tool_positions(None, q)[:, 2] > 0.0]


def plan_poses(
    model: CableModel, n: int, candidates: int = 5000, *, seed: int = 0,
    margin: float = np.deg2rad(5.0), target: float | None = None,
) -> Plan:
    """Pick ``n`` of ``candidates`` random poses that maximise O1 for ``model``'s sensor.

    Args:
        model: The cable model (robot, parameter model, sensor geometry).
        n: Poses to choose.
        candidates: Random poses to choose from.
        seed: Seed of the candidates.
        margin: Distance kept from every joint limit, [rad].
        target: Report how many chosen poses reach this total information (geometric
            mean of the singular values; default: that of n random poses).
    """
    rng = np.random.default_rng(seed)
    pool = _tool_above_base(model, random_poses(model.chain, candidates, rng, margin=margin))
    if len(pool) < n:
        raise ValueError(f"only {len(pool)} of {candidates} candidates put the tool point above the base; ask for more")
    zero = np.zeros(model.n_params)
    jacobian = model.predict_with_jacobian(zero, pool)[1]
    basis = Subspace.of(jacobian, model.scale).vt.T
    z = (jacobian * model.scale) @ basis  # candidates in the identifiable directions
    inverse = np.eye(basis.shape[1]) / (RIDGE * np.max(np.sum(z**2, axis=1)))
    chosen: list[int] = []
    available = np.ones(len(pool), dtype=bool)
    for _ in progress(range(n), desc="choosing poses"):
        gain = np.einsum("ij,jk,ik->i", z, inverse, z)
        gain[~available] = -np.inf
        k = int(np.argmax(gain))
        chosen.append(k)
        available[k] = False
        v = inverse @ z[k]
        inverse -= np.outer(v, v) / (1.0 + z[k] @ v)
    q = pool[chosen]

    def indices(qs: np.ndarray) -> tuple[float, float, float]:
        result = analyze(CalibrationProblem(model, qs, np.zeros(len(qs))))
        return result.o1, result.o3, result.o1 * np.sqrt(len(qs))

    o1, o3, _ = indices(q)
    random_o1, random_o3, random_total = indices(pool[:n])
    target = random_total if target is None else target
    reach = next((k for k in range(basis.shape[1], n + 1) if indices(q[:k])[2] >= target), None)
    return Plan(q, o1, o3, random_o1, random_o3, reach, target)

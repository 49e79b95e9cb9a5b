"""Choosing poses that make the parameters observable (D-optimal greedy design).

From ``candidates`` random poses within the joint limits (tool point above the mounting
plane), the planner picks ``n`` one at a time, each the candidate that most increases
log det of the information matrix of the identifiable directions (the scaled
identification Jacobian projected on the directions the whole candidate set can see).
That maximises the observability index O1 (the geometric mean of the singular values).

Any sensor is planned for through its measurement model; several sensors at once (a
drawstring and a tracker reading at every pose) through a :class:`SensorMix`: one robot,
each sensor's own unknowns, each sensor's rows weighted by sigma_0 / sigma_k (its noise),
so that the design is D-optimal on the stacked, weighted identification Jacobian the
calibration will see. :attr:`Plan.identifiability` says what the chosen set can identify.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..estimators.subspace import Subspace
from ..exceptions import ArgumentError, CalibPinError
from ..robot.poses import random_poses
from ..sensors.base import MeasurementModel
from ..sensors.problem import SetProblem
from ..util.progress import progress
from .identifiability import Identifiability, analyze

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
        identifiability: What the chosen poses can identify (rank, the unknowns they
            cannot see, the combinations seen only together), for the planned model.
    """

    q: np.ndarray
    o1: float
    o3: float
    random_o1: float
    random_o3: float
    reach: int | None
    target: float
    identifiability: Identifiability | None = None
    #: What each chosen pose measures, for a sensor that makes its own candidates (its
    #: ``plan_candidates``): a contact set's fixture (touches found by inverse kinematics), a
    #: camera's corners in view; else None.
    points: np.ndarray | None = None


class SensorMix(MeasurementModel):
    """Several sensors reading at every pose, as one measurement model to plan for.

    A row is one pose: every value of every part (each part's :meth:`grid_points`: all its
    points), part k's multiplied by w_k = sigma_0 / sigma_k. The unknowns are the robot's
    (deviations and compliances, shared) and then each part's own, named ``<label>:<name>``.

    Args:
        parts: The sensors' measurement models (one chain, one parameter model and
            compliance spec).
        noise: Each part's noise (1 sigma) [m]; None: equal weights.
        labels: Each part's name in the unknowns; default its kind (``k2`` when repeated).

    Raises:
        ArgumentError: no parts, or noise or labels not one per part.
        CalibPinError: parts of different robots or parameter models.
    """

    kind = "mix"
    data_name = "several sensors' values"
    error_name = "every sensor's weighted errors at a pose"

    def __init__(self, parts: Sequence[MeasurementModel], noise: Sequence[float] | None = None,
                 labels: Sequence[str] | None = None) -> None:
        parts = tuple(parts)
        if not parts or not all(isinstance(p, MeasurementModel) for p in parts):
            raise ArgumentError("parts", "give one measurement model or more (CableModel, PositionModel, ...)")
        sigma = np.ones(len(parts)) if noise is None else np.asarray(noise, dtype=float)
        if sigma.shape != (len(parts),) or not np.all(np.isfinite(sigma) & (sigma > 0)):
            raise ArgumentError("noise", f"give one noise > 0 [m] per sensor ({len(parts)})")
        if labels is None:
            kinds = [p.kind for p in parts]
            labels = [k if kinds.count(k) == 1 else f"{k}{i + 1}" for i, k in enumerate(kinds)]
        if len(labels) != len(parts) or len(set(labels)) != len(parts):
            raise ArgumentError("labels", f"give one distinct label per sensor ({len(parts)})")
        first = parts[0]
        for label, part in zip(labels, parts, strict=True):
            if tuple(part.names[: part.sensor_start]) != tuple(first.names[: first.sensor_start]) or \
                    part.chain is not first.chain:
                raise CalibPinError(f"sensor {label}: its robot unknowns differ from the first sensor's "
                                    "(plan one robot, one parameter model, one compliance spec)")
        extra = [(f"{label}:{n}", u, float(c)) for label, part in zip(labels, parts, strict=True)
                 for n, u, c in zip(part.names[part.sensor_start :], part.units[part.sensor_start :],
                                    part.scale[part.sensor_start :], strict=True)]
        super().__init__(first.chain, first.params, extra)
        start = first.sensor_start  # the robot's unknowns as the parts have them (with compliances)
        self.names = tuple(first.names[:start]) + tuple(e[0] for e in extra)
        self.units = tuple(first.units[:start]) + tuple(e[1] for e in extra)
        self.scale = np.concatenate([first.scale[:start], [e[2] for e in extra]])
        self.sensor_start, self.deflection, self.compliance_spec = start, first.deflection, first.compliance_spec
        self.parts, self.labels = parts, tuple(labels)
        self.weights = sigma[0] / sigma
        sizes = [p.n_params - p.sensor_start for p in parts]
        self._slots = [slice(start + a, start + a + n) for a, n in zip(np.cumsum([0, *sizes[:-1]]), sizes, strict=True)]
        self.values_per_pose = sum(p.values_per_row * len(p.grid_points(1)[0]) for p in parts)

    @classmethod
    def problem_for(cls, chain: Any, params: Any, data: Any, fit_rows: np.ndarray, options: Any) -> SetProblem:
        raise CalibPinError("a sensor mix plans poses; its sets are calibrated together with several --data")

    def _part_x(self, x: np.ndarray | None, k: int) -> np.ndarray | None:
        if x is None:
            return None
        x = np.asarray(x, dtype=float)
        return np.concatenate([x[: self.sensor_start], x[self._slots[k]]])

    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Weighted values of every part at each pose, shape (n_poses, values_per_pose), [m]."""
        out = []
        for k, part in enumerate(self.parts):
            rows, index = part.grid_points(len(q))
            out.append(part.predict(self._part_x(x, k), q[rows], index).reshape(len(q), -1) * self.weights[k])
        return np.concatenate(out, axis=1)

    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray,
                              points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`predict` and its derivative, shape (n_poses, values_per_pose, n_params)."""
        values, jacobians = [], []
        for k, part in enumerate(self.parts):
            rows, index = part.grid_points(len(q))
            v, j = part.predict_with_jacobian(self._part_x(x, k), q[rows], index)  # type: ignore[arg-type]
            j = j.reshape(len(q), -1, part.n_params) * self.weights[k]
            block = np.zeros(j.shape[:2] + (self.n_params,))
            block[:, :, : self.sensor_start] = j[:, :, : self.sensor_start]
            block[:, :, self._slots[k]] = j[:, :, self.sensor_start :]
            values.append(v.reshape(len(q), -1) * self.weights[k])
            jacobians.append(block)
        return np.concatenate(values, axis=1), np.concatenate(jacobians, axis=1)

    def geometry_at(self, x: np.ndarray | None) -> dict[str, Any]:
        return {label: part.geometry_at(self._part_x(x, k))
                for k, (label, part) in enumerate(zip(self.labels, self.parts, strict=True))}

    def geometry_report(self, x: np.ndarray | None) -> dict:
        return {label: part.geometry_report(self._part_x(x, k))
                for k, (label, part) in enumerate(zip(self.labels, self.parts, strict=True))}

    def describe(self) -> str:
        return "; ".join(f"{label}: {part.describe()} (weight {w:.3g})"
                         for label, part, w in zip(self.labels, self.parts, self.weights, strict=True))

    @property
    def reference_point(self) -> np.ndarray:
        return self.parts[0].reference_point


def _above_base(model: MeasurementModel, q: np.ndarray) -> np.ndarray:
    """The poses that put the sensor's reference point above the mounting plane (z > 0)."""
    return q[model.points_at(None, q, model.reference_point)[:, 2] > 0.0]


def _rows(model: MeasurementModel, q: np.ndarray) -> np.ndarray:
    """Scaled identification rows of each pose, shape (n_poses, rows per pose, n_params).

    Every point the sensor measures, every value of each.
    """
    rows, points = model.grid_points(len(q))
    jac = model.predict_with_jacobian(np.zeros(model.n_params), q[rows], points)[1] * model.scale
    return jac.reshape(len(q), -1, model.n_params)


def _greedy(z: np.ndarray, n: int) -> list[int]:
    """D-optimal greedy choice of n poses from per-pose blocks z (n_poses, k, r).

    Each step adds the pose with the largest log det gain (a rank-k update of the inverse).
    """
    inverse = np.eye(z.shape[2]) / (RIDGE * np.max(np.sum(z**2, axis=(1, 2))))
    chosen: list[int] = []
    available = np.ones(len(z), dtype=bool)
    for _ in progress(range(n), desc="choosing poses"):
        inner = np.eye(z.shape[1]) + (z @ inverse) @ z.transpose(0, 2, 1)
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
        model: The measurement model (robot, parameter model, sensor geometry), or a
            :class:`SensorMix` of several sensors reading at every pose.
        n: Poses to choose.
        candidates: Random poses to choose from.
        seed: Seed of the candidates.
        margin: Distance kept from every joint limit, [rad].
        target: Report how many chosen poses reach this total information (geometric
            mean of the singular values; default: that of n random poses).
    """
    rng = np.random.default_rng(seed)
    touches = getattr(model, "plan_candidates", None)
    fixtures: np.ndarray | None = None
    if touches is not None:  # the sensor's own candidates: touches of a fixture, views of a board (random order)
        pool, fixtures = touches(candidates, rng, margin)
        if len(pool) < n:
            rule = getattr(model, "plan_rule", "are usable")
            raise ValueError(f"only {len(pool)} of {candidates} candidates {rule}; ask for more")
        blocks = model.planning_rows(pool, fixtures)  # type: ignore[attr-defined]
    else:
        pool = _above_base(model, random_poses(model.chain, candidates, rng, margin=margin))
        if len(pool) < n:
            raise ValueError(f"only {len(pool)} of {candidates} candidates put the tool point above the base; "
                             "ask for more")
        blocks = _rows(model, pool)
    basis = Subspace.of(blocks.reshape(-1, model.n_params), np.ones(model.n_params)).vt.T
    picked = np.asarray(_greedy(blocks @ basis, n), dtype=int)  # candidates in the identifiable directions
    q = pool[picked]
    picked_fixtures = None if fixtures is None else fixtures[picked]

    def analysis(qs: np.ndarray, at: np.ndarray | None = None) -> Identifiability:
        if at is not None:
            return analyze(model.planning_problem(qs, at))  # type: ignore[attr-defined]
        rows, points = model.grid_points(len(qs))
        predicted = model.predict(None, qs[rows], points)  # the readings do not matter here, only the Jacobian
        return analyze(SetProblem(model, qs[rows], predicted, points))

    def indices(qs: np.ndarray, at: np.ndarray | None = None) -> tuple[float, float, float]:
        result = analysis(qs, at)
        return result.o1, result.o3, result.o1 * np.sqrt(len(qs))

    chosen = analysis(q, picked_fixtures)
    o1, o3 = chosen.o1, chosen.o3
    random_o1, random_o3, random_total = indices(pool[:n], None if fixtures is None else fixtures[:n])
    target = random_total if target is None else target
    fewest = int(np.ceil(basis.shape[1] / blocks.shape[1]))  # poses whose rows can span the directions
    reach = next((k for k in range(fewest, n + 1)
                  if indices(q[:k], None if picked_fixtures is None else picked_fixtures[:k])[2] >= target), None)
    return Plan(q, o1, o3, random_o1, random_o3, reach, target, chosen, picked_fixtures)

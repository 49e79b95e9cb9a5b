"""Several measurement sets of one robot as one least-squares problem.

All sets share the robot: its deviations and its compliances, the first ``sensor_start``
entries of every set's unknown vector. Each set keeps its own sensor and set-up (an
anchor, a device frame and markers) and its own noise. The stacked unknown vector is

    x = [robot deviations, compliances, set 1's sensor unknowns, set 2's, ...],

and the stacked residual is every set's residual in turn, set k's multiplied by
w_k = sigma_0 / sigma_k (sigma_0: the first set's noise), so that every row weighs as its
noise says and the whole residual is in units of sigma_0 (the noise the Kalman filters
are given). The sets may be of different sensors, their rows of different sizes (a
cable's one length, a tracker's three coordinates): a row's entries are found from
``row_offsets``, each set's errors are sized by its own problem, in its own units.
:class:`StackedProblem` implements :class:`calib_pin.estimators.problem.LeastSquares`
exactly as :class:`~calib_pin.estimators.problem.CalibrationProblem` does, so every estimator, the
identifiability analysis, the uncertainty and the active set see it unchanged. One set is
never stacked: the pipeline uses its own problem, bit for bit as before.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from ..estimators.problem import CalibrationProblem, RowProblem
from ..exceptions import CalibPinError


@dataclass(frozen=True)
class StackedModel:
    """The shared robot of several sets' measurement models, and their sensors in turn.

    It answers what the pipeline, the reports and the uncertainty ask of a calibration's
    model about the robot (names, units, scale, ``robot``, ``compliance``, the end-frame
    points), and maps the stacked x onto each set's own (:meth:`part_x`).

    Attributes:
        parts: Each set's measurement model (one robot, one compliance spec).
        labels: Each set's label, used as the prefix of its sensor unknowns (``s2:anchor_x``).
    """

    parts: tuple[Any, ...]
    labels: tuple[str, ...]

    def __post_init__(self) -> None:
        first = self.parts[0]
        for label, part in zip(self.labels[1:], self.parts[1:], strict=True):
            if tuple(part.names[: part.sensor_start]) != tuple(first.names[: first.sensor_start]):
                raise CalibPinError(f"set {label}: its robot unknowns differ from set {self.labels[0]}'s "
                                    "(one robot, one parameter model, one compliance spec for every set)")

    @property
    def first(self) -> Any:
        return self.parts[0]

    @property
    def n_robot(self) -> int:
        return int(self.first.n_robot)

    @property
    def sensor_start(self) -> int:
        return int(self.first.sensor_start)

    @property
    def chain(self) -> Any:
        return self.first.chain

    @property
    def params(self) -> Any:
        return self.first.params

    @property
    def compliance_spec(self) -> Any:
        return self.first.compliance_spec

    @property
    def deflection(self) -> Any:
        return self.first.deflection

    @property
    def mixed(self) -> bool:
        """The sets' rows differ in size (sensors of different kinds, say a cable and a tracker)."""
        return len({int(part.values_per_row) for part in self.parts}) > 1 or \
            any(getattr(part, "rows_differ", False) for part in self.parts)

    @property
    def values_per_row(self) -> int:
        """Values of each row, when every set's rows hold the same number.

        Raises:
            CalibPinError: sets whose rows differ in size (use ``row_offsets``).
        """
        if self.mixed:
            raise CalibPinError("the sets' rows differ in size (" + ", ".join(
                f"{label}: {part.values_per_row}" for label, part in zip(self.labels, self.parts, strict=True))
                + "): find a row's values with calib_pin.estimators.problem.row_offsets")
        return int(self.first.values_per_row)

    @property
    def error_name(self) -> str:
        """What a row's error is: the sets' one name, or each kind's with its sets
        (``reading error (cable); position error (tracker)``)."""
        names: dict[str, list[str]] = {}
        for label, part in zip(self.labels, self.parts, strict=True):
            names.setdefault(str(part.error_name), []).append(label)
        if len(names) == 1:
            return next(iter(names))
        return "; ".join(f"{name} ({', '.join(labels)})" for name, labels in names.items())

    @cached_property
    def columns(self) -> tuple[np.ndarray, ...]:
        """Each set's unknowns as indices into the stacked x: the shared robot part, then its own."""
        robot = np.arange(self.sensor_start)
        out, start = [], self.sensor_start
        for part in self.parts:
            n = part.n_params - part.sensor_start
            out.append(np.concatenate([robot, np.arange(start, start + n)]).astype(int))
            start += n
        return tuple(out)

    @cached_property
    def names(self) -> tuple[str, ...]:
        """The robot's names, then each set's sensor unknowns prefixed ``<label>:``."""
        own = [f"{label}:{name}" for label, part in zip(self.labels, self.parts, strict=True)
               for name in part.names[part.sensor_start:]]
        return tuple(self.first.names[: self.sensor_start]) + tuple(own)

    @cached_property
    def units(self) -> tuple[str, ...]:
        return tuple(self.first.units[: self.sensor_start]) + tuple(
            u for part in self.parts for u in part.units[part.sensor_start:])

    @cached_property
    def scale(self) -> np.ndarray:
        return np.concatenate([self.first.scale[: self.sensor_start]]
                              + [part.scale[part.sensor_start:] for part in self.parts])

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def nonnegative(self) -> tuple[int, ...]:
        """The compliances (shared by every set): they must be >= 0 (none for the gravity basis)."""
        return tuple(self.first.nonnegative)

    def part_x(self, x: np.ndarray | None, k: int) -> np.ndarray | None:
        """Set k's own unknown vector within the stacked x (None stays None)."""
        return None if x is None else np.asarray(x, dtype=float)[self.columns[k]]

    def robot(self, x: np.ndarray) -> np.ndarray:
        """The robot's deviations within x, shape (n_robot,)."""
        return np.asarray(x, dtype=float)[: self.n_robot]

    def compliance(self, x: np.ndarray | None) -> np.ndarray:
        """The joint compliances within x, [rad/Nm]; x None: zero."""
        if x is None:
            return np.zeros(self.sensor_start - self.n_robot)
        return np.asarray(x, dtype=float)[self.n_robot : self.sensor_start]

    def sensor_part(self, x: np.ndarray | None) -> np.ndarray:
        """Every set's sensor unknowns within x, in turn."""
        if x is None:
            return np.zeros(self.n_params - self.sensor_start)
        return np.asarray(x, dtype=float)[self.sensor_start :]

    def point_jacobian(self, x: np.ndarray, q: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A point fixed in the end frame [m] and its derivative (n_rows, 3, n_params):
        the robot's part only (zero in every set's sensor columns)."""
        points, jac = self.first.point_jacobian(self.part_x(x, 0), q, point)
        full = np.zeros(jac.shape[:2] + (self.n_params,))
        full[:, :, : self.sensor_start] = jac[:, :, : self.sensor_start]
        return points, full

    def geometry_at(self, x: np.ndarray | None) -> tuple[Any, ...]:
        """Each set's sensor geometry at x."""
        return tuple(part.geometry_at(self.part_x(x, k)) for k, part in enumerate(self.parts))

    def geometry_report(self, x: np.ndarray | None) -> dict:
        """Each set's geometry at x for report.json, by label."""
        pairs = list(enumerate(zip(self.labels, self.parts, strict=True)))
        return {"set_geometry": {label: part.geometry_report(self.part_x(x, k)) for k, (label, part) in pairs},
                "set_kinds": {label: part.kind for _, (label, part) in pairs}}

    def describe(self) -> str:
        return f"{len(self.parts)} sets: " + "; ".join(
            f"{label} ({part.describe()})" for label, part in zip(self.labels, self.parts, strict=True))

    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        raise CalibPinError(f"a calibration of {len(self.parts)} sets predicts per set: use result.sets[k].predict(q)")

    def point_index(self, labels: Any, n_rows: int, source: str = "") -> np.ndarray | None:
        raise CalibPinError(f"a calibration of {len(self.parts)} sets predicts per set: use result.sets[k].predict(q)")


@dataclass(frozen=True)
class StackedProblem(RowProblem):
    """Several sets' calibration problems with one robot (module docstring).

    Attributes:
        model: The stacked model (every set's measurement model, the labels).
        parts: Each set's problem over its rows, in the stacked order; an empty set is
            left out (``sets`` says which set each part is).
        weights: w_k = sigma_0 / sigma_k of each part, shape (n_parts,).
        sets: Each part's index into ``model.parts``.
    """

    model: StackedModel
    parts: tuple[CalibrationProblem, ...]
    weights: np.ndarray
    sets: tuple[int, ...] = ()
    _offsets: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.sets:
            object.__setattr__(self, "sets", tuple(range(len(self.parts))))
        object.__setattr__(self, "weights", np.asarray(self.weights, dtype=float))
        object.__setattr__(self, "_offsets", np.cumsum([0] + [p.n_rows for p in self.parts]))

    @classmethod
    def of(cls, problems: Sequence[CalibrationProblem], labels: Sequence[str], sigmas: Sequence[float]) -> StackedProblem:
        """The stack of every row of each set's problem, set k weighted by sigmas[0] / sigmas[k] [m]."""
        model = StackedModel(tuple(p.model for p in problems), tuple(labels))
        sigma = np.asarray(sigmas, dtype=float)
        return cls(model, tuple(problems), sigma[0] / sigma)

    def with_weights(self, sigmas: Sequence[float]) -> StackedProblem:
        """The same rows with set k weighted by sigmas[0] / sigmas[k] (sigmas of every set of the model)."""
        sigma = np.asarray(sigmas, dtype=float)
        return StackedProblem(self.model, self.parts, (sigma[0] / sigma)[list(self.sets)], self.sets)

    # --- LeastSquares ------------------------------------------------------------------

    @property
    def scale(self) -> np.ndarray:
        return self.model.scale

    @property
    def values_per_row(self) -> int:
        """Values of each row when every set's rows hold the same number (else refused:
        rows of mixed sets are found with :attr:`row_offsets`)."""
        return self.model.values_per_row

    @property
    def n_params(self) -> int:
        return self.model.n_params

    @property
    def nonnegative(self) -> tuple[int, ...]:
        return self.model.nonnegative

    @property
    def n_rows(self) -> int:
        return int(self._offsets[-1])

    @property
    def row_offsets(self) -> np.ndarray:
        """Where each stacked row's entries start, shape (n_rows + 1,): each set's own
        offsets in turn (its rows may hold another number of values than the others')."""
        starts = np.cumsum([0] + [p.n_values for p in self.parts])
        inner = [p.row_offsets[:-1] + s for p, s in zip(self.parts, starts[:-1], strict=True)]
        return np.concatenate([*inner, [starts[-1]]]).astype(int)

    n_poses = n_rows

    @property
    def n_values(self) -> int:
        return sum(p.n_values for p in self.parts)

    @property
    def q(self) -> np.ndarray:
        """Every data row's joint angles, shape (n_data, n_joints), [rad]: row k is stacked
        row ``data_rows[k]`` (a contact set's known-distance rows carry no pose)."""
        return np.concatenate([p.q for p in self.parts])

    @property
    def points(self) -> np.ndarray | None:
        """Every data row's point index, shape (n_data,), or None for one-point sensors."""
        if any(p.points is None for p in self.parts):
            return None
        return np.concatenate([p.points for p in self.parts])  # type: ignore[misc]

    def _x(self, x: np.ndarray | None, part: int) -> Any:
        return self.model.part_x(x, self.sets[part])

    def _columns(self, part: int) -> np.ndarray:
        return self.model.columns[self.sets[part]]

    def residual(self, x: np.ndarray | None) -> np.ndarray:
        """Each set's residual times its weight, in turn, shape (n_values,), [m of sigma_0]."""
        return np.concatenate([w * p.residual(self._x(x, k))
                               for k, (p, w) in enumerate(zip(self.parts, self.weights, strict=True))])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Derivative of :meth:`residual`, shape (n_values, n_params); a set's rows are
        zero in the other sets' sensor columns."""
        jac = np.zeros((self.n_values, self.n_params))
        start = 0
        for k, (p, w) in enumerate(zip(self.parts, self.weights, strict=True)):
            block = p.jacobian(self._x(x, k))
            jac[start : start + len(block), self._columns(k)] = w * block
            start += len(block)
        return jac

    def row_residual_with_jacobian(self, x: np.ndarray, row: int) -> tuple[np.ndarray, np.ndarray]:
        """Row ``row``'s weighted residual (its set's values per row,) and Jacobian
        (its set's values per row, n_params)."""
        k = int(np.searchsorted(self._offsets, row, side="right")) - 1
        r, j = self.parts[k].row_residual_with_jacobian(self._x(x, k), row - int(self._offsets[k]))
        w = self.weights[k]
        full = np.zeros((len(r), self.n_params))
        full[:, self._columns(k)] = w * j
        return w * r, full

    def subset(self, rows: np.ndarray | slice) -> StackedProblem:
        """The stack restricted to some data rows (rows of :attr:`q`, the sets' data rows in
        turn, kept in that order within each set; each contact set's known-distance rows
        stay with its part, :func:`calib_pin.estimators.problem.data_rows`); sets left without rows
        are left out."""
        n_data = [len(p.q) for p in self.parts]
        index = np.arange(sum(n_data))[rows] if isinstance(rows, slice) else np.asarray(rows, dtype=int).reshape(-1)
        starts = np.cumsum([0] + n_data)
        parts, weights, sets = [], [], []
        for k, p in enumerate(self.parts):
            lo, hi = starts[k], starts[k + 1]
            mine = index[(index >= lo) & (index < hi)] - lo
            if len(mine):
                parts.append(p.subset(mine))
                weights.append(self.weights[k])
                sets.append(self.sets[k])
        return StackedProblem(self.model, tuple(parts), np.asarray(weights), tuple(sets))

    def row_errors(self, residual: np.ndarray) -> np.ndarray:
        """Size of each row's error in its own set's units (the weight divided out),
        shape (n_rows,), [m]: each set's rows as its own problem sizes them (a reading's
        |error|, a position's Euclidean error), so sets of rows of different sizes mix."""
        residual = np.asarray(residual)
        if not self.parts:
            return np.zeros(0)
        starts = np.cumsum([0] + [p.n_values for p in self.parts])
        return np.concatenate([p.row_errors(residual[lo:hi]) / w for p, w, lo, hi
                               in zip(self.parts, self.weights, starts[:-1], starts[1:], strict=True)])

    @property
    def data_rows(self) -> np.ndarray:
        """The stacked rows that are data rows: every part's (a contact set's known
        distances are rows of its own, no data row), shape (n_data,)."""
        return np.concatenate([getattr(p, "data_rows", np.arange(p.n_rows)) + int(self._offsets[k])
                               for k, p in enumerate(self.parts)] or [np.zeros(0)]).astype(int)

    def part_rows(self, part: int) -> np.ndarray:
        """The stacked rows of part ``part``."""
        return np.arange(self._offsets[part], self._offsets[part + 1])

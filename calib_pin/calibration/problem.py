"""The calibration problem: one robot and a list of measurement sets, as one least-squares problem.

Every set shares the robot: its deviations and its compliances, the first ``sensor_start``
entries of every set's unknown vector. Each set keeps its own sensor and set-up (an
anchor, a device frame and markers) and its own noise. The unknown vector is

    x = [robot deviations, compliances, set 1's sensor unknowns, set 2's, ...],

and the residual is every set's residual in turn, set k's multiplied by
w_k = sigma_0 / sigma_k (sigma_0: the first set's noise), so that every row weighs as its
noise says and the whole residual is in units of sigma_0 (the noise the Kalman filters are
given). The sets may be of different sensors, their rows of different sizes (a cable's
one length, a tracker's three coordinates): a row's entries are found from
``row_offsets``, each set's errors are sized by its own problem, in its own units.

One set is a list of one: its unknowns keep their own names, its weight is 1 and every
call is handed to the set's problem, so that a calibration of one set is that set's
problem to the bit (and as fast). With several sets a set's sensor unknowns are prefixed
with its label (``s2:anchor_x``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from ..estimators.problem import RowProblem
from ..exceptions import CalibPinError
from ..sensors.problem import SetProblem


@dataclass(frozen=True)
class ProblemModel:
    """The shared robot of several sets' measurement models, and their sensors in turn.

    It answers what a calibration asks of its model about the robot (names, units, scale,
    ``chain``, ``compliance``, the end-frame points) and maps the whole x onto each set's own
    (:meth:`part_x`). Of one set it is that set's model: its names, its description, its
    geometry and its predictions.

    Attributes:
        parts: Each set's measurement model (one robot, one compliance spec).
        labels: Each set's label, the prefix of its sensor unknowns with several sets.
    """

    parts: tuple[Any, ...]
    labels: tuple[str, ...]

    def __post_init__(self) -> None:
        if not self.parts:
            raise CalibPinError("a calibration problem needs at least one measurement set")
        first = self.parts[0]
        for label, part in zip(self.labels[1:], self.parts[1:], strict=True):
            if tuple(part.names[: part.sensor_start]) != tuple(first.names[: first.sensor_start]):
                raise CalibPinError(f"set {label}: its robot unknowns differ from set {self.labels[0]}'s "
                                    "(one robot, one parameter model, one compliance spec for every set)")

    @property
    def one(self) -> Any | None:
        """The only set's model, or None with several sets."""
        return self.parts[0] if len(self.parts) == 1 else None

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
    def error_name(self) -> str:
        """What a row's error is: the sets' one name, or each kind's with its sets.

        For example ``reading error (cable); position error (tracker)``.
        """
        names: dict[str, list[str]] = {}
        for label, part in zip(self.labels, self.parts, strict=True):
            names.setdefault(str(part.error_name), []).append(label)
        if len(names) == 1:
            return next(iter(names))
        return "; ".join(f"{name} ({', '.join(labels)})" for name, labels in names.items())

    @property
    def value_unit(self) -> str:
        """The unit of the sets' row errors when they share one, else ``mixed``."""
        units = {str(getattr(part, "value_unit", "mm")) for part in self.parts}
        return units.pop() if len(units) == 1 else "mixed"

    @cached_property
    def columns(self) -> tuple[np.ndarray, ...]:
        """Each set's unknowns as indices into x: the shared robot part, then its own."""
        robot = np.arange(self.sensor_start)
        out, start = [], self.sensor_start
        for part in self.parts:
            n = part.n_params - part.sensor_start
            out.append(np.concatenate([robot, np.arange(start, start + n)]).astype(int))
            start += n
        return tuple(out)

    @cached_property
    def names(self) -> tuple[str, ...]:
        """The robot's names, then each set's sensor unknowns (prefixed ``<label>:`` with several sets)."""
        if self.one is not None:
            return tuple(self.one.names)
        own = [f"{label}:{name}" for label, part in zip(self.labels, self.parts, strict=True)
               for name in part.names[part.sensor_start:]]
        return tuple(self.first.names[: self.sensor_start]) + tuple(own)

    @cached_property
    def units(self) -> tuple[str, ...]:
        return tuple(self.first.units[: self.sensor_start]) + tuple(
            u for part in self.parts for u in part.units[part.sensor_start:])

    @cached_property
    def scale(self) -> np.ndarray:
        if self.one is not None:
            return np.asarray(self.one.scale)
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
        """Set k's own unknown vector within x (None stays None)."""
        if x is None:
            return None
        if self.one is not None:
            return np.asarray(x, dtype=float)
        return np.asarray(x, dtype=float)[self.columns[k]]

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
        """A point fixed in the end frame [m] and its derivative (n_rows, 3, n_params).

        The derivative holds the robot's part only (zero in every set's sensor columns).
        """
        points, jac = self.first.point_jacobian(self.part_x(x, 0), q, point)
        if self.one is not None:
            return points, jac
        full = np.zeros(jac.shape[:2] + (self.n_params,))
        full[:, :, : self.sensor_start] = jac[:, :, : self.sensor_start]
        return points, full

    def end_frames(self, x: np.ndarray | None, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The end frame's rotations (n, 3, 3) and origins (n, 3) [m] in the base frame at q."""
        return self.first.end_frames(self.part_x(x, 0), q)

    def geometry_at(self, x: np.ndarray | None) -> Any:
        """The sensor's geometry at x; with several sets, each set's in turn."""
        if self.one is not None:
            return self.one.geometry_at(x)
        return tuple(part.geometry_at(self.part_x(x, k)) for k, part in enumerate(self.parts))

    def geometry_report(self, x: np.ndarray | None) -> dict:
        """The sensor's geometry at x for report.json; with several sets, each set's by label."""
        if self.one is not None:
            return self.one.geometry_report(x)
        pairs = list(enumerate(zip(self.labels, self.parts, strict=True)))
        return {"set_geometry": {label: part.geometry_report(self.part_x(x, k)) for k, (label, part) in pairs},
                "set_kinds": {label: part.kind for _, (label, part) in pairs}}

    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """What the only set's sensor reads at q for x, [m].

        With several sets, name the set: ``result.predict(q, set=...)``.

        Args:
            x: The unknowns, shape (n_params,), SI; None: the start.
            q: Joint angles [rad], shape (n_poses, n_joints).
            points: Which of the sensor's points each pose measures (indices), or None.

        Raises:
            CalibPinError: several sets.
        """
        if self.one is None:
            raise CalibPinError(f"a calibration of {len(self.parts)} sets predicts per set: "
                                f"result.predict(q, set=LABEL) with a label of {', '.join(self.labels)}")
        return self.one.predict(x, q, points)  # type: ignore[no-any-return]

    def describe(self) -> str:
        if self.one is not None:
            return str(self.one.describe())
        return f"{len(self.parts)} sets: " + "; ".join(
            f"{label} ({part.describe()})" for label, part in zip(self.labels, self.parts, strict=True))


@dataclass(frozen=True)
class Problem(RowProblem):
    """A calibration problem of one or more sets with one robot (module docstring).

    It implements :class:`calib_pin.estimators.problem.LeastSquares`.

    Attributes:
        model: The model (every set's measurement model, the labels).
        parts: Each set's problem over its rows, in order; a set without rows here is left
            out (``sets`` says which set each part is).
        weights: w_k = sigma_0 / sigma_k of each part, shape (n_parts,).
        sets: Each part's index into ``model.parts``.
    """

    model: ProblemModel
    parts: tuple[SetProblem, ...]
    weights: np.ndarray
    sets: tuple[int, ...] = ()
    _offsets: np.ndarray = field(init=False, repr=False, compare=False)
    _only: SetProblem | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Raises: CalibPinError: no part, or parts, weights and ``sets`` of different lengths."""
        if not isinstance(self.model, ProblemModel) or not isinstance(self.parts, tuple | list) or not self.parts:
            raise CalibPinError("a calibration problem needs at least one measurement set's rows (parts: a "
                                "SetProblem per set; build it with Problem.of)")
        if not self.sets:
            object.__setattr__(self, "sets", tuple(range(len(self.parts))))
        object.__setattr__(self, "weights", np.asarray(self.weights, dtype=float))
        if len(self.sets) != len(self.parts) or self.weights.shape != (len(self.parts),):
            raise CalibPinError(f"a calibration problem of {len(self.parts)} part(s) with {len(self.sets)} set "
                                f"index(es) and weights of shape {self.weights.shape}: one of each per part")
        object.__setattr__(self, "_offsets", np.cumsum([0] + [p.n_rows for p in self.parts]))
        # One set, weight 1, every unknown its own: every call is the set's own problem's.
        only = self.parts[0] if (len(self.parts) == 1 and self.model.one is not None
                                 and float(self.weights[0]) == 1.0) else None
        object.__setattr__(self, "_only", only)

    @classmethod
    def of(cls, problems: Sequence[SetProblem], labels: Sequence[str], sigmas: Sequence[float]) -> Problem:
        """Every row of each set's problem, set k weighted by sigmas[0] / sigmas[k] [m].

        Raises:
            CalibPinError: no set, or problems, labels and sigmas of different lengths.
        """
        if not isinstance(problems, Sequence) or not problems:
            raise CalibPinError("a calibration problem needs at least one measurement set")
        if len(labels) != len(problems) or len(sigmas) != len(problems):
            raise CalibPinError(f"{len(problems)} set problem(s), {len(labels)} label(s) and {len(sigmas)} sigma(s): "
                                "give one of each per set")
        model = ProblemModel(tuple(p.model for p in problems), tuple(labels))
        sigma = np.asarray(sigmas, dtype=float)
        return cls(model, tuple(problems), sigma[0] / sigma)

    def with_weights(self, sigmas: Sequence[float]) -> Problem:
        """The same rows with set k weighted by sigmas[0] / sigmas[k] (sigmas of every set of the model)."""
        sigma = np.asarray(sigmas, dtype=float)
        weights = (sigma[0] / sigma)[list(self.sets)]
        if np.array_equal(weights, self.weights):
            return self
        return Problem(self.model, self.parts, weights, self.sets)

    def with_parts(self, parts: Sequence[SetProblem]) -> Problem:
        """The same weights with each part's problem replaced.

        A part is replaced by its set's model reweighted within
        (:meth:`~calib_pin.sensors.base.MeasurementModel.with_part_noise`).
        """
        models = list(self.model.parts)
        for k, part in zip(self.sets, parts, strict=True):
            models[k] = part.model
        return Problem(ProblemModel(tuple(models), self.model.labels), tuple(parts), self.weights, self.sets)

    # --- LeastSquares ------------------------------------------------------------------

    @property
    def scale(self) -> np.ndarray:
        return self.model.scale

    @property
    def values_per_row(self) -> int:
        """Values of each row, when every part's rows hold the same number.

        Raises:
            CalibPinError: parts whose rows differ in size (use ``row_offsets``).
        """
        sizes = {int(p.values_per_row) for p in self.parts} if self.parts else {int(self.model.first.values_per_row)}
        if len(sizes) > 1 or any(getattr(p.model, "rows_differ", False) for p in self.parts):
            raise CalibPinError("the sets' rows differ in size (" + ", ".join(
                f"{self.model.labels[k]}: {p.values_per_row}" for k, p in zip(self.sets, self.parts, strict=True))
                + "): find a row's values with calib_pin.estimators.problem.row_offsets")
        return sizes.pop()

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
        """Where each row's entries start, shape (n_rows + 1,).

        Each part's own offsets in turn (its rows may hold another number of values than
        the others').
        """
        if self._only is not None:
            return self._only.row_offsets
        starts = np.cumsum([0] + [p.n_values for p in self.parts])
        inner = [p.row_offsets[:-1] + s for p, s in zip(self.parts, starts[:-1], strict=True)]
        return np.concatenate([*inner, [starts[-1]]]).astype(int)

    n_poses = n_rows

    @property
    def n_values(self) -> int:
        return sum(p.n_values for p in self.parts)

    @property
    def q(self) -> np.ndarray:
        """Every data row's joint angles, shape (n_data, n_joints), [rad].

        Row k is row ``data_rows[k]`` (a contact set's known-distance rows carry no pose).
        """
        if self._only is not None:
            return self._only.q
        return np.concatenate([p.q for p in self.parts])

    @property
    def points(self) -> np.ndarray | None:
        """Every data row's point index, shape (n_data,), or None for one-point sensors."""
        if self._only is not None:
            return self._only.points
        if any(p.points is None for p in self.parts):
            return None
        return np.concatenate([p.points for p in self.parts])  # type: ignore[misc]

    @property
    def data_rows(self) -> np.ndarray:
        """The rows that are data rows, every part's, shape (n_data,).

        A contact set's known distances are rows of its own, no data row.
        """
        return np.concatenate([getattr(p, "data_rows", np.arange(p.n_rows)) + int(self._offsets[k])
                               for k, p in enumerate(self.parts)] or [np.zeros(0)]).astype(int)

    def _x(self, x: np.ndarray | None, part: int) -> Any:
        return self.model.part_x(x, self.sets[part])

    def _columns(self, part: int) -> np.ndarray:
        return self.model.columns[self.sets[part]]

    def residual(self, x: np.ndarray | None) -> np.ndarray:
        """Each part's residual times its weight, in turn, shape (n_values,), [m of sigma_0]."""
        if self._only is not None:
            return self._only.residual(x)
        return np.concatenate([w * p.residual(self._x(x, k))
                               for k, (p, w) in enumerate(zip(self.parts, self.weights, strict=True))])

    def residuals(self, xs: np.ndarray | list[np.ndarray]) -> np.ndarray:
        """:meth:`residual` at k points xs, shape (k, n_values).

        Each part's own batched evaluation (:meth:`~calib_pin.sensors.problem.SetProblem.residuals`),
        weighted, side by side.
        """
        if self._only is not None:
            return self._only.residuals(xs)
        blocks = [w * p.residuals([self._x(x, k) for x in xs])
                  for k, (p, w) in enumerate(zip(self.parts, self.weights, strict=True))]
        return np.concatenate(blocks, axis=1)

    def costs(self, xs: list[np.ndarray]) -> list[float]:
        """:meth:`cost` at several points, each part's rows evaluated in one batched pass."""
        if self._only is not None:
            return self._only.costs(xs)
        if not len(xs):
            return []
        return [float(r @ r) / len(r) for r in self.residuals(xs)]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Derivative of :meth:`residual`, shape (n_values, n_params).

        A set's rows are zero in the other sets' sensor columns.
        """
        if self._only is not None:
            return self._only.jacobian(x)
        jac = np.zeros((self.n_values, self.n_params))
        start = 0
        for k, (p, w) in enumerate(zip(self.parts, self.weights, strict=True)):
            block = p.jacobian(self._x(x, k))
            jac[start : start + len(block), self._columns(k)] = w * block
            start += len(block)
        return jac

    def row_residual_with_jacobian(self, x: np.ndarray, row: int) -> tuple[np.ndarray, np.ndarray]:
        """Row ``row``'s weighted residual and Jacobian.

        Shapes: (its set's values per row,) and (its set's values per row, n_params).
        """
        if self._only is not None:
            return self._only.row_residual_with_jacobian(x, row)
        k = int(np.searchsorted(self._offsets, row, side="right")) - 1
        r, j = self.parts[k].row_residual_with_jacobian(self._x(x, k), row - int(self._offsets[k]))
        w = self.weights[k]
        full = np.zeros((len(r), self.n_params))
        full[:, self._columns(k)] = w * j
        return w * r, full

    def subset(self, rows: np.ndarray | slice) -> Problem:
        """The problem restricted to some data rows; parts left without rows are left out.

        ``rows`` are rows of :attr:`q`, the parts' data rows in turn, kept in that order
        within each part; each contact set's known-distance rows stay with its part.
        """
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
        if not parts:
            raise CalibPinError("no rows: a calibration problem needs at least one row")
        return Problem(self.model, tuple(parts), np.asarray(weights), tuple(sets))

    def row_errors(self, residual: np.ndarray) -> np.ndarray:
        """Size of each row's error in its own set's unit, shape (n_rows,), [m].

        The weight is divided out. Each set's rows as its own problem sizes them (a
        reading's |error|, a position's Euclidean error), so sets of rows of different sizes mix.
        """
        if self._only is not None:
            return self._only.row_errors(residual)
        residual = np.asarray(residual)
        starts = np.cumsum([0] + [p.n_values for p in self.parts])
        return np.concatenate([p.row_errors(residual[lo:hi]) / w for p, w, lo, hi
                               in zip(self.parts, self.weights, starts[:-1], starts[1:], strict=True)])

    def named_directions(self, x: np.ndarray | None = None) -> dict[str, tuple[np.ndarray, str]]:
        """Directions of the unknowns each part's sensor names, as vectors of x, by name.

        A direction is for example a turn of the base with the fixtures; with several sets
        the name is prefixed with the set's label.
        """
        out: dict[str, tuple[np.ndarray, str]] = {}
        for k, p in enumerate(self.parts):
            named = getattr(p, "named_directions", None)
            if named is None:
                continue
            for name, (v, hint) in named(self._x(x, k)).items():
                full = np.zeros(self.n_params)
                full[self._columns(k)] = v
                label = name if self.model.one is not None else f"{self.model.labels[self.sets[k]]}: {name}"
                out[label] = (full, hint)
        return out


def values_error(training: Problem, x0: np.ndarray, held: tuple[int, ...], n_rows: int,
                 rows: str = "training rows") -> str | None:
    """Why ``training`` (``n_rows`` rows, called ``rows``) has too few values to fit, or None.

    An estimate moves only the directions its rows identify (the rank r of the Jacobian's
    free columns at ``x0``: the unknowns not ``held``), so its values are counted against
    r, not against every unknown: they must be more than r, or every value is fitted
    exactly and nothing is left to check the fit (or to estimate the noise). The rank is
    computed only when the values are no more than the free unknowns.
    """
    free = np.array([i not in held for i in range(training.n_params)], dtype=bool)
    n_free, n_values = int(free.sum()), training.n_values
    if n_values > n_free:
        return None
    from ..estimators.subspace import Subspace

    rank = Subspace.of(training.jacobian(x0)[:, free], np.asarray(training.scale)[free], x0[free]).rank
    if n_values > rank:
        return None
    unknowns = f"{n_free} free unknowns, {len(held)} held" if held else f"{n_free} unknowns"
    return (f"{n_rows} {rows} give {n_values} values, no more than the {rank} directions they identify (of the "
            f"{unknowns}): every value would be fitted exactly, none left to check the fit: measure more poses")

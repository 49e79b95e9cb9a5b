"""The calibration problem: measured rows and the model that predicts them.

:class:`CalibrationProblem` is the one residual function and the one identification
Jacobian every estimator, the identifiability analysis and the uncertainty use. An
estimator sees it only through :class:`LeastSquares` (residual, Jacobian, scale and the
row blocks), so it can be tested on any small least-squares problem.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np


class LeastSquares(Protocol):
    """What an estimator needs of a problem (SciPy's ``least_squares`` shape).

    Attributes:
        scale: Typical size of each unknown, shape (n_params,), SI units.
        values_per_row: Residual entries one row (a Kalman update's block) holds, when
            every row holds the same number.
        row_offsets: Where each row's entries start in the residual, shape (n_rows + 1,):
            row k holds entries ``row_offsets[k]:row_offsets[k + 1]``. Rows of several
            sensors (a cable reading, a 3-D position) differ in size; estimators use
            this, never ``values_per_row``, to find a row's entries.
        n_rows, n_values, n_params: Sizes.

    A problem may also name unknowns that must be >= 0 in ``nonnegative`` (indices; a
    calibration problem's compliances): :func:`calib_pin.estimators.run_estimator` keeps
    them so for every method.
    """

    @property
    def scale(self) -> np.ndarray: ...

    @property
    def values_per_row(self) -> int: ...

    @property
    def row_offsets(self) -> np.ndarray: ...

    @property
    def n_rows(self) -> int: ...

    @property
    def n_values(self) -> int: ...

    @property
    def n_params(self) -> int: ...

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Predicted minus measured values, shape (n_values,)."""
        ...

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Derivative of :meth:`residual`, shape (n_values, n_params)."""
        ...

    def row_residual_with_jacobian(self, x: np.ndarray, row: int) -> tuple[np.ndarray, np.ndarray]:
        """One row's residual (values_per_row,) and Jacobian (values_per_row, n_params)."""
        ...

    def cost(self, x: np.ndarray) -> float:
        """Mean squared residual."""
        ...

    def subset(self, rows: np.ndarray | slice) -> LeastSquares: ...

    def rows_of(self, values: np.ndarray) -> np.ndarray: ...


def row_offsets(problem: Any) -> np.ndarray:
    """Where each row's residual entries start in ``problem``'s residual, shape
    (n_rows + 1,): its ``row_offsets``, or, for a problem that states only
    ``values_per_row`` (rows of one size), multiples of it."""
    offsets = getattr(problem, "row_offsets", None)
    if offsets is None:
        return np.arange(problem.n_rows + 1) * int(problem.values_per_row)
    return np.asarray(offsets, dtype=int)


def data_rows(problem: Any) -> np.ndarray:
    """The rows of ``problem`` that are data rows, in order, shape (n_data,): row k of its
    ``q`` (and of the measurement set) is row ``data_rows(problem)[k]`` of its residual's rows.

    Every row is a data row except a contact set's known-distance rows (``# distance_mm``):
    they carry no pose, follow its touches, and are kept by every ``subset`` (so they are
    always training rows and never test rows). ``subset(rows)`` takes data rows (rows of
    ``q``); ``n_rows``, ``row_offsets``, ``row_residual_with_jacobian`` and ``row_errors``
    count every row; metrics, per-row figures and test rows are of data rows only.
    """
    rows = getattr(problem, "data_rows", None)
    return np.arange(problem.n_rows) if rows is None else np.asarray(rows, dtype=int)


def data_row_errors(problem: Any, residual: np.ndarray) -> np.ndarray:
    """Size of each data row's error (:func:`data_rows`), shape (n_data,), [the rows' unit]."""
    return np.asarray(problem.row_errors(residual))[data_rows(problem)]


class RowProblem:
    """What every least-squares problem derives from its residual and row size: the
    cost and the rows of residual entries (shared by :class:`CalibrationProblem`,
    :class:`calib_pin.calibration.problem.StackedProblem` and the active set's reduced problem)."""

    values_per_row: Any
    n_rows: Any

    def residual(self, x: Any) -> np.ndarray:
        raise NotImplementedError

    @property
    def row_offsets(self) -> np.ndarray:
        """Where each row's residual entries start, shape (n_rows + 1,) (rows of equal size)."""
        return np.arange(self.n_rows + 1) * self.values_per_row

    def cost(self, x: np.ndarray) -> float:
        """Mean squared residual (paper eq. 6), [m^2]."""
        r = self.residual(x)
        return float(r @ r) / len(r)

    def costs(self, xs: list[np.ndarray]) -> list[float]:
        """:meth:`cost` at several points (a search's candidates), [m^2] each."""
        return [self.cost(x) for x in xs]

    def rows_of(self, values: np.ndarray) -> np.ndarray:
        """Rows that hold the given residual entries (indices into the residual)."""
        return np.unique(np.searchsorted(self.row_offsets, np.asarray(values, dtype=int), side="right") - 1)


#: Points x rows of one batched pass of :meth:`CalibrationProblem.costs` (a few tens of MB).
BATCH_ROWS = 200_000


@dataclass
class CalibrationProblem(RowProblem):
    """Measured data and the model that predicts it.

    Attributes:
        model: The sensor's measurement model (:mod:`calib_pin.sensors`).
        q: Joint angles of the rows, shape (n_rows, n_joints), [rad].
        readings: Measured values, shape (n_rows,) or (n_rows, values_per_row), [m].
        points: Each row's index of the measured point, for sensors that measure
            several (marker positions); else None.
    """

    model: Any  # the sensor's MeasurementModel (typed loosely: sensors/ imports this module)
    q: np.ndarray
    readings: np.ndarray
    points: np.ndarray | None = None

    @property
    def scale(self) -> np.ndarray:
        return self.model.scale

    @property
    def values_per_row(self) -> int:
        return self.model.values_per_row

    @property
    def n_params(self) -> int:
        return self.model.n_params

    @property
    def nonnegative(self) -> tuple[int, ...]:
        """Unknowns that must be >= 0 (the compliances), kept so by every estimator
        (:func:`calib_pin.estimators.run_estimator`)."""
        return self.model.nonnegative

    @property
    def n_rows(self) -> int:
        """Data rows."""
        return len(self.readings)

    n_poses = n_rows

    @property
    def n_values(self) -> int:
        """Length of the residual: rows times values per row."""
        return int(np.size(self.readings))

    def subset(self, rows: np.ndarray | slice) -> CalibrationProblem:
        """The same problem restricted to some rows (row indices)."""
        points = None if self.points is None else self.points[rows]
        return replace(self, q=self.q[rows], readings=self.readings[rows], points=points)

    def predict(self, x: np.ndarray | None) -> np.ndarray:
        """Predicted values, shaped like ``readings``, [m]."""
        return self.model.predict(x, self.q, self.points)

    def predict_with_jacobian(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predicted values flattened, shape (n_values,), and their Jacobian (n_values, n_params)."""
        values, jac = self.model.predict_with_jacobian(x, self.q, self.points)
        return values.reshape(-1), jac.reshape(self.n_values, -1)

    def residual(self, x: np.ndarray | None) -> np.ndarray:
        """Predicted minus measured values, flattened, shape (n_values,), [m]."""
        return (self.predict(x) - self.readings).reshape(-1)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Derivative of :meth:`residual`, shape (n_values, n_params)."""
        return self.predict_with_jacobian(x)[1]

    def residuals(self, xs: np.ndarray | list[np.ndarray]) -> np.ndarray:
        """:meth:`residual` at k points xs (k, n_params), shape (k, n_values), [m]: one
        batched forward-kinematics pass over (points x rows), the same numbers to the bit.
        A problem whose class has its own :meth:`residual` (a 6-D pose's whitened rotation
        vector, a contact set's touches and distances) is evaluated point by point with it:
        the plain batch (predicted minus measured) would be another residual."""
        if type(self).residual is not CalibrationProblem.residual:
            return np.array([self.residual(x) for x in xs])
        stacked = getattr(self.model, "predict_stacked", None)  # a model that stacks them itself: no copy
        if stacked is None:
            predicted = np.asarray(self.model.predict_many(list(xs), self.q, self.points))  # (k, *readings.shape)
            return (predicted - self.readings).reshape(len(predicted), self.n_values)
        predicted = stacked(list(xs), self.q, self.points)
        predicted -= self.readings  # predict_stacked's own new array: the difference in place
        return predicted.reshape(len(predicted), self.n_values)

    def costs(self, xs: list[np.ndarray]) -> list[float]:
        """:meth:`cost` at several points from batched :meth:`residuals` (at most
        :data:`BATCH_ROWS` point-rows a pass, to bound the memory), [m^2] each."""
        step = max(1, BATCH_ROWS // max(1, len(self.readings)))
        if 0 < len(xs) <= step:  # one pass (a search's few candidates)
            return [float(r @ r) / len(r) for r in self.residuals(xs)]
        out = []
        for start in range(0, len(xs), step):
            for r in self.residuals(xs[start : start + step]):
                out.append(float(r @ r) / len(r))
        return out

    def row_residual_with_jacobian(self, x: np.ndarray, row: int) -> tuple[np.ndarray, np.ndarray]:
        """Row ``row``'s residual (values_per_row,) [m] and Jacobian (values_per_row, n_params)."""
        rows = slice(row, row + 1)
        values, jac = self.model.predict_with_jacobian(x, self.q[rows], None if self.points is None else self.points[rows])
        return values.reshape(-1) - self.readings[rows].reshape(-1), jac.reshape(values.size, -1)

    def row_errors(self, residual: np.ndarray) -> np.ndarray:
        """Size of each row's error, shape (n_rows,), [m]: |reading error| for one value
        per row, the Euclidean error for a position."""
        return np.linalg.norm(np.asarray(residual).reshape(self.n_rows, -1), axis=1)


"""One measurement set's rows and the sensor model that predicts them.

A :class:`SetProblem` is a sensor's part of a calibration problem
(:class:`calib_pin.calibration.problem.Problem`): its rows' joint angles, their measured
values and the measurement model. A sensor whose residual is not "predicted minus
measured" (a 6-D pose's weighted rotation, a contact set's touches and distances)
subclasses it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np

from ..estimators.problem import BATCH_ROWS, RowProblem


@dataclass
class SetProblem(RowProblem):
    """Measured data and the model that predicts it.

    Attributes:
        model: The sensor's measurement model (:mod:`calib_pin.sensors`).
        q: Joint angles of the rows, shape (n_rows, n_joints), [rad].
        readings: Measured values, shape (n_rows,) or (n_rows, values_per_row), [m].
        points: Each row's index of the measured point, for sensors that measure
            several (marker positions); else None.
    """

    model: Any  # the sensor's MeasurementModel (sensors/base.py imports this module)
    q: np.ndarray
    readings: np.ndarray
    points: np.ndarray | None = None
    #: What rows after the data rows are, for people (a contact set's known distances).
    other_rows: ClassVar[str] = "other rows"

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
        """Unknowns that must be >= 0 (the compliances).

        Every estimator keeps them so (:func:`calib_pin.estimators.run_estimator`).
        """
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

    def subset(self, rows: np.ndarray | slice) -> SetProblem:
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
        """:meth:`residual` at k points xs (k, n_params), shape (k, n_values), [m].

        One batched forward-kinematics pass over (points x rows), the same numbers to the bit.
        A problem whose class has its own :meth:`residual` (a 6-D pose's whitened rotation
        vector, a contact set's touches and distances) is evaluated point by point with it:
        the plain batch (predicted minus measured) would be another residual.
        """
        if type(self).residual is not SetProblem.residual:
            return np.array([self.residual(x) for x in xs])
        stacked = getattr(self.model, "predict_stacked", None)  # a model that stacks them itself: no copy
        if stacked is None:
            predicted = np.asarray(self.model.predict_many(list(xs), self.q, self.points))  # (k, *readings.shape)
            return (predicted - self.readings).reshape(len(predicted), self.n_values)
        predicted = stacked(list(xs), self.q, self.points)
        predicted -= self.readings  # predict_stacked's own new array: the difference in place
        return predicted.reshape(len(predicted), self.n_values)

    def costs(self, xs: list[np.ndarray]) -> list[float]:
        """:meth:`cost` at several points from batched :meth:`residuals`, [m^2] each.

        At most :data:`BATCH_ROWS` point-rows a pass, to bound the memory.
        """
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
        """Size of each row's error, shape (n_rows,), [m].

        |reading error| for one value per row, the Euclidean error for a position.
        """
        return np.linalg.norm(np.asarray(residual).reshape(self.n_rows, -1), axis=1)


"""What an estimator sees of a problem: residual, Jacobian, scale and row blocks.

:class:`LeastSquares` is SciPy's ``least_squares`` shape; :class:`RowProblem` derives the
cost and the row blocks from a residual. A calibration problem (:mod:`calib_pin.calibration.problem`)
is one, and so is any small least-squares problem an estimator is tested on.
"""

from __future__ import annotations

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
    """Where each row's residual entries start in ``problem``'s residual, shape (n_rows + 1,).

    Its ``row_offsets``, or, for a problem that states only ``values_per_row`` (rows of one
    size), multiples of it.
    """
    offsets = getattr(problem, "row_offsets", None)
    if offsets is None:
        return np.arange(problem.n_rows + 1) * int(problem.values_per_row)
    return np.asarray(offsets, dtype=int)


def data_rows(problem: Any) -> np.ndarray:
    """The rows of ``problem`` that are data rows, in order, shape (n_data,).

    Row k of its ``q`` (and of the measurement set) is row ``data_rows(problem)[k]`` of its
    residual's rows.

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
    """What every least-squares problem derives from its residual and row size.

    The cost and the rows of residual entries, shared by
    :class:`~calib_pin.sensors.problem.SetProblem`, :class:`calib_pin.calibration.problem.Problem`
    and the active set's reduced problem.
    """

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


#: Points x rows of one batched pass of a problem's ``costs`` (a few tens of MB).
BATCH_ROWS = 200_000

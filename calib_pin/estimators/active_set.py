"""Unknowns that must be >= 0 (joint compliances), for every estimator: an active set.

A problem names its bounded unknowns in ``nonnegative`` (indices into x; a calibration
problem: the compliances [rad/Nm], :attr:`calib_pin.sensors.base.MeasurementModel.nonnegative`).
:func:`estimate_nonnegative` runs an estimator; while some bounded unknown comes out
negative it fixes those at zero, drops their columns from the problem (:class:`Fixed`, so
the estimator searches the others only, as it leaves a blind direction at its start) and
runs the same estimator again, from the same start with the same seed. Each round fixes
at least one more unknown, so it ends within ``len(nonnegative) + 1`` runs. A bound that
is fixed stays fixed (no unknown is released again): the answer is the estimate with the
fitted-negative unknowns held at zero, which the report names.

Values within :data:`TOLERANCE` (relative to the unknown's scale) below zero are rounding
of a blind direction, not a fit: they are set to exactly zero without another run.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .base import EstimateResult
from .problem import LeastSquares, RowProblem, row_offsets

#: A bounded unknown below -TOLERANCE x its scale counts as negative (1e-3 of a typical
#: compliance: -0.02 urad/Nm, a stiffness of 5e7 Nm/rad); one between that and zero is the
#: leak of a blind direction into the search (1e-11 rad/Nm seen) and is set to zero.
TOLERANCE = 1e-3


@dataclass(frozen=True)
class Fixed(RowProblem):
    """A least-squares problem with some unknowns held at given values.

    The estimator sees the free ones only (their columns, scale and count).

    Attributes:
        problem: The full problem.
        free: Indices of the free unknowns, shape (n_free,).
        values: Every unknown's value, shape (n_params,), SI units; the fixed ones are used.
    """

    problem: Any
    free: np.ndarray
    values: np.ndarray

    def expand(self, z: np.ndarray) -> np.ndarray:
        """The full unknown vector for free values z, shape (n_params,)."""
        x = np.array(self.values, dtype=float)
        x[self.free] = z
        return x

    @property
    def scale(self) -> np.ndarray:
        return np.asarray(self.problem.scale)[self.free]

    @property
    def values_per_row(self) -> int:
        return self.problem.values_per_row

    @property
    def row_offsets(self) -> np.ndarray:
        return row_offsets(self.problem)

    @property
    def n_rows(self) -> int:
        return self.problem.n_rows

    @property
    def n_values(self) -> int:
        return self.problem.n_values

    @property
    def n_params(self) -> int:
        return len(self.free)

    def residual(self, z: np.ndarray) -> np.ndarray:
        return self.problem.residual(self.expand(z))

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        return self.problem.jacobian(self.expand(z))[:, self.free]

    def row_residual_with_jacobian(self, z: np.ndarray, row: int) -> tuple[np.ndarray, np.ndarray]:
        r, jac = self.problem.row_residual_with_jacobian(self.expand(z), row)
        return r, jac[:, self.free]

    def subset(self, rows: np.ndarray | slice) -> Fixed:
        return Fixed(self.problem.subset(rows), self.free, self.values)

    def __getattr__(self, name: str) -> Any:
        """The full problem's data (``q``, ``points``, ``model``) for methods that read it."""
        if name.startswith("__") or name in ("problem", "free", "values"):  # not set yet (unpickling)
            raise AttributeError(name)
        return getattr(self.problem, name)


def expanded(result: EstimateResult, fixed: Fixed, bounded: tuple[int, ...], nfev: float,
              rounds: int) -> EstimateResult:
    """``result`` of the reduced problem in the full problem's unknowns."""
    extras = dict(result.extras)
    cov = result.covariance
    if cov is not None:  # the fixed unknowns are known exactly: zero rows and columns
        full = np.zeros((len(fixed.values), len(fixed.values)))
        full[np.ix_(fixed.free, fixed.free)] = cov
        extras["covariance"] = full
    extras["bounded"] = bounded
    message = result.message
    if rounds > 1:
        message = f"{message} (run {rounds} times: {len(bounded)} unknown(s) fitted negative, fixed at zero)"
    return dataclasses.replace(result, x=fixed.expand(result.x), extras=extras, nfev=nfev,
                               message=message)


def estimate_nonnegative(
    run: Callable[[LeastSquares, np.ndarray], EstimateResult], problem: LeastSquares, x0: np.ndarray,
    nonnegative: Sequence[int],
) -> EstimateResult:
    """``run(problem, x0)`` with the unknowns ``nonnegative`` kept >= 0 by an active set.

    Args:
        run: One estimate of a problem from a start (an estimator with its settings).
        problem: The least-squares problem (SI units).
        x0: The start, shape (n_params,); its bounded entries must be >= 0.
        nonnegative: Indices of the unknowns that must be >= 0.

    Returns:
        The estimate, every bounded unknown >= 0; ``extras["bounded"]`` (``.bounded``):
        the indices fitted negative and fixed at zero, ascending. ``nfev`` adds up every
        run; the rest (``history``, ``iterations``) is the last run's.
    """
    x0 = np.asarray(x0, dtype=float)
    n = len(x0)
    bounds = np.asarray(sorted(set(int(i) for i in nonnegative)), dtype=int)
    scale = np.asarray(problem.scale, dtype=float)
    fixed_at_zero: list[int] = []
    nfev, rounds = 0.0, 0
    while True:
        start = x0.copy()
        start[fixed_at_zero] = 0.0
        reduced = Fixed(problem, np.setdiff1d(np.arange(n), fixed_at_zero), start)
        result = run(reduced, start[reduced.free])
        rounds += 1
        nfev += result.nfev
        x = reduced.expand(result.x)
        free_bounds = np.setdiff1d(bounds, fixed_at_zero)
        negative = free_bounds[x[free_bounds] < -TOLERANCE * scale[free_bounds]]
        if not len(negative):
            break
        fixed_at_zero = sorted([*fixed_at_zero, *negative.tolist()])
    out = expanded(result, reduced, tuple(fixed_at_zero), nfev, rounds)
    x = np.array(out.x)
    x[bounds] = np.where(x[bounds] <= 0.0, 0.0, x[bounds])  # rounding of a blind direction (or -0.0): zero
    return dataclasses.replace(out, x=x)

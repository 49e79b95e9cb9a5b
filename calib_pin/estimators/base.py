"""What every estimator shares: the call signature, the result type and its bookkeeping.

An estimator is a small frozen dataclass whose fields are its settings (with documented
defaults) and whose call is::

    estimator(problem, x0, *, seed=0, noise=5e-5, callback=None) -> EstimateResult

``problem`` is any :class:`calib_pin.estimators.problem.LeastSquares` (residual, Jacobian, scale and
row blocks; a calibration problem is one), ``x0`` the start (SI units), ``seed`` seeds any
randomness, ``noise`` is the measurement noise (1 sigma, [m]) for methods that weigh
values by it. ``callback(rmse, evaluations)``, when given, is called with the training
RMSE [m] at the start and after every iteration and the evaluations used so far: the
convergence history. Without it nothing is recorded, so a benchmark times the method
and not its bookkeeping. A method whose iteration is one row's update (the Kalman
filters) computes the training RMSE over every row for each entry: it records at most
:data:`HISTORY_POINTS` entries, spread evenly over its updates (every update when it
has no more), so the record costs O(rows), not O(rows^2); the result's
``history_iterations`` then says which update each entry follows. Those entries are
computed in batches (one batched residual pass over at most
:data:`calib_pin.estimators.problem.BATCH_ROWS` point-rows, :meth:`Tracker.flush`) and handed to the
callback when a batch is full, at the last update and before any other entry: the
callback gets the same calls with the same values in the same order, only later; a
callback that raises to stop a filter stops it at the end of that batch, not at its entry.

Work is counted in *evaluations*: one evaluation is the residual (or the Jacobian) of
the whole training set; a Kalman update that predicts one row counts 1/n_rows of an
evaluation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .problem import BATCH_ROWS, LeastSquares
from .subspace import Subspace

#: ``callback(rmse, evaluations)``: training RMSE [m] reached with that many evaluations.
Callback = Callable[[float, float], None]

#: Most history entries a method records over its row updates (see the module docstring):
#: a convergence figure is drawn from a hundred points as well as from every one, and each
#: entry is the training RMSE over every row, a full residual pass.
HISTORY_POINTS = 100

#: ``correction(q, points)``: what to add to the values a model predicts at joint angles
#: q (n_rows, n_joints) [rad] for rows measuring points ``points`` (each row's point
#: index, or None for a sensor that measures one point), shape (n_rows, values_per_row), [m].
Correction = Callable[[np.ndarray, np.ndarray | None], np.ndarray]


@dataclass(frozen=True)
class EstimateResult:
    """Outcome of one estimate (not changed after it is returned).

    Attributes:
        x: Estimated unknowns, shape (n_params,), SI units ([m], [rad]).
        success: True when the method stopped on its convergence rule, not on a budget
            or a failure.
        status: 0 converged, 1 iteration or evaluation budget used, 2 failed.
        message: Why the method stopped.
        iterations: Iterations of the method's main loop (see each method).
        nfev: Evaluations used in all (see the module docstring).
        history: Training RMSE [m] at the start and after each iteration, when recorded
            (a callback was given), else empty.
        evaluations: Evaluations used when each ``history`` entry was reached.
        time_s: Wall time of the estimate, [s].
        extras: Method-specific results: ``covariance`` (a Kalman filter's P carried to
            x), ``stages`` (a pipeline's iterations per stage), ``correction`` (RBF: a
            :data:`Correction`, what to add to the predicted values [m]),
            ``outliers`` (rows a robust method judged outliers), ``bounded`` (unknowns
            fixed at zero because they fitted negative, see :attr:`bounded`),
            ``history_iterations`` (when the history was thinned: the iteration each of
            its first entries follows; later entries follow one iteration each).
    """

    x: np.ndarray
    success: bool
    status: int
    message: str
    iterations: int
    nfev: float
    history: tuple[float, ...] = ()
    evaluations: tuple[float, ...] = ()
    time_s: float = 0.0
    extras: Mapping[str, Any] = field(default_factory=dict)

    @property
    def kinematic(self) -> bool:
        """True when x alone is the calibration (it can be exported as a URDF)."""
        return self.correction is None

    @property
    def correction(self) -> Correction | None:
        return self.extras.get("correction")

    @property
    def covariance(self) -> np.ndarray | None:
        return self.extras.get("covariance")

    @property
    def stages(self) -> dict[str, int]:
        return dict(self.extras.get("stages", {}))

    @property
    def outliers(self) -> tuple[int, ...]:
        return tuple(self.extras.get("outliers", ()))

    @property
    def bounded(self) -> tuple[int, ...]:
        """Unknowns (indices into x) that must be >= 0, fitted negative and fixed at zero.

        See :mod:`calib_pin.estimators.active_set`.
        """
        return tuple(self.extras.get("bounded", ()))

    def predict(self, model: Any, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Values [m] this estimate predicts at joint angles q [rad] with a measurement model.

        For rows measuring ``points`` (point indices; None for a one-point sensor).
        """
        values = model.predict(self.x, q, points)
        if self.correction is not None:
            values = values + self.correction(np.atleast_2d(q), points).reshape(values.shape)
        return values

    def residual(self, problem: LeastSquares) -> np.ndarray:
        """Predicted minus measured values of ``problem``'s rows, flattened, [m]."""
        r = problem.residual(self.x)
        if self.correction is None:
            return r
        return r + self.correction(problem.q, problem.points).reshape(-1)  # type: ignore[attr-defined]

    def converged(self, tolerance: float = 0.05) -> tuple[int, float]:
        """Iterations and evaluations used until the training RMSE first came within ``tolerance``.

        ``tolerance`` is relative to its final value; needs a recorded history.
        """
        if not self.history:
            return self.iterations, float(self.nfev)
        h = np.asarray(self.history)
        k = int(np.argmax(h <= h[-1] * (1.0 + tolerance)))
        return self.iteration_of(k), float(self.evaluations[k])

    def iteration_of(self, entry: int) -> int:
        """The iteration after which ``history[entry]`` was recorded (0: the start)."""
        known = tuple(self.extras.get("history_iterations", ()))
        if entry < len(known):
            return int(known[entry])
        return int(known[-1]) + entry - len(known) + 1 if known else entry


class History:
    """A callback that keeps what it is given: ``history`` [m] and ``evaluations``."""

    def __init__(self) -> None:
        self.history: list[float] = []
        self.evaluations: list[float] = []

    def __call__(self, rmse_m: float, evaluations: float) -> None:
        self.history.append(float(rmse_m))
        self.evaluations.append(float(evaluations))


def offset(callback: Callback | None, evaluations: float, skip_first: bool = True) -> Callback | None:
    """A callback for a later stage, its evaluations counted after ``evaluations`` already used.

    With ``skip_first``, its start is not recorded again.
    """
    if callback is None:
        return None
    state = {"first": skip_first}

    def inner(rmse_m: float, used: float) -> None:
        if state["first"]:
            state["first"] = False
            return
        callback(rmse_m, evaluations + used)

    return inner


class Tracker:
    """Counts evaluations and reports progress to an optional callback.

    Args:
        problem: The least-squares problem.
        callback: See the module docstring; None records nothing.
    """

    def __init__(self, problem: LeastSquares, callback: Callback | None = None) -> None:
        self.problem = problem
        self.callback = callback
        self.nfev = 0.0
        self.stride = 1
        self.updates = 0
        self.recorded: list[int] = []  # the update each entry follows, when thinned
        self.pending: list[tuple[np.ndarray, float]] = []  # row updates' (x, nfev) not yet reported

    @property
    def recording(self) -> bool:
        return self.callback is not None

    def whitened(self, x0: np.ndarray) -> Subspace:
        """The identifiable subspace at x0 (:mod:`calib_pin.estimators.subspace`).

        Its Jacobian counts as one evaluation.
        """
        self.nfev += 1
        x0 = np.asarray(x0, dtype=float)
        return Subspace.of(self.problem.jacobian(x0), self.problem.scale, x0)

    def cost(self, x: np.ndarray) -> float:
        """Mean squared residual (eq. 6) [m^2], counted as one evaluation."""
        self.nfev += 1
        return self.problem.cost(x)

    def costs(self, xs: list[np.ndarray], used: int | None = None) -> list[float]:
        """:meth:`cost` at several points, counted as one evaluation each (or as ``used``).

        With ``used``, the first ``used`` points are counted, when the others are a
        look-ahead that is counted only if the method uses it (see :meth:`count`). Batched
        where the problem's own class evaluates several at once (``costs``, :attr:`batched`),
        else one by one (a problem with another cost, e.g. a robust one, never inherits the
        plain batch).
        """
        self.nfev += len(xs) if used is None else used
        batched = getattr(type(self.problem), "costs", None)
        if batched is None:
            return [self.problem.cost(x) for x in xs]
        return list(batched(self.problem, xs))

    @property
    def batched(self) -> bool:
        """True when :meth:`costs` evaluates several points in one call of the problem's own."""
        return getattr(type(self.problem), "costs", None) is not None

    def count(self, evaluations: int) -> None:
        """Count evaluations done ahead (:meth:`costs` with ``used``) once the method uses them."""
        self.nfev += evaluations

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Residual [m], counted as one evaluation."""
        self.nfev += 1
        return self.problem.residual(x)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Jacobian, counted as one evaluation."""
        self.nfev += 1
        return self.problem.jacobian(x)

    def record(self, rmse_m: float) -> None:
        """Report a training RMSE [m] reached with the evaluations counted so far."""
        if self.callback is not None:
            self.flush()
            self.callback(float(rmse_m), self.nfev)

    def record_at(self, x: np.ndarray) -> None:
        """Report the training RMSE at x; computed only when recording, and not counted as work.

        It is bookkeeping, not part of the method.
        """
        if self.callback is not None:
            self.flush()
            self.callback(rmse(self.problem.residual(x)), self.nfev)

    def flush(self) -> None:
        """Report the row updates' RMSEs held back by :meth:`record_update`, in order.

        Their residuals come from one batched pass of the problem's own ``residuals`` (the
        same numbers to the bit as one :meth:`record_at` each, the same callback calls in the
        same order).
        """
        if not self.pending:
            return
        pending, self.pending = self.pending, []
        residuals = type(self.problem).residuals(self.problem, [x for x, _ in pending])  # type: ignore[attr-defined]
        for (_, nfev), r in zip(pending, residuals, strict=True):
            self.callback(rmse(r), nfev)  # type: ignore[misc]

    def thin(self, updates: int) -> None:
        """Record at most :data:`HISTORY_POINTS` of ``updates`` row updates after the start.

        Every ``stride``-th and the last; call before the start is recorded.
        """
        self.stride = max(1, -(-updates // HISTORY_POINTS))
        self.updates = updates
        self.recorded = [0] if self.stride > 1 else []

    def record_update(self, x: np.ndarray, update: int) -> None:
        """After row update ``update`` (1-based) at estimate x: :meth:`record_at` at a thinned point.

        It records only when ``update`` is one of the thinned points (see :meth:`thin`).
        """
        if self.callback is None or (update % self.stride and update != self.updates):
            return
        if self.stride > 1:
            self.recorded.append(update)
        if getattr(type(self.problem), "residuals", None) is None:
            self.record_at(x)
            return
        # Held back and evaluated in batches of at most BATCH_ROWS point-rows: one batched
        # pass instead of one residual call per recorded update.
        self.pending.append((np.array(x, dtype=float), self.nfev))
        if len(self.pending) * self.problem.n_rows >= BATCH_ROWS or update == self.updates:
            self.flush()

    def result(self, x: np.ndarray, iterations: int, message: str, *, status: int = 0,
               **extras: Any) -> EstimateResult:
        if self.callback is not None:
            self.flush()
        if self.recorded and self.callback is not None:
            extras.setdefault("history_iterations", tuple(self.recorded))
        return EstimateResult(
            x=np.asarray(x, dtype=float).copy(), success=status == 0, status=status, message=message,
            iterations=iterations, nfev=self.nfev, extras={k: v for k, v in extras.items() if v is not None},
        )


def rmse(residual: np.ndarray) -> float:
    """Root mean square of a residual vector, in its unit."""
    return float(np.sqrt(np.mean(np.square(residual))))

"""Estimators on a tiny linear least-squares problem: the narrow interface they share."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pytest

from calib_pin.estimators import METHODS, get_method, run_estimator
from calib_pin.estimators.base import History
from calib_pin.exceptions import EstimatorError


@dataclass
class Linear:
    """r(x) = A x - b with rows of ``values_per_row`` values: any LeastSquares will do."""

    a: np.ndarray
    b: np.ndarray
    scale: np.ndarray
    values_per_row: int = 1

    @property
    def n_rows(self) -> int:
        return len(self.b) // self.values_per_row

    @property
    def n_values(self) -> int:
        return len(self.b)

    @property
    def n_params(self) -> int:
        return self.a.shape[1]

    def residual(self, x):
        return self.a @ x - self.b

    def jacobian(self, x):
        return self.a

    def row_residual_with_jacobian(self, x, row):
        k = slice(row * self.values_per_row, (row + 1) * self.values_per_row)
        return self.a[k] @ x - self.b[k], self.a[k]

    def cost(self, x):
        r = self.residual(x)
        return float(r @ r) / len(r)

    def subset(self, rows):
        rows = np.arange(self.n_rows)[rows]
        k = (rows[:, None] * self.values_per_row + np.arange(self.values_per_row)).ravel()
        return Linear(self.a[k], self.b[k], self.scale, self.values_per_row)

    def rows_of(self, values):
        return np.unique(np.asarray(values, dtype=int) // self.values_per_row)


def _problem(values_per_row: int = 1, noise: float = 1e-6) -> tuple[Linear, np.ndarray]:
    rng = np.random.default_rng(0)
    a = rng.normal(size=(60, 3))
    x_true = np.array([1e-3, -2e-3, 0.5e-3])
    b = a @ x_true + rng.normal(scale=noise, size=60)
    return Linear(a, b, np.full(3, 1e-3), values_per_row), x_true


@pytest.mark.parametrize("name", [m for m in METHODS if METHODS[m].kinematic])
def test_every_estimator_solves_a_small_linear_problem(name):
    """Each parameter method recovers x of a 3-unknown linear problem (noise 1e-6): to
    2e-5 (a typical size 1e-3), or 3e-4 for BAS, whose plain search stops earliest."""
    problem, x_true = _problem()
    result = run_estimator(name, problem, np.zeros(3), noise=1e-6)
    np.testing.assert_allclose(result.x, x_true, atol=3e-4 if name == "bas" else 2e-5)
    assert result.nfev > 0 and result.iterations >= 1 and result.status in (0, 1)


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_kalman_filters_take_blocks_of_values(name):
    """A row of three values is one Kalman update; the estimate is the same problem's."""
    problem, x_true = _problem(values_per_row=3)
    result = run_estimator(name, problem, np.zeros(3), noise=1e-6)
    assert result.iterations == 20
    np.testing.assert_allclose(result.x, x_true, atol=2e-5)


def test_history_only_through_the_callback():
    """Without a callback nothing is recorded, and the estimate is the same."""
    problem, _ = _problem()
    with_history = run_estimator("ekf-qibas", problem, np.zeros(3))
    without = run_estimator("ekf-qibas", problem, np.zeros(3), history=False)
    np.testing.assert_array_equal(with_history.x, without.x)
    assert without.history == () and len(with_history.history) == with_history.iterations + 1
    assert list(with_history.evaluations) == sorted(with_history.evaluations)


def test_callback_sees_start_and_every_iteration():
    """The callback gets (RMSE, evaluations) at the start and after each iteration."""
    problem, _ = _problem()
    seen = History()
    result = get_method("qibas").estimator()(problem, np.zeros(3), callback=seen)
    assert len(seen.history) == result.iterations + 1 and seen.history[-1] <= seen.history[0]


def test_result_is_not_changed_after_return():
    """EstimateResult is frozen: method specifics live in extras."""
    problem, _ = _problem()
    result = run_estimator("ekf", problem, np.zeros(3))
    with pytest.raises(AttributeError):
        result.x = np.ones(3)  # type: ignore[misc]
    assert result.covariance is not None and result.covariance.shape == (3, 3)


def test_method_records_state_their_capabilities():
    """The registry answers what the code would otherwise ask of the estimator's type."""
    assert get_method("lm").robust == "native" and get_method("bas").robust == "refit"
    assert not get_method("rbf").kinematic and get_method("rbf").kinds == ()
    assert not get_method("lm+rbf").kinematic and not get_method("lm+rbf").paper
    with pytest.raises(EstimatorError, match="has no robust loss"):
        get_method("ekf").check("cauchy")
    assert "takes cable data, not position data" in dataclasses.replace(get_method("rbf"), kinds=("cable",)).takes(
        "position")
    assert "rows differ in size" in get_method("ukf").takes("contact", ("ukf",)) and get_method("lm").takes("contact") is None
    with pytest.raises(EstimatorError, match="unknown method 'nope'"):
        get_method("nope")

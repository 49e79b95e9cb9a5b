"""UKF: each update's sigma points are predicted in one batched call, the same numbers to
the bit as one residual per sigma point (filterpy's hx called point by point)."""

from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin import prepare
from calib_pin.estimators import run_estimator, ukf

ROBOTS = Path(__file__).parent.parent / "robots"


def _one_by_one(monkeypatch):
    """Make every sigma point miss the batch: each is evaluated on its own, as before."""
    batched = ukf._Predictions.__init__

    def unbatched(self, row, space, sigmas):
        batched(self, row, space, sigmas)
        self.at = {}

    monkeypatch.setattr(ukf._Predictions, "__init__", unbatched)


def _positions():
    chain = cp.load_chain("ur5")
    data, _ = cp.simulate_positions(chain, cp.parameter_model(chain), 12, seed=2, noise_mm=0.05,
                                    markers_mm=((60.0, 0.0, 40.0), (0.0, 50.0, 30.0)))
    return prepare("ur5", data).problem_on(np.arange(len(data)))


@pytest.mark.parametrize("kind", ["cable", "positions", "pose"])
def test_batched_sigma_points_are_the_one_by_one_filter(session, monkeypatch, kind):
    """Cable rows, position rows of two markers and 6-D pose rows (a class with its own
    residual, evaluated point by point inside the batch): estimate, covariance, history
    and counts equal the filter that evaluates each sigma point on its own."""
    if kind == "cable":
        problem = prepare("irb120", session[0]).problem_on(np.arange(40))
    elif kind == "positions":
        problem = _positions()
    else:
        problem = prepare("irb120", ROBOTS / "irb120_pose_example.csv").problem.subset(np.arange(20))
    x0 = np.zeros(problem.n_params)
    batched = run_estimator("ukf", problem, x0)
    calls = []
    residual = type(problem).residual
    monkeypatch.setattr(type(problem), "residual", lambda self, x: calls.append(1) or residual(self, x))
    _one_by_one(monkeypatch)
    single = run_estimator("ukf", problem, x0)
    assert len(calls) >= round((batched.nfev - 1) * problem.n_rows)  # every sigma point on its own
    assert np.array_equal(batched.x, single.x) and np.array_equal(batched.covariance, single.covariance)
    assert batched.history == single.history and batched.evaluations == single.evaluations
    assert (batched.iterations, batched.nfev) == (single.iterations, single.nfev)


def test_a_point_outside_the_batch_is_evaluated_on_its_own(session):
    """The measurement function answers any point: one not among the sigma points gets
    the row's own residual there."""
    problem = prepare("irb120", session[0]).problem_on(np.arange(5))
    row = problem.subset(slice(2, 3))
    space = cp.estimators.base.Tracker(problem).whitened(np.zeros(problem.n_params))
    rng = np.random.default_rng(0)
    sigmas = rng.normal(size=(7, space.dim))
    predicted = ukf._Predictions(row, space, sigmas)
    for s in sigmas:
        assert np.array_equal(predicted(s), row.residual(space.to_x(s)))
    other = rng.normal(size=space.dim)
    assert np.array_equal(predicted(other), row.residual(space.to_x(other)))

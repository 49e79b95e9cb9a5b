"""DE: scipy's immediate updating by default; ``updating="deferred"`` evaluates each
generation's trials in one batched call, the same search to the bit as evaluating them
one at a time."""

import numpy as np
import pytest

from calib_pin import prepare
from calib_pin.estimators.base import Tracker
from calib_pin.estimators.de import DE
from calib_pin.exceptions import ArgumentError


@pytest.fixture(scope="module")
def problem(session):
    return prepare("irb120", session[0]).problem_on(np.arange(96))


def test_deferred_generations_batched_are_the_one_by_one_search(problem, monkeypatch):
    """Batched trial costs give the same estimate, iterations, evaluations and history
    as the same deferred search evaluating each trial on its own."""
    search = DE(updating="deferred", max_iter=15)
    x0 = np.zeros(problem.n_params)
    history: list[tuple[float, float]] = []
    batched = search(problem, x0, callback=lambda r, e: history.append((r, e)))
    batches: list[int] = []
    monkeypatch.setattr(Tracker, "costs", lambda self, xs: batches.append(len(xs)) or [self.cost(x) for x in xs])
    single_history: list[tuple[float, float]] = []
    single = search(problem, x0, callback=lambda r, e: single_history.append((r, e)))
    assert batches and min(batches) > 1  # a generation a call
    assert np.array_equal(batched.x, single.x)
    assert (batched.iterations, batched.nfev, batched.message) == (single.iterations, single.nfev, single.message)
    assert history == single_history and len(history) == batched.iterations + 1


def test_deferred_reaches_the_noise_floor(problem, session, fresh):
    """The deferred search predicts 1000 fresh poses within 0.06 mm of the noise-free truth."""
    result = DE(updating="deferred")(problem, np.zeros(problem.n_params), seed=0)
    q, true_readings = fresh
    assert result.success and np.sqrt(np.mean((problem.model.predict(result.x, q) - true_readings) ** 2)) * 1e3 < 0.06


def test_an_unknown_updating_is_refused(problem):
    with pytest.raises(ArgumentError, match="updating: expected one of immediate, deferred, got 'later'"):
        DE(updating="later")(problem, np.zeros(problem.n_params))

"""CalibrationProblem.residuals / costs: a search's candidate points in one batched
forward-kinematics pass, the same numbers to the bit as one residual per point."""

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.estimators import run_estimator
from calib_pin.estimators.base import Tracker
from calib_pin.estimators.robust import RobustProblem
from calib_pin.pipeline import prepare
from calib_pin.robot.deflection import Compliance


def _points(problem, k=4, seed=0):
    rng = np.random.default_rng(seed)
    return [0.5 * problem.scale * rng.standard_normal(problem.n_params) for _ in range(k)]


def _check(problem):
    xs = _points(problem)
    batched = problem.residuals(xs)
    assert batched.shape == (len(xs), problem.n_values)
    for x, r in zip(xs, batched, strict=True):
        assert np.array_equal(r, problem.residual(x))
    assert problem.costs(xs) == [problem.cost(x) for x in xs]


def test_cable_rows_batched_to_the_bit(session):
    data, _ = session
    _check(prepare("irb120", data).problem_on(np.arange(96)))


def test_position_rows_batched_to_the_bit():
    chain = cp.load_chain("ur5")
    data, _ = cp.simulate_positions(chain, cp.parameter_model(chain), 30, seed=2, noise_mm=0.05,
                                    markers_mm=((60.0, 0.0, 40.0), (0.0, 50.0, 30.0)))
    problem = prepare("ur5", data).problem_on(np.arange(len(data)))
    assert problem.points is not None and len(set(problem.points)) == 2  # rows of two markers
    _check(problem)


def test_with_compliances_each_point_on_its_own_deflection(session):
    data, _ = session
    problem = prepare("irb120", data, compliance=Compliance(("joint_2", "joint_3"), cable_tension_n=5.0)).problem_on(np.arange(96))
    assert problem.model.deflection is not None
    _check(problem)


def test_a_robust_cost_is_never_batched_as_the_plain_one(session):
    data, _ = session
    problem = prepare("irb120", data).problem_on(np.arange(96))
    robust = RobustProblem(problem, "huber", 1e-4)
    xs = _points(problem)
    track = Tracker(robust, None)
    assert track.costs(xs) == [robust.cost(x) for x in xs] != problem.costs(xs)
    assert track.nfev == len(xs)


def test_qibas_reaches_the_truth_with_batched_antennae(session, fresh):
    data, _ = session
    problem = prepare("irb120", data).problem_on(np.arange(96)).subset(np.arange(96))
    result = run_estimator("qibas", problem, np.zeros(problem.n_params), seed=0)
    q, true_readings = fresh
    assert np.sqrt(np.mean((problem.model.predict(result.x, q) - true_readings) ** 2)) * 1e3 < 0.06


def test_costs_in_bounded_passes_are_the_same(session, monkeypatch):
    from calib_pin import problem as problem_module

    data, _ = session
    problem = prepare("irb120", data).problem_on(np.arange(96))
    xs = _points(problem, k=5)
    whole = problem.costs(xs)
    monkeypatch.setattr(problem_module, "BATCH_ROWS", 2 * 96)  # two points a pass: 2 + 2 + 1
    assert problem.costs(xs) == whole == [problem.cost(x) for x in xs]


@pytest.mark.parametrize("example", ["irb120_pose_example.csv", "irb120_contact_example.csv", "irb120_default.csv"])
def test_batched_costs_are_each_sensors_own_cost(example):
    """The searches' batched costs equal the problem's own cost point by point for every
    shipped sensor: a 6-D pose (whitened rotation vector) and a contact set (touches and
    distances) have their own residual, which the plain batch must not replace."""
    from pathlib import Path

    problem = prepare("irb120", Path(__file__).parent.parent / "robots" / example).problem
    rng = np.random.default_rng(3)
    xs = [rng.normal(size=problem.n_params) * problem.scale * 0.1 for _ in range(3)]
    assert problem.costs(xs) == [problem.cost(x) for x in xs]


def test_pose_rows_batched_costs_are_the_weighted_pose_cost():
    """A 6-D pose set's residual is its weighted pose error, not predicted minus the 7
    numbers read: BAS/QIBAS/PSO's batched costs are that residual's."""
    from calib_pin.simulation import simulate_sessions

    chain = cp.load_chain("irb120")
    (data,), _ = simulate_sessions(chain, cp.parameter_model(chain), [20], seed=3, kinds=("pose",))
    problem = prepare("irb120", data).problem_on(np.arange(len(data)))
    assert type(problem).__name__ == "PoseProblem"
    _check(problem)


def test_contact_rows_batched_costs_keep_the_distance_rows():
    from calib_pin.sensors.contact import simulate_contacts

    chain = cp.load_chain("irb120")
    data, _ = simulate_contacts(chain, cp.parameter_model(chain), 6, seed=11, noise_mm=0.05)
    problem = prepare("irb120", data).problem_on(np.arange(len(data)))
    assert type(problem).__name__ == "ContactProblem"
    _check(problem)

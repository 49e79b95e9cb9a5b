"""RBF network (M5) and LM + RBF on the residual (M6+M5), against simulated truth.

M5 on sin/cos inputs with the kernel chosen by cross-validation must beat the first M5
(raw angles, thin-plate spline); LM + RBF must lower the fresh-pose error when the data
hold an unmodelled smooth error (compliant joints calibrated without compliance) and
change little when they hold none; both must take positions of several markers.
"""

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.estimators import run_estimator
from calib_pin.estimators.rbf import RBF
from calib_pin.exceptions import CalibPinError
from calib_pin.robot.deflection import ComplianceSpec
from calib_pin.robot.poses import random_poses
from calib_pin.simulation import simulate, simulate_positions
from calib_pin.studies.comparison import FRESH_POSES

#: True compliances of joints 2 and 3 [rad/Nm] (as in test_deflection.py).
TRUE_C = np.array([2.5e-5, 4e-5])
#: The first M5: raw joint angles [rad], thin-plate spline, smoothing by cross-validation.
FIRST_M5 = RBF(features="angles", kernels=("thin_plate_spline",), smoothing=(0.0, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0))


def fresh_scorer(setup, truth, seed):
    """score(predict) -> RMSE [mm] of ``predict(q, points)`` [m] at compare's fresh poses
    (every point the sensor measures, at each) against the noise-free truth."""
    poses = random_poses(setup.chain, FRESH_POSES, np.random.default_rng(seed + 10_000))
    model = truth.model(setup.chain, setup.params)
    rows, points = model.grid_points(len(poses))
    q = poses[rows]
    true_values = model.predict(truth.x_model, q, points)
    return lambda predict: float(np.sqrt(np.mean(model.fresh_difference(predict(q, points), true_values) ** 2)) * 1e3)


def _fresh_mm(setup, truth, estimate, problem) -> float:
    """Fresh-pose RMSE [mm] of an estimate against the noise-free truth."""
    return fresh_scorer(setup, truth, 0)(lambda q, points: estimate.predict(problem.model, q, points))


def test_sincos_inputs_beat_raw_angles(session):
    """On the 120-pose drawstring session (3 splits), M5 with sin/cos inputs and the kernel
    chosen by cross-validation removes more of the nominal fresh-pose error than the first
    M5, and at least 30 % of it."""
    data, truth = session
    setup = cp.prepare("irb120", data)
    removed: dict[str, list[float]] = {"first": [], "new": []}
    for seed in range(3):
        train, _ = setup.split(0.2, seed)
        problem = setup.problem_on(train)
        x0 = np.zeros(problem.n_params)
        nominal = fresh_scorer(setup, truth, 0)(lambda q, points, p=problem, x=x0: p.model.predict(x, q, points))
        for name, net in (("first", FIRST_M5), ("new", RBF())):
            estimate = net(problem.subset(train), x0, seed=seed)
            removed[name].append(1 - _fresh_mm(setup, truth, estimate, problem) / nominal)
    assert np.mean(removed["new"]) > np.mean(removed["first"]) + 0.1
    assert np.mean(removed["new"]) > 0.3


@pytest.fixture(scope="module")
def compliant_cable(chain, params):
    """150 drawstring poses (5 N pull) of an arm with compliant joints 2 and 3."""
    spec = ComplianceSpec(("joint_2", "joint_3"), cable_tension_n=5.0)
    return simulate(chain, params, 150, seed=9, compliance=spec, true_compliance=TRUE_C)


def test_lm_rbf_learns_an_unmodelled_smooth_error(compliant_cable):
    """Compliant joints calibrated with a geometric model: the network on LM's residual
    lowers the fresh-pose error by at least 8 %; x is LM's estimate and there is no URDF."""
    data, truth = compliant_cable
    setup = cp.prepare("irb120", data)
    lm, both = cp.solve(setup, "lm"), cp.solve(setup, "lm+rbf")
    fresh = {r.method: _fresh_mm(setup, truth, r.estimate, r.problem) for r in (lm, both)}
    assert fresh["lm+rbf"] < 0.92 * fresh["lm"]
    assert np.allclose(both.x, lm.x) and not both.kinematic
    assert both.estimate.stages == {"lm": lm.estimate.iterations, "rbf": 1}
    assert both.metrics["test"]["after"].rmse_mm < lm.metrics["test"]["after"].rmse_mm


def test_lm_rbf_changes_little_on_geometric_data(session):
    """No unmodelled error: LM + RBF stays within 5 % (+ 1 um) of LM on fresh poses."""
    data, truth = session
    setup = cp.prepare("irb120", data)
    fresh = {m: _fresh_mm(setup, truth, (r := cp.solve(setup, m)).estimate, r.problem) for m in ("lm", "lm+rbf")}
    assert fresh["lm+rbf"] <= 1.05 * fresh["lm"] + 1e-3


def test_nothing_learnable_gives_a_zero_correction():
    """Pure noise: cross-validation finds no network that beats adding nothing."""
    rng = np.random.default_rng(0)
    chain = cp.load_chain("irb120")
    data, _ = simulate(chain, cp.parameter_model(chain), 60, seed=2, nominal_rmse_mm=0.0, noise_mm=0.05)
    problem = cp.prepare("irb120", data).problem
    x = run_estimator("lm", problem, np.zeros(problem.n_params)).x
    result = RBF()(problem, x)
    assert "no network" in result.message
    assert not np.any(result.correction(rng.normal(size=(4, 6)), None))


def test_positions_of_several_markers(chain, params):
    """100 poses x 3 markers: M5 learns a vector per row that depends on the marker (it
    removes at least 15 % of the nominal fresh-pose error; with 36 poses it finds nothing
    to learn), LM + RBF runs on the same rows, and a session with a marker the correction
    never saw is refused in one line."""
    spec = ComplianceSpec(("joint_2", "joint_3"))
    data, truth = simulate_positions(chain, params, 100, seed=3, compliance=spec, true_compliance=TRUE_C)
    setup = cp.prepare("irb120", data)
    rbf = cp.solve(setup, "rbf")
    problem, x0 = rbf.problem, np.zeros(rbf.problem.n_params)
    nominal = fresh_scorer(setup, truth, 0)(lambda q, points: problem.model.predict(x0, q, points))
    assert _fresh_mm(setup, truth, rbf.estimate, problem) < 0.85 * nominal
    q = data.q[:1].repeat(3, axis=0)
    shifts = rbf.estimate.correction(q, np.arange(3))
    assert shifts.shape == (3, 3) and np.ptp(shifts, axis=0).max() > 1e-5  # one shift per marker
    both = cp.solve(setup, "lm+rbf")
    assert both.metrics["test"]["after"].rmse_mm < 0.2 * rbf.metrics["test"]["before"].rmse_mm
    session = data.subset(np.arange(6))
    session.point_ids[:] = 7
    with pytest.raises(CalibPinError, match="point_id 7 is not a marker of this calibration"):
        rbf.sets[0].model.session_errors(rbf.x, session, rbf.estimate.correction)


def test_centres_bounded_to_whole_poses(session, monkeypatch):
    """Above MAX_CENTRES rows the network's centres are a seeded subset of whole poses of at
    most that many rows (the message says so); the correction still removes at least 30 %
    of the nominal fresh-pose error, and at or below the bound every row is a centre."""
    from calib_pin.estimators import rbf

    pose = np.repeat(np.arange(50), 3)  # 50 poses of 3 rows (three markers)
    monkeypatch.setattr(rbf, "MAX_CENTRES", 40)
    rows = rbf.centre_rows(pose, 0)
    assert 37 <= len(rows) <= 40 and np.all(np.bincount(pose[rows], minlength=50) % 3 == 0)
    assert np.array_equal(rows, rbf.centre_rows(pose, 0)) and not np.array_equal(rows, rbf.centre_rows(pose, 1))
    monkeypatch.setattr(rbf, "MAX_CENTRES", 150)
    assert np.array_equal(rbf.centre_rows(pose, 0), np.arange(150))
    monkeypatch.setattr(rbf, "MAX_CENTRES", 60)
    data, truth = session
    setup = cp.prepare("irb120", data)
    train, _ = setup.split(0.2, 0)
    problem = setup.problem_on(train)
    x0 = np.zeros(problem.n_params)
    nominal = fresh_scorer(setup, truth, 0)(lambda q, points: problem.model.predict(x0, q, points))
    estimate = RBF()(problem.subset(train), x0, seed=0)
    assert "(60 of 96 rows as centres)" in estimate.message
    assert _fresh_mm(setup, truth, estimate, problem) < 0.7 * nominal

"""Estimators reach the noise floor on seeded data with known truth.

The session: sigma = 0.05 mm, 120 poses split 96 train / 24 test, nominal error 2 mm.
Every parameter method must cut the test RMSE at least 5x and predict 1000 fresh poses
within 0.06 mm RMSE of the noise-free truth (the attainable floor is about
sigma * sqrt(20 / 96) = 0.023 mm); RBF, which learns no parameters, must beat the
nominal model by 20 %.
"""

import numpy as np
import pytest

import calib_pin as cp
from calib_pin import prepare
from calib_pin.estimators import PAPER_LABELS, PAPER_METHODS, get_estimator
from calib_pin.estimators.ekf import EKF
from calib_pin.estimators.qibas import parabola_vertex
from calib_pin.estimators.subspace import Subspace
from calib_pin.report.build import build_report
from calib_pin.robot.poses import random_poses

#: The paper's nine methods; rbf is the one that estimates no kinematic parameters
#: (lm+rbf, the one combination, is tested in test_rbf.py).
METHODS = list(PAPER_METHODS)
PARAMETER_METHODS = [m for m in METHODS if m != "rbf"]


@pytest.fixture(scope="module")
def results(session):
    data, _ = session
    return {m: cp.calibrate("irb120", data, method=m, seed=0) for m in METHODS}


def test_registry_in_paper_order():
    """The registry holds the nine methods of Table I in the paper's order M1..M9."""
    assert METHODS == ["ekf", "bas", "ukf", "pso", "rbf", "lm", "de", "qibas", "ekf-qibas"]
    assert list(cp.ESTIMATORS) == [*METHODS, "lm+rbf"] and PAPER_LABELS["lm+rbf"] == "M6+M5"
    assert PAPER_LABELS["ekf"] == "M1" and PAPER_LABELS["ekf-qibas"] == "M9"


@pytest.mark.parametrize("method", PARAMETER_METHODS)
def test_parameter_methods_reach_noise_floor(results, fresh_rmse_mm, method):
    """Each parameter method cuts the test RMSE at least 5x below the nominal model's and
    predicts 1000 fresh poses within 0.06 mm of the noise-free truth."""
    m = results[method].metrics["test"]
    assert m["after"].rmse_mm <= m["before"].rmse_mm / 5
    assert fresh_rmse_mm(results[method]) <= 0.06


def test_rbf_learns_the_error_but_no_parameters(results, fresh_rmse_mm, tmp_path):
    """RBF lowers the test RMSE below 0.8x the nominal model's (a black box on 96 poses in
    6-D does no better), estimates no kinematic parameters and exports no URDF."""
    result = results["rbf"]
    m = result.metrics["test"]
    assert m["after"].rmse_mm <= 0.8 * m["before"].rmse_mm
    assert fresh_rmse_mm(result) <= 0.8 * m["before"].rmse_mm
    assert not result.kinematic and not np.any(result.x)
    assert build_report(result)["kinematic_parameters"] is False and build_report(result)["deviations"] == {}
    with pytest.raises(cp.CalibPinError, match="no corrected URDF"):
        result.to_urdf(tmp_path / "x.urdf")


@pytest.mark.parametrize("method", METHODS)
def test_history_and_counts(results, method):
    """Every method counts its work and records a history, one entry per iteration plus
    the start, with the evaluations used so far."""
    est = results[method].estimate
    assert est.iterations >= 1 and est.nfev > 0 and est.time_s > 0
    assert len(est.history) == est.iterations + 1 == len(est.evaluations)
    assert est.evaluations[0] <= est.evaluations[-1] <= est.nfev + 1e-9
    assert np.all(np.diff(est.evaluations) >= 0)
    factor = 5 if method in PARAMETER_METHODS else 1
    assert est.history[0] > 1e-3 and est.history[-1] < est.history[0] / factor


@pytest.mark.parametrize("method", ["lm", "bas", "qibas", "pso", "de"])
def test_search_history_never_increases(results, method):
    """Greedy searches and elitist populations keep the best cost: the history never rises."""
    h = np.array(results[method].estimate.history)
    assert np.all(np.diff(h) <= 1e-15)


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_kalman_filters_update_once_per_pose(results, method):
    """The Kalman filters make one update per training pose and return their covariance."""
    est = results[method].estimate
    assert est.iterations == 96
    assert est.covariance.shape == (24, 24)
    np.testing.assert_allclose(est.covariance, est.covariance.T)


def test_qibas_converges_in_fewer_iterations_than_bas(results):
    """The quadratic interpolation is what QIBAS adds: it needs fewer iterations and
    evaluations than BAS to come within 5 % of its final training RMSE."""
    bas = results["bas"].estimate.converged()
    qibas = results["qibas"].estimate.converged()
    assert qibas[0] < bas[0] and qibas[1] < bas[1]


def test_converged_counts_until_within_tolerance():
    """converged() gives the first iteration within 5 % of the final RMSE, and its evaluations."""
    est = cp.EstimateResult(x=np.zeros(1), success=True, status=0, message="", history=(4.0, 2.0, 1.04, 1.01, 1.0),
                            evaluations=(0, 3, 6, 9, 12), iterations=4, nfev=12)
    assert est.converged(0.05) == (2, 6.0)
    assert est.converged(0.0) == (4, 12.0)


def test_ekf_qibas_stages(results):
    """EKF-QIBAS reports both stages and starts QIBAS from the EKF estimate."""
    est = results["ekf-qibas"].estimate
    assert est.stages["ekf"] == 96 and est.stages["qibas"] >= 1
    assert est.covariance is not None and est.covariance.shape == (24, 24)


def test_seeded_reproducible(session):
    """The same seed gives the same QIBAS estimate."""
    data, _ = session
    a = cp.calibrate("irb120", data, method="qibas", seed=5)
    b = cp.calibrate("irb120", data, method="qibas", seed=5)
    assert np.array_equal(a.x, b.x)


def test_one_cable_sees_20_of_24_directions(chain, params):
    """On the shipped IRB120 set, 20 DH directions are identifiable: theta_6 (hook on the
    joint-6 axis), d_2 - d_3 (parallel joints 2 and 3) and two wrist combinations are not."""
    data = cp.read_measurements(chain.description.default_data, chain)
    sensor = cp.Drawstring(data.anchor, data.tool, data.length_offset)
    problem = cp.SetProblem(cp.CableModel(chain, params, sensor), data.q, data.lengths)
    assert Subspace.of_problem(problem, np.zeros(params.n_params)).dim == 20
    jac = problem.jacobian(np.zeros(params.n_params))
    names = list(params.names)
    assert np.abs(jac[:, names.index("theta_6")]).max() < 1e-12
    np.testing.assert_allclose(jac[:, names.index("d_2")], jac[:, names.index("d_3")], atol=1e-12)


def test_unknown_method_lists_valid_names():
    with pytest.raises(cp.EstimatorError, match="unknown method 'gauss'.*ekf-qibas"):
        get_estimator("gauss")


def test_parabola_vertex():
    """Eq. 16 gives the minimum of a convex parabola and flags concave or degenerate ones."""
    f = lambda x: 3.0 * (x - 0.4) ** 2 + 1.0  # noqa: E731
    x1, x2, x3 = np.array([-1.0, 0.0]), np.array([1.0, 0.0]), np.array([0.2, 0.0])
    v, ok = parabola_vertex(x1, x2, x3, f(-1.0), f(1.0), f(0.2))
    assert v[0] == pytest.approx(0.4) and ok.tolist() == [True, False]
    _, ok = parabola_vertex(x1[:1], x2[:1], x3[:1], -f(-1.0), -f(1.0), -f(0.2))
    assert not ok[0]


def _outlier_session(chain, params, fresh):
    """Seed 7, sigma 0.05 mm Student-t noise with 5 % gross outliers; and a function
    giving a result's RMSE [m] on the fresh poses against the truth."""
    data, truth = cp.simulate(chain, params, 120, seed=7, noise_mm=0.05, noise_kind="student-outliers")
    q, _ = fresh
    true_fresh = cp.CableModel(chain, params, truth.sensor).predict(truth.x, q)

    def fresh_error(result):
        return float(np.sqrt(np.mean((result.predict(q) - true_fresh) ** 2)))

    return data, truth, fresh_error


def test_robust_loss_halves_the_error_with_outliers(chain, params, fresh):
    """Must hold (issue 5): sigma 0.05 mm Student-t noise with 5 % gross outliers: the
    robust LM's fresh-pose error is at most half of plain LM's, and it names the
    outlier rows."""
    data, truth, fresh_error = _outlier_session(chain, params, fresh)
    plain = cp.calibrate("irb120", data, method="lm")
    for loss in ("huber", "soft_l1", "cauchy"):
        robust = cp.calibrate("irb120", data, method="lm", loss=loss)
        assert fresh_error(robust) <= 0.5 * fresh_error(plain), loss
        in_train = set(truth.outliers) & set(robust.train.tolist())
        assert in_train <= set(robust.outlier_rows), loss
        assert build_report(robust)["loss"] == loss


def test_loss_only_where_supported():
    with pytest.raises(cp.EstimatorError, match="method .ekf. has no robust loss; --loss huber works with: bas, pso, lm, de, qibas, ekf-qibas"):
        cp.calibrate("irb120", method="ekf", loss="huber")
    with pytest.raises(cp.EstimatorError, match="unknown loss 'l2'"):
        cp.calibrate("irb120", method="lm", loss="l2")


@pytest.mark.parametrize("method", ["bas", "qibas", "ekf-qibas"])
def test_robust_search_methods_halve_the_error_with_outliers(chain, params, fresh, method):
    """Must hold (issue 5) for the search methods too: with Student-t noise and 5 %
    gross outliers, the method with the Cauchy loss is at most half as far from the
    truth on fresh poses as plain LM, and lists the outliers it found."""
    data, truth, fresh_error = _outlier_session(chain, params, fresh)
    plain = cp.calibrate("irb120", data, method="lm")
    robust = cp.calibrate("irb120", data, method=method, loss="cauchy")
    assert fresh_error(robust) <= 0.5 * fresh_error(plain)
    assert set(truth.outliers) & set(robust.train.tolist()) <= set(robust.outlier_rows)
    est = robust.estimate
    assert len(est.history) == est.iterations + 1 == len(est.evaluations)
    assert "cauchy" in est.stages or "qibas cauchy" in est.stages


@pytest.mark.parametrize("seed", [7, 11, 15])
def test_default_pipeline_reaches_the_attainable_floor(chain, params, fresh, seed):
    """Must hold (issue 5): with Gaussian noise the default pipeline's fresh-pose error
    is within 5 % of an LM fit started from the true deviations on the same rows."""
    from calib_pin.estimators.lm import LevenbergMarquardt

    data, truth = cp.simulate(chain, params, 120, seed=seed)
    q, _ = fresh
    true_fresh = cp.CableModel(chain, params, truth.sensor).predict(truth.x, q)
    result = cp.calibrate("irb120", data)
    floor = LevenbergMarquardt()(result.problem.subset(result.train), truth.x).x
    model = result.problem.model

    def fresh_error(x):
        return float(np.sqrt(np.mean((model.predict(x, q) - true_fresh) ** 2)))

    assert fresh_error(result.x) <= 1.05 * fresh_error(floor)


@pytest.mark.parametrize(("robot", "end_frame"), [("ur5", None), ("panda", "panda_hand_tcp")])
def test_any_urdf_arm_calibrates_with_the_placement_model(robot, end_frame):
    """example-robot-data arms have no DH table: the placement model (6D offset of every
    joint, reduced to the identifiable directions) calibrates them to the noise floor."""
    chain = cp.load_chain(robot, end_frame)
    placement = cp.parameter_model(chain, "placement")
    data, truth = cp.simulate(chain, placement, 120, seed=2)
    result = cp.calibrate(robot, data, method="lm")
    assert result.model_name == "placement" and len(result.x) == 6 * (chain.n_joints + 1)
    q = random_poses(chain, 500, np.random.default_rng(4))
    true_fresh = cp.CableModel(chain, placement, truth.sensor).predict(truth.x, q)
    fresh = np.sqrt(np.mean((result.predict(q) - true_fresh) ** 2)) * 1e3
    assert fresh < 0.06 and result.metrics["test"]["before"].rmse_mm > 1.0


def test_ekf_leaves_out_only_an_identity_prediction(session):
    """Without process noise the EKF skips filterpy's prediction (F = I, Q = 0): the same
    estimate, to the bit, as calling it with a Q that underflows to zero; with process
    noise the prediction runs and widens the covariance."""
    data, _ = session
    problem = prepare("irb120", data).problem_on(np.arange(40))
    x0 = np.zeros(problem.n_params)
    skipped = EKF()(problem, x0)
    predicted = EKF(process=1e-300)(problem, x0)  # (1e-300 * scale)^2 underflows: Q = 0
    assert np.array_equal(skipped.x, predicted.x)
    assert np.array_equal(skipped.covariance, predicted.covariance)
    drifting = EKF(process=0.1)(problem, x0)
    assert not np.array_equal(drifting.x, skipped.x)
    assert np.trace(drifting.covariance) > np.trace(skipped.covariance)


@pytest.mark.parametrize("method", ["ekf", "ukf", "ekf-qibas"])
def test_kalman_history_is_thinned_to_evenly_spread_updates(session, monkeypatch, method):
    """Over more row updates than HISTORY_POINTS the Kalman filters record that many entries,
    every stride-th update and the last (the same RMSE as a full record at those updates),
    the estimate is the same to the bit, and converged() names the update each entry follows."""
    from calib_pin.estimators import base, run_estimator

    data, _ = session
    problem = prepare("irb120", data).problem_on(np.arange(96)).subset(np.arange(96))
    x0 = np.zeros(problem.n_params)
    full = run_estimator(method, problem, x0)
    monkeypatch.setattr(base, "HISTORY_POINTS", 10)
    thin = run_estimator(method, problem, x0)
    assert np.array_equal(full.x, thin.x) and full.iterations == thin.iterations
    updates = [0, *range(10, 96, 10), 96]  # stride ceil(96 / 10) = 10, and the last update
    assert list(thin.extras["history_iterations"]) == updates
    n_filter = len(updates)
    np.testing.assert_array_equal(thin.history[:n_filter], np.asarray(full.history)[updates])
    np.testing.assert_array_equal(thin.evaluations[:n_filter], np.asarray(full.evaluations)[updates])
    assert thin.history[n_filter:] == full.history[97:]  # the QIBAS stage: one entry per iteration
    assert [thin.iteration_of(k) for k in range(len(thin.history))] == [*updates, *range(97, thin.iterations + 1)]
    k_full, _ = full.converged()
    k_thin, _ = thin.converged()
    assert k_thin >= k_full and (k_thin - k_full < 10 or k_full > 96)


@pytest.mark.parametrize("method", ["ekf", "ukf"])
@pytest.mark.parametrize("kind", ["cable", "position", "pose"])
def test_held_back_history_is_the_one_by_one_history(session, monkeypatch, method, kind):
    """The Kalman filters' row-update history, held back and evaluated in batches
    (Tracker.flush), is the history of one residual call per recorded update, to the bit:
    the same RMSEs, evaluation counts and order, and the same estimate (cable, position
    and 6-D pose rows; the pose class has its own residual and is evaluated point by point)."""
    from calib_pin.estimators import base, run_estimator

    if kind == "cable":
        data, _ = session
        setup = prepare("irb120", data)
    else:
        chain = cp.load_chain("irb120")
        from calib_pin.simulation import simulate_poses

        simulate = cp.simulate_positions if kind == "position" else simulate_poses
        data = simulate(chain, cp.parameter_model(chain), 40, 3)[0]
        setup = prepare("irb120", data)
    problem = setup.problem_on(np.arange(len(data)))
    x0 = np.zeros(problem.n_params)
    batched = run_estimator(method, problem, x0)

    def one_by_one(self, x, update):  # the Tracker before it held updates back
        if self.callback is None or (update % self.stride and update != self.updates):
            return
        if self.stride > 1:
            self.recorded.append(update)
        self.record_at(x)

    monkeypatch.setattr(base.Tracker, "record_update", one_by_one)
    single = run_estimator(method, problem, x0)
    assert np.array_equal(batched.x, single.x)
    assert batched.history == single.history and batched.evaluations == single.evaluations
    assert len(batched.history) > problem.n_rows // 2

"""Estimators reach the noise floor on seeded data with known truth.

The session: sigma = 0.05 mm, 120 poses split 96 train / 24 test, nominal error 2 mm.
The fitted model must predict 1000 fresh poses within 0.06 mm RMSE of the noise-free
truth (the attainable floor is about sigma * sqrt(20 / 96) = 0.023 mm).
"""

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.estimators import SearchSpace
from calib_pin.estimators.qibas import parabola_vertex

METHODS = ["ekf-qibas", "lm", "ekf", "qibas"]


@pytest.fixture(scope="module")
def results(session):
    data, _ = session
    return {m: cp.calibrate("irb120", data, method=m, seed=0) for m in METHODS}


@pytest.mark.parametrize("method", METHODS)
def test_fresh_pose_error_at_noise_floor(results, fresh_rmse_mm, method):
    """The calibrated model predicts 1000 fresh poses within 0.06 mm of the truth."""
    assert fresh_rmse_mm(results[method]) <= 0.06


@pytest.mark.parametrize("method", METHODS)
def test_history_and_counts(results, method):
    """Every method counts its work and records a training-RMSE history from 2 mm to the floor."""
    est = results[method].estimate
    assert est.iterations >= 1 and est.nfev >= 1 and est.time_s > 0
    assert est.history[0] > 1e-3 and est.history[-1] < 0.06e-3
    assert len(est.history) >= 2


@pytest.mark.parametrize("method", ["lm", "qibas"])
def test_search_history_never_increases(results, method):
    """Greedy QIBAS and the LM record keep the best cost: the history never goes up."""
    h = np.array(results[method].estimate.history)
    assert np.all(np.diff(h) <= 1e-15)


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
    problem = cp.CalibrationProblem(cp.CableModel(chain, params, sensor), data.q, data.lengths)
    assert SearchSpace.whitened(problem, np.zeros(params.n_params)).dim == 20
    jac = problem.jacobian(np.zeros(params.n_params))
    names = list(params.names)
    assert np.abs(jac[:, names.index("theta_6")]).max() < 1e-12
    np.testing.assert_allclose(jac[:, names.index("d_2")], jac[:, names.index("d_3")], atol=1e-12)


def test_unknown_method_lists_valid_names():
    with pytest.raises(cp.EstimatorError, match="unknown method 'gauss'.*ekf-qibas"):
        cp.get_estimator("gauss")


def test_parabola_vertex():
    """Eq. 16 gives the minimum of a convex parabola and flags concave or degenerate ones."""
    f = lambda x: 3.0 * (x - 0.4) ** 2 + 1.0  # noqa: E731
    x1, x2, x3 = np.array([-1.0, 0.0]), np.array([1.0, 0.0]), np.array([0.2, 0.0])
    v, ok = parabola_vertex(x1, x2, x3, f(-1.0), f(1.0), f(0.2))
    assert v[0] == pytest.approx(0.4) and ok.tolist() == [True, False]
    _, ok = parabola_vertex(x1[:1], x2[:1], x3[:1], -f(-1.0), -f(1.0), -f(0.2))
    assert not ok[0]

"""The drawstring error model and its analytic identification Jacobian."""

import numpy as np
import pinocchio as pin

import calib_pin as cp


def test_reading_is_distance_plus_offset(chain, params):
    """reading = ||p - P0|| + offset with p the hook point through Pinocchio's FK (eq. 7)."""
    sensor = cp.Drawstring(np.array([0.6, 0.2, -0.1]), np.array([0.01, 0.02, 0.05]), 0.003)
    cable = cp.CableModel(chain, params, sensor)
    q = cp.random_poses(chain, 4, np.random.default_rng(0))
    data = chain.model.createData()
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(chain.model, data, qk)
        p = data.oMf[chain.frame_id].act(sensor.hook)
        expected = np.linalg.norm(p - sensor.anchor) + 0.003
        assert abs(cable.predict(np.zeros(params.n_params), q[k : k + 1])[0] - expected) < 1e-12


def test_identification_jacobian_matches_finite_differences(chain, params, session):
    """d reading / d deviation from the regressor equals central differences."""
    data, truth = session
    sensor = cp.Drawstring(truth.sensor.anchor, np.array([0.02, -0.01, 0.05]))
    problem = cp.CalibrationProblem(cp.CableModel(chain, params, sensor), data.q[:30], data.lengths[:30])
    x = truth.x
    jac = problem.jacobian(x)
    fd = np.empty_like(jac)
    for k in range(params.n_params):
        h = 1e-3 * params.scale[k]
        xp, xm = x.copy(), x.copy()
        xp[k] += h
        xm[k] -= h
        fd[:, k] = (problem.residual(xp) - problem.residual(xm)) / (2 * h)
    np.testing.assert_allclose(jac, fd, atol=1e-8)


def test_residual_and_cost(chain, params, session):
    """Residual = predicted - measured; cost is its mean square (eq. 6)."""
    data, truth = session
    problem = cp.CalibrationProblem(cp.CableModel(chain, params, truth.sensor), data.q, data.lengths)
    r = problem.residual(truth.x)
    assert np.sqrt(np.mean(r**2)) < 0.07e-3  # the true model leaves only the 0.05 mm noise
    assert np.isclose(problem.cost(truth.x), np.mean(r**2))
    assert problem.subset(np.arange(10)).n_poses == 10

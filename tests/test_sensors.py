"""The drawstring error model and its analytic identification Jacobian."""

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.report.build import build_report
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import setup_record


def test_reading_is_distance_plus_offset(chain, params):
    """reading = ||p - P0|| + offset with p the hook point through Pinocchio's FK (eq. 7)."""
    sensor = cp.Drawstring(np.array([0.6, 0.2, -0.1]), np.array([0.01, 0.02, 0.05]), 0.003)
    cable = cp.CableModel(chain, params, sensor)
    q = random_poses(chain, 4, np.random.default_rng(0))
    data = chain.model.createData()
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(chain.model, data, qk)
        p = data.oMf[chain.frame_id].act(sensor.tool)
        expected = np.linalg.norm(p - sensor.anchor) + 0.003
        assert abs(cable.predict(np.zeros(params.n_params), q[k : k + 1])[0] - expected) < 1e-12


def test_identification_jacobian_matches_finite_differences(chain, params, session):
    """d reading / d deviation from the regressor equals central differences."""
    data, truth = session
    sensor = cp.Drawstring(truth.sensor.anchor, np.array([0.02, -0.01, 0.05]))
    problem = cp.SetProblem(cp.CableModel(chain, params, sensor), data.q[:30], data.lengths[:30])
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
    problem = cp.SetProblem(cp.CableModel(chain, params, truth.sensor), data.q, data.lengths)
    r = problem.residual(truth.x)
    assert np.sqrt(np.mean(r**2)) < 0.07e-3  # the true model leaves only the 0.05 mm noise
    assert np.isclose(problem.cost(truth.x), np.mean(r**2))
    assert problem.subset(np.arange(10)).n_poses == 10


def test_sensor_unknowns_jacobian_matches_finite_differences(chain, session):
    """With anchor and offset estimated, every column (robot, anchor_x/y/z, offset) of
    the Jacobian equals central differences, for DH and Hayati models."""
    data, truth = session
    for name in ("dh", "hayati"):
        model = cp.CableModel(chain, cp.parameter_model(chain, name), truth.sensor, estimate=("anchor", "offset"))
        assert model.names[-4:] == ("anchor_x", "anchor_y", "anchor_z", "offset")
        problem = cp.SetProblem(model, data.q[:20], data.lengths[:20])
        x = np.random.default_rng(3).normal(size=model.n_params) * model.scale
        fd = np.stack([(problem.residual(x + 1e-7 * e) - problem.residual(x - 1e-7 * e)) / 2e-7
                       for e in np.eye(model.n_params)], axis=1)
        np.testing.assert_allclose(problem.jacobian(x), fd, atol=1e-7)


def test_estimating_anchor_and_offset_recovers_a_wrong_sensor_geometry(session, fresh, chain, params):
    """The technician's anchor is 4 mm off and the zero offset 1 mm: with them held
    fixed the calibration is 1 mm off on fresh poses; estimated with the robot
    (--estimate anchor,offset) it is back at the noise floor."""
    data, truth = session
    q, true_readings = fresh
    wrong = truth.sensor.anchor * 1e3 + np.array([3.0, -2.0, 2.0])

    def fresh_mm(estimate):
        result = cp.calibrate("irb120", data, method="lm", setup=setup_record(anchor_mm=wrong, length_offset_mm=1.0, estimate=estimate))
        return float(np.sqrt(np.mean((result.predict(q) - true_readings) ** 2)) * 1e3), result

    fixed, _ = fresh_mm(())
    estimated, result = fresh_mm(("anchor", "offset"))
    assert fixed > 0.5 and estimated < 0.06
    assert set(result.sensor_corrections) == {"anchor_x_mm", "anchor_y_mm", "anchor_z_mm", "offset_mm"}
    assert abs(result.sensor_corrections["offset_mm"] + 1.0) < 0.1
    assert build_report(result)["length_offset_mm"] == pytest.approx(1.0 + result.sensor_corrections["offset_mm"])


def test_anchor_analysis_names_its_overlap_with_the_base(session):
    """The anchor's z moves like d_1 and its xy like theta_1: --analyze says so."""
    data, _ = session
    report = cp.analyze(cp.prepare("irb120", data, setup=setup_record(estimate=("anchor", "offset"))).problem)
    assert "d_1 +1 mm with anchor_z +1 mm" in report.combinations
    assert any(c.startswith("theta_1") and "anchor_x" in c for c in report.combinations)
    assert "offset" in report.base

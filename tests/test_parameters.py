"""Parameter models: analytic placement Jacobians match finite differences."""

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.robots import DHTable


def _fd_delta_jacobian(model, x, h=1e-7):
    base = model.deltas(x)
    cols = []
    for k in range(len(x)):
        xp = x.copy()
        xp[k] += h
        cols.append(
            np.concatenate([pin.log6(a.actInv(b)).vector for a, b in zip(base, model.deltas(xp))]) / h
        )
    return np.array(cols).T


def test_dh_names_follow_eq5(params):
    """Four deviations per joint in the order (a, d, alpha, theta), SI units."""
    assert params.names[:4] == ("a_1", "d_1", "alpha_1", "theta_1")
    assert params.n_params == 24 and params.units[:4] == ("m", "m", "rad", "rad")


def test_dh_delta_jacobian_matches_finite_differences(params):
    """The analytic DH placement Jacobian equals finite differences (1e-6)."""
    x = np.random.default_rng(0).normal(size=params.n_params) * params.scale
    np.testing.assert_allclose(params.delta_jacobian(x), _fd_delta_jacobian(params, x), atol=1e-6)


def test_placement_model_jacobian_matches_finite_differences(chain):
    """The 6D placement model's Jacobian (exp6 right Jacobian) equals finite differences."""
    model = cp.PlacementModel(chain)
    x = np.random.default_rng(1).normal(size=len(model.names)) * model.scale
    np.testing.assert_allclose(model.delta_jacobian(x), _fd_delta_jacobian(model, x), atol=1e-6)


def test_wrong_dh_table_is_refused(chain):
    """A DH table that does not describe the URDF names the first joint that is off."""
    good = chain.description.dh
    bad = DHTable(good.a.copy(), good.d.copy(), good.alpha, good.theta_offset)
    bad.a[1] += 0.01
    with pytest.raises(cp.RobotError, match="does not describe its URDF: joint 'joint_3'"):
        cp.DHModel(chain, bad)


def test_robot_without_dh_table_gets_clear_message():
    """ur5 has no DH table in calib-pin: calibrating says so."""
    with pytest.raises(cp.RobotError, match="robot 'ur5' has no DH table"):
        cp.parameter_model(cp.load_chain("ur5"))

"""Parameter models: analytic placement Jacobians match finite differences."""

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.robot.description import DHTable


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
    """ur5 has no DH table in calib-pin: a DH model says so and points to placement."""
    with pytest.raises(cp.RobotError, match="robot 'ur5' has no DH table for the 'dh' model: use --model placement"):
        cp.parameter_model(cp.load_chain("ur5"), "dh")
    assert isinstance(cp.parameter_model(cp.load_chain("ur5"), "placement"), cp.PlacementModel)
    with pytest.raises(cp.RobotError, match="unknown parameter model 'mdh' \\(valid: dh, hayati, placement\\)"):
        cp.parameter_model(cp.load_chain("ur5"), "mdh")


def test_hayati_replaces_d_of_the_parallel_pair(chain):
    """IRB120 joints 2 and 3 are parallel (alpha_2 = 0): Hayati's beta_2 [rad] takes the
    place of d_2; every other name and the nominal placements are the DH model's."""
    dh, hayati = cp.parameter_model(chain, "dh"), cp.parameter_model(chain, "hayati")
    assert hayati.names[4:8] == ("a_2", "beta_2", "alpha_2", "theta_2")
    assert hayati.units[5] == "rad" and hayati.scale[5] == dh.scale[6]
    assert [n for n in hayati.names if n not in dh.names] == ["beta_2"]
    zero = np.zeros(hayati.n_params)
    for a, b in zip(dh.deltas(zero), hayati.deltas(zero)):
        assert np.allclose(a.homogeneous, b.homogeneous)


def test_hayati_delta_jacobian_matches_finite_differences(chain):
    """The Hayati placement Jacobian (with Ry(beta) at the end of the link) equals
    finite differences away from zero."""
    model = cp.parameter_model(chain, "hayati")
    x = np.random.default_rng(2).normal(size=model.n_params) * model.scale * 3
    np.testing.assert_allclose(model.delta_jacobian(x), _fd_delta_jacobian(model, x), atol=1e-6)


def test_hayati_beta_is_well_conditioned_where_d_is_not(chain, session):
    """With a known cable anchor, d_2 - d_3 is blind under DH; Hayati's beta_2 is seen,
    so the Hayati model has one more identifiable direction."""
    data, truth = session
    ranks = {}
    for name in ("dh", "hayati"):
        model = cp.CableModel(chain, cp.parameter_model(chain, name), truth.sensor)
        ranks[name] = cp.analyze(cp.SetProblem(model, data.q, data.lengths)).rank
    assert ranks["hayati"] == ranks["dh"] + 1

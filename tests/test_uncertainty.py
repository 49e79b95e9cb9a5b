"""Intervals only for what the data determines, and they cover the truth."""

import numpy as np

import calib_pin as cp
from calib_pin.report.build import build_report


def test_intervals_cover_the_truth(session):
    """The deviations the data determines alone have intervals that hold the truth; the
    combinations (d_2 + d_3, a_5 with theta_5, d_5 with alpha_5 on the IRB120 cable set)
    have theirs, and theta_6, which no reading sees, has none and stays at zero."""
    data, truth = session
    result = cp.calibrate("irb120", data, method="lm")
    u = result.uncertainty
    assert 0.035e-3 < u.noise < 0.065e-3
    alone = [i for i, s in enumerate(u.status) if s == "identified" and i < len(truth.x)]
    z = np.abs(result.x[alone] - truth.x[alone]) / u.std[alone]
    assert len(alone) >= 15 and np.mean(z < 1.96) >= 0.8 and z.max() < 4
    i = u.names.index("theta_6")
    assert u.status[i] == "not determined" and np.isnan(u.std[i]) and abs(result.x[i]) < 1e-5
    assert {u.names[i] for i, s in enumerate(u.status) if s == "combination"} >= {"d_2", "d_3"}
    for c in u.combinations:
        true = sum(k * truth.x[j] for j, k in c.terms)
        assert abs(true - c.value) < 4 * c.std, c.text
    assert any(c.text == "d_2 + d_3" for c in u.combinations)
    report = build_report(result)["uncertainty"]
    entry = report["parameters"]["a_1_mm"]
    assert entry["status"] == "identified" and entry["ci95"][0] < entry["value"] < entry["ci95"][1]
    assert report["parameters"]["d_2_mm"]["ci95"] is None and report["parameters"]["theta_6_deg"]["std"] is None


def test_more_poses_shrink_the_uncertainty(chain, params):
    """The noise part of the predicted error at the hook shrinks with more training poses."""
    data, _ = cp.simulate(chain, params, 240, seed=3)
    few = cp.prepare("irb120", data)
    small = cp.solve(few, "lm", holdout=0.75).accuracy.points[0].noise
    large = cp.solve(few, "lm", holdout=0.0).accuracy.points[0].noise
    assert large < 0.75 * small


def test_runaway_deviation_is_refused(session, tmp_path):
    """An estimate beyond the sanity bound writes no URDF and says which parameter."""
    import dataclasses

    import pytest

    data, _ = session
    result = cp.calibrate("irb120", data, method="lm")
    x = result.x.copy()
    x[list(result.params.names).index("d_4")] = 0.05
    result = dataclasses.replace(result, x=x)
    with pytest.raises(cp.CalibPinError, match=r"d_4 = \+50 mm is beyond the sanity bound 20 mm"):
        result.to_urdf(tmp_path / "x.urdf")
    assert not (tmp_path / "x.urdf").exists()


def test_a_sensor_direction_seen_weakly_keeps_its_variance():
    """A sensor unknown's variance is the inverse of the information left to it: a combination of sensor unknowns
    the data sees at 1e-4 of the strongest direction (a lens's k1, k2, k3 together) keeps its large variance,
    where the estimators' cut (1e-3) would drop it and report a std many times too small."""
    from calib_pin.analysis.determined import Determined
    from calib_pin.analysis.uncertainty import sensor_variance

    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    jac = q @ np.diag([1.0, 0.5, 0.2, 1e-4]) @ np.linalg.qr(rng.normal(size=(4, 4)))[0]
    gram = jac.T @ jac
    split = Determined(robot=np.array([0, 1]), sigma=np.ones(2), singular_values=np.ones(2), vt=np.eye(2), rank=2,
                       noise=0.1, n_params=4, free=np.arange(4), gram=gram)
    np.testing.assert_allclose(sensor_variance(split, np.ones(4)), 0.01 * np.diag(np.linalg.inv(gram))[2:], rtol=1e-6)
    assert np.sqrt(sensor_variance(split, np.ones(4))).max() > 100

"""The simulator draws deviations of the paper's size and records the truth."""

import json

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.sensors import CableModel
from calib_pin.simulation import NOISE_KINDS


def test_nominal_error_and_noise(chain, params, session):
    """Nominal model is off by 2 mm RMSE; the true model leaves the 0.05 mm noise."""
    data, truth = session
    cable = CableModel(chain, params, truth.sensor)
    nominal = cable.predict(np.zeros(params.n_params), data.q) - data.lengths
    true = cable.predict(truth.x, data.q) - data.lengths
    assert 1.9 < np.sqrt(np.mean(nominal**2)) * 1e3 < 2.1
    assert 0.035 < np.sqrt(np.mean(true**2)) * 1e3 < 0.065


def test_poses_within_limits_and_seeded(chain, params, session):
    """Poses respect the joint limits; the same seed gives the same session."""
    data, truth = session
    assert np.all(data.q >= chain.lower) and np.all(data.q <= chain.upper)
    again, truth2 = cp.simulate(chain, params, 120, seed=7, noise_mm=0.05)
    assert np.array_equal(again.lengths, data.lengths) and np.array_equal(truth2.x, truth.x)


def test_truth_file(tmp_path, session):
    """The truth file holds deviations in mm/deg, the sensor and the noise."""
    _, truth = session
    truth.to_json(tmp_path / "t.json")
    doc = json.loads((tmp_path / "t.json").read_text())
    assert doc["noise_mm"] == 0.05 and len(doc["deviations"]) == 24
    assert doc["deviations"]["a_2_mm"] == truth.x[4] * 1e3


def test_simulate_robot_without_dh_table():
    """Robots with no DH table simulate with joint-placement deviations."""
    chain = cp.load_chain("ur5")
    data, truth = cp.simulate(chain, cp.PlacementModel(chain), 10, seed=0)
    assert data.q.shape == (10, 6) and np.all(data.lengths > 0) and len(truth.x) == 42


def test_pose_search_is_bounded(chain, params, monkeypatch):
    """If no pose puts the hook above the mounting plane, the simulator says so, not hangs."""
    import pytest

    below = lambda self, x, q: np.tile([0.0, 0.0, -1.0], (len(q), 1))  # noqa: E731
    monkeypatch.setattr(CableModel, "tool_positions", below)
    with pytest.raises(cp.CalibPinError, match="above the base's mounting plane"):
        cp.simulate(chain, params, 10, seed=0)


@pytest.mark.parametrize("kind", NOISE_KINDS)
def test_noise_kinds(chain, params, kind):
    """gauss and student have the stated sigma; student has heavy tails; the outlier kinds
    put 1-3 mm gross errors on 5 % of the rows and record which."""
    data, truth = cp.simulate(chain, params, 400, seed=11, noise_mm=0.05, noise_kind=kind)
    noise = (data.lengths - CableModel(chain, params, truth.sensor).predict(truth.x, data.q)) * 1e3
    assert truth.noise_kind == kind and kind in data.notes["source"]
    clean = np.delete(noise, list(truth.outliers))
    kurtosis = np.mean(clean**4) / np.mean(clean**2) ** 2
    if kind.endswith("outliers"):
        assert len(truth.outliers) == 20
        assert np.all(np.abs(noise[list(truth.outliers)]) > 0.8)
    else:
        assert truth.outliers == ()
    if kind == "outliers":
        assert np.all(np.abs(clean) < 0.3)
    else:
        assert 0.035 < np.std(clean) < 0.065
        assert (kurtosis > 4.5) if kind.startswith("student") else (2.5 < kurtosis < 3.5)


def test_unknown_noise_kind(chain, params):
    with pytest.raises(cp.CalibPinError, match="unknown noise kind 'pink'"):
        cp.simulate(chain, params, 10, seed=0, noise_kind="pink")


def test_truth_file_round_trip(tmp_path, params, session):
    """A truth file reads back to the same deviations and sensor."""
    _, truth = session
    truth.to_json(tmp_path / "t.json")
    back = cp.Truth.from_json(tmp_path / "t.json", params)
    np.testing.assert_allclose(back.x, truth.x, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(back.sensor.anchor, truth.sensor.anchor)
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(cp.DataError, match="bad.json: not a calib-pin truth file"):
        cp.Truth.from_json(tmp_path / "bad.json", params)


def test_noise_free_sets_read_back(tmp_path, chain, params):
    """noise_mm=0 (the README's dry run): exact values of the true robot, and the written
    set reads back (no '# noise_mm: 0', which a reader refuses as a sensor sigma)."""
    from calib_pin.measurements import read_measurements, write_measurements
    from calib_pin.sensors import PositionModel
    from calib_pin.simulation import simulate_positions

    data, truth = cp.simulate(chain, params, 20, seed=1, noise_mm=0)
    np.testing.assert_allclose(data.values, CableModel(chain, params, truth.sensor).predict(truth.x, data.q), atol=1e-15)
    points, ptruth = simulate_positions(chain, params, 5, seed=1, noise_mm=0)
    exact = PositionModel(chain, params, ptruth.sensor, estimate=()).predict(ptruth.x, points.q, points.point_ids - 1)
    np.testing.assert_allclose(points.values, exact, atol=1e-15)
    for name, kind in (("c.csv", data), ("p.csv", points)):
        write_measurements(tmp_path / name, kind)
        assert len(read_measurements(tmp_path / name, chain)) == len(kind)

"""Sets of different sensors in one fit: a drawstring set (one length a row) and a tracker
set (three coordinates a row) of one true robot, stacked and weighted by each set's noise."""

from __future__ import annotations

import json

import numpy as np
import pytest

import calib_pin as cp
from calib_pin import FitSet
from calib_pin.analysis.identifiability import distinct_values, support_error
from calib_pin.calibration.problem import Problem
from calib_pin.cli.calibrate import calibrate_main
from calib_pin.estimators.problem import row_offsets
from calib_pin.robot.poses import random_poses
from calib_pin.simulation import simulate_set

#: The two sets' noise (1 sigma) [mm]: a drawstring's and a tracker's (per axis).
CABLE_MM, TRACKER_MM = 0.05, 0.02


@pytest.fixture(scope="module")
def mixed(chain, params):
    """One true robot: a long drawstring session (60 poses, 0.05 mm) and a few tracker poses
    (10 poses of 3 markers, 0.02 mm per axis), neither noise stated in its set (estimated
    from the residual). The tracker's 8 training poses alone barely pin its 15 device and
    marker unknowns and the robot; the drawstring's robot is what the tracker's rows refine."""
    sets, truth = cp.simulate_sessions(chain, params, [60, 10], seed=1, kinds=["cable", "position"],
                                       noise_mm=[CABLE_MM, TRACKER_MM])
    for s in sets:
        s.noise = None
    return sets, truth


def _fresh_rmse_mm(chain, params, truth, model, x, k) -> float:
    """RMSE [mm] of ``model`` at ``x`` at 1000 fresh poses (every marker of a tracker)
    against session k's noise-free truth, each row's error as its sensor sizes it."""
    grid, points = model.grid_points(1000)
    q = random_poses(chain, 1000, np.random.default_rng(123))[grid]
    true = truth.session(k)
    error = model.predict(x, q, points) - true.model(chain, params).predict(true.x_model, q, points)
    return float(np.sqrt(np.mean(np.sum(error.reshape(len(q), -1) ** 2, axis=1))) * 1e3)


def test_mixed_stack_rows_of_two_sizes_and_its_jacobian_matches_finite_differences(chain, params, mixed):
    sets, _ = mixed
    prepared = cp.prepare("irb120", [FitSet(sets[0], "c"), FitSet(sets[1], "t")], noise_mm=[CABLE_MM, TRACKER_MM])
    stacked = prepared.problem.subset(np.r_[0:8, 60:66])  # 8 lengths, 6 positions
    assert isinstance(stacked, Problem) and len({int(p.values_per_row) for p in stacked.parts}) == 2
    assert np.array_equal(np.diff(row_offsets(stacked)), [1] * 8 + [3] * 6) and stacked.n_values == 26
    with pytest.raises(cp.CalibPinError, match="rows differ in size"):
        _ = stacked.values_per_row
    x = np.random.default_rng(0).normal(size=stacked.n_params) * stacked.scale * 0.3
    jac = stacked.jacobian(x)
    numeric = np.empty_like(jac)
    for i, h in enumerate(stacked.scale * 1e-5):
        e = np.zeros(stacked.n_params)
        e[i] = h
        numeric[:, i] = (stacked.residual(x + e) - stacked.residual(x - e)) / (2 * h)
    assert np.allclose(jac, numeric, atol=1e-6 * np.abs(numeric).max())
    for row in (3, 10):  # a length row and a position row, as a Kalman update sees them
        r, j = stacked.row_residual_with_jacobian(x, row)
        lo, hi = row_offsets(stacked)[row : row + 2]
        assert np.allclose(r, stacked.residual(x)[lo:hi]) and np.allclose(j, jac[lo:hi])
    errors = stacked.row_errors(stacked.residual(x))  # each row in its own units: the weight divided out
    cable, tracker = stacked.parts
    assert np.allclose(errors[:8], cable.row_errors(cable.residual(stacked.model.part_x(x, 0))))
    assert np.allclose(errors[8:], tracker.row_errors(tracker.residual(stacked.model.part_x(x, 1))))
    assert distinct_values(stacked) == 26 and support_error(stacked) is None
    assert distinct_values(prepared.problem.subset([0, 0, 60, 60])) == 1 + 3  # a repeated row counts once, at its size
    assert "reading error (c)" in stacked.model.error_name and "(t)" in stacked.model.error_name


@pytest.mark.parametrize("method", ["lm", "ekf-qibas"])
def test_cable_and_tracker_fit_together_beat_each_alone_and_recover_each_noise(chain, params, mixed, method):
    sets, truth = mixed
    joint = cp.calibrate("irb120", [FitSet(sets[0], "cable"), FitSet(sets[1], "tracker")], method=method)
    for k, (s, sigma_mm) in enumerate(zip(joint.sets, (CABLE_MM, TRACKER_MM), strict=True)):
        assert s.sigma_origin == "estimate" and abs(s.sigma * 1e3 / sigma_mm - 1) < 0.3, (s.label, s.sigma)
        alone = cp.calibrate("irb120", sets[k], method=method)
        together = _fresh_rmse_mm(chain, params, truth, s.model, s.x, k)
        single = _fresh_rmse_mm(chain, params, truth, alone.sets[0].model, alone.x, k)
        print(f"{method} {s.label}: alone {single:.4f} mm, joint {together:.4f} mm, sigma {s.sigma * 1e3:.4f} mm "
              f"(true {sigma_mm})")
        assert together <= single, (s.label, together, single)
        assert together < 1.5 * sigma_mm * (1 if k == 0 else np.sqrt(3))  # near each sensor's noise floor
    assert joint.data.kind == "cable+position" and len(joint.data) == 60 + 30


def test_cli_cable_and_tracker_files(mixed, tmp_path, capsys):
    sets, _ = mixed
    files = [tmp_path / "cable.csv", tmp_path / "tracker.csv"]
    for f, s in zip(files, sets, strict=True):
        cp.write_measurements(f, s)
    out = tmp_path / "o"
    assert calibrate_main(["irb120", "--data", str(files[0]), "--data", f"{files[1]}:noise_mm=0.02",
                           "--method", "lm", "--no-html", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "set cable: 60 rows" in text and "set tracker: 30 rows" in text and "noise 0.0200 mm (caller)" in text
    report = json.loads((out / "report.json").read_text())
    assert [(s["data_kind"], s["noise_from"]) for s in report["sets"]] == [("cable", "estimate"), ("position", "caller")]
    assert report["sets"][0]["error"] == "reading error" and "position" in report["sets"][1]["error"]
    calibration = json.loads((out / "irb120_calibration.json").read_text())
    assert calibration["sensor"]["kind"] == "cable+position"
    assert set(calibration["sensor"]["set_geometry"]) == {"cable", "tracker"}


@pytest.fixture
def laser():
    """The invented third sensor (tests/fake_sensor.py) registered for one test."""
    import fake_sensor

    fake_sensor.register()
    yield fake_sensor
    fake_sensor.unregister()


def test_an_invented_sensor_simulates_through_its_one_method_and_mixes_with_the_others(chain, params, laser):
    """The laser's simulate_rows is all it took: simulate_set and simulate_sessions write its
    sessions with the others' (rows of 1, 3 and 1 values), and the three calibrate together."""
    data, truth = simulate_set(laser.DistanceModel, chain, params, 20, seed=3, noise_mm=0.0)
    assert data.kind == "distance" and np.allclose(
        truth.model(chain, params).predict(truth.x_model, data.q), data.values, atol=1e-12)
    sets, truth = cp.simulate_sessions(chain, params, [40, 10, 40], seed=2, kinds=["cable", "position", "distance"],
                                       noise_mm=[0.05, 0.02, 0.03])
    assert [s.kind for s in sets] == ["cable", "position", "distance"]
    assert [truth.session(k).kind for k in range(3)] == ["cable", "position", "distance"]
    result = cp.calibrate("irb120", sets, method="lm")
    assert [s.sigma_origin for s in result.sets] == ["estimate", "file", "estimate"]
    assert [round(s.sigma * 1e3, 2) for s in result.sets][1] == 0.02
    for k in (0, 2):  # estimated from the residual
        assert abs(result.sets[k].sigma / truth.session(k).noise - 1) < 0.3, (k, result.sets[k].sigma)
    for k, s in enumerate(result.sets):
        per_axis = 1 if k != 1 else np.sqrt(3)
        assert _fresh_rmse_mm(chain, params, truth, s.model, s.x, k) < 2.0 * truth.session(k).noise * 1e3 * per_axis


def test_a_truth_of_mixed_sessions_round_trips(chain, params, tmp_path):
    sets, truth = cp.simulate_sessions(chain, params, [12, 6], seed=4, kinds=["cable", "position"],
                                       noise_mm=[0.05, 0.02])
    truth.to_json(tmp_path / "t.json")
    doc = json.loads((tmp_path / "t.json").read_text())
    assert [(g["data_kind"], g["noise_mm"]) for g in doc["sessions"]] == [("cable", 0.05), ("position", 0.02)]
    back = cp.Truth.from_json(tmp_path / "t.json", params)
    assert np.allclose(back.x, truth.x, rtol=1e-12, atol=0) and back.session(1).kind == "position"
    assert np.allclose(back.session(1).sensor.frame.translation, truth.session(1).sensor.frame.translation)
    assert np.allclose(back.session(0).sensor.anchor, sets[0].anchor) and back.session(0).noise == 5e-5

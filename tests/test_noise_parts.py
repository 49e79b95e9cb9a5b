"""Noise per part of a row (calib_pin/sensors/base.py noise_parts, calib_pin/calibration/noise.py
estimate_noise): a 6-D pose set that states neither noise gets
both from its residual, and calibrates as well as with them stated; the per-part errors
and noises reach report.json, the printout and report.html."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.report.build import build_report
from calib_pin.robot.poses import random_poses
from calib_pin.sensors.pose import PoseModel
from calib_pin.simulation import simulate_poses


@pytest.fixture(scope="module")
def robot():
    chain = cp.load_chain("irb120")
    return chain, cp.parameter_model(chain)


def _unstated(data: cp.MeasurementSet) -> cp.MeasurementSet:
    """The set without its ``# noise_mm`` and ``# noise_deg``."""
    return replace(data, noise=None, notes={k: v for k, v in data.notes.items() if k != "noise_deg"})


def _fresh_rms(chain, params, truth, result) -> tuple[float, float]:
    """RMS position [mm] and orientation [deg] error of the calibrated model on 1 000
    fresh poses against the noise-free truth."""
    model = result.sets[0].model
    fresh = random_poses(chain, 1000, np.random.default_rng(99))
    true_poses = PoseModel(chain, params, truth.sensor, estimate=()).predict(truth.x, fresh)
    mm, deg = model.part_errors(result.x, fresh, true_poses)
    return float(np.sqrt(np.mean(mm**2))), float(np.sqrt(np.mean(deg**2)))


@pytest.mark.parametrize("seed", [7, 8])
def test_a_pose_set_stating_no_noise_recovers_both_and_calibrates_as_well(robot, seed):
    chain, params = robot
    data, truth = simulate_poses(chain, params, 60, seed=seed, noise_mm=0.05, noise_deg=0.01)
    stated = cp.calibrate("irb120", data, method="lm", test_fraction=0.0)
    found = cp.calibrate("irb120", _unstated(data), method="lm", test_fraction=0.0)
    position, orientation = found.sets[0].model.noise_parts()
    assert (position.origin, orientation.origin) == ("estimate", "estimate")
    assert position.sigma * 1e3 == pytest.approx(0.05, rel=0.3)
    assert np.rad2deg(orientation.sigma) == pytest.approx(0.01, rel=0.3)
    assert found.noise == position.sigma and found.noise_from.startswith("estimated per part")
    assert [p.origin for p in stated.sets[0].model.noise_parts()] == ["file", "file"]
    ours, theirs = _fresh_rms(chain, params, truth, found), _fresh_rms(chain, params, truth, stated)
    assert ours[0] <= 1.1 * theirs[0] and ours[1] <= 1.1 * theirs[1], (ours, theirs)
    assert ours[0] < 0.06 and ours[1] < 0.01  # near the noise floor, as stated


def test_a_wrong_default_ratio_is_what_the_estimate_repairs(robot):
    """Orientation noise 0.1 deg, stated nowhere: the default (0.01 deg) overweights the
    orientation 10 x; the estimate finds 0.1 deg and keeps the stated position noise."""
    chain, params = robot
    data, truth = simulate_poses(chain, params, 60, seed=3, noise_mm=0.05, noise_deg=0.1)
    bare = replace(data, notes={k: v for k, v in data.notes.items() if k != "noise_deg"})  # noise_mm stays
    found = cp.calibrate("irb120", bare, method="lm", test_fraction=0.0)
    position, orientation = found.sets[0].model.noise_parts()
    assert position.origin == "file" and position.sigma == pytest.approx(0.05e-3)
    assert orientation.origin == "estimate" and np.rad2deg(orientation.sigma) == pytest.approx(0.1, rel=0.3)
    stated = cp.calibrate("irb120", data, method="lm", test_fraction=0.0)
    assert _fresh_rms(chain, params, truth, found)[0] <= 1.05 * _fresh_rms(chain, params, truth, stated)[0]


def test_the_variance_components_of_several_sets_are_unchanged_by_the_shared_loop(robot):
    """Three cable sessions with unstated noises: the loop now shared with the per-part
    estimate still estimates each set's sigma (within 30 % of the simulated 0.05 mm)."""
    chain, params = robot
    sets, _ = cp.simulate_sessions(chain, params, 100, seed=5, sessions=2, noise_mm=[0.05, 0.2])
    bare = [replace(s, noise=None) for s in sets]
    result = cp.calibrate("irb120", bare, method="lm")
    assert [s.sigma_origin for s in result.sets] == ["estimate", "estimate"]
    assert result.sets[0].sigma * 1e3 == pytest.approx(0.05, rel=0.3)
    assert result.sets[1].sigma * 1e3 == pytest.approx(0.2, rel=0.3)


def test_report_json_gives_each_part_in_its_unit_and_the_noise_used(robot, tmp_path):
    chain, params = robot
    data, truth = simulate_poses(chain, params, 40, seed=4, noise_mm=0.05, noise_deg=0.01)
    result = cp.calibrate("irb120", _unstated(data), method="lm")
    report = build_report(result)
    assert report["noise_by_part"]["position"]["noise_from"] == "estimate"
    assert set(report["noise_by_part"]["orientation"]) == {"noise_deg", "noise_from"}
    for split, rows in (("train", result.train), ("test", result.test)):
        part = result.sets[0].problem.subset(rows)
        mm, deg = part.part_errors(result.x)
        after = report["errors_by_part"][split]["after"]
        assert after["position_mm"]["rmse_mm"] == pytest.approx(np.sqrt(np.mean(mm**2)))
        assert after["orientation_deg"]["max_deg"] == pytest.approx(deg.max())
        before = report["errors_by_part"][split]["before"]["position_mm"]["rmse_mm"]
        assert before > 10 * after["position_mm"]["rmse_mm"]  # nominal: millimetres
    assert report["sensor_geometry"] == result.problem.model.geometry_report(result.x)
    assert report["sensor_geometry"]["body"]["translation_mm"] == pytest.approx(
        (truth.sensor.body.translation * 1e3).tolist(), abs=2.0)  # the body's offset trades with the last link's
    json.dumps(report)  # JSON-ready
    cable = build_report(cp.calibrate("irb120", method="lm"))
    assert "errors_by_part" not in cable and "noise_by_part" not in cable  # one part: the row error in mm


def test_several_sets_report_a_pose_sets_errors_in_mm_and_deg(robot):
    chain, params = robot
    sets, _ = cp.simulate_sessions(chain, params, 12, seed=21, kinds=["cable", "pose"])
    result = cp.calibrate("irb120", sets, method="lm")
    tables = build_report(result)["sets"]
    assert "errors_by_part" not in tables[0]
    after = tables[1]["errors_by_part"]["train"]["after"]
    assert set(after) == {"position_mm", "orientation_deg"} and after["position_mm"]["rmse_mm"] < 0.2
    assert tables[1]["device_frame"]["translation_mm"] and tables[0]["anchor_mm"]  # each set's own geometry


def test_the_printout_gives_the_noise_per_part(tmp_path, monkeypatch, capsys):
    from calib_pin.cli import main

    chain = cp.load_chain("irb120")
    data, _ = simulate_poses(chain, cp.parameter_model(chain), 40, seed=4)
    cp.write_measurements(tmp_path / "p.csv", _unstated(data))
    monkeypatch.chdir(tmp_path)
    assert main(["calibrate", "irb120", "--data", "p.csv", "--method", "lm", "--out", "o", "--no-html"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("noise per part"))
    assert "position 0.0" in line and " mm (estimate), orientation 0.0" in line and line.endswith("deg (estimate)")
    report = json.loads((tmp_path / "o" / "report.json").read_text())
    assert report["noise_by_part"]["orientation"]["noise_deg"] == pytest.approx(0.01, rel=0.3)


def test_the_callers_position_noise_is_kept_and_only_the_orientation_estimated(robot):
    chain, params = robot
    data, _ = simulate_poses(chain, params, 40, seed=4, noise_mm=0.05, noise_deg=0.01)
    result = cp.calibrate("irb120", _unstated(data), method="lm", noise_mm=0.08)
    position, orientation = result.sets[0].model.noise_parts()
    assert (position.origin, position.sigma) == ("caller", pytest.approx(0.08e-3))
    assert orientation.origin == "estimate" and result.noise_from == "stated"

"""Several simulated sessions of one true robot (simulate_sessions, simulate --sessions):
each its own set-up, one truth, and the joint fit of all sessions recovers the robot."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.cli.simulate import simulate_main
from calib_pin.exceptions import ArgumentError
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import setup_record
from calib_pin.simulation import Truth


def _fresh_rmse_mm(chain, params, truth, s, k) -> float:
    """RMSE [mm] of a fitted set's model against session k's noise-free truth at 1000 fresh poses."""
    q = random_poses(chain, 1000, np.random.default_rng(123))
    true = truth.session(k)
    return float(np.sqrt(np.mean((s.model.predict(s.x, q) - true.model(chain, params).predict(true.x_model, q)) ** 2))
                 * 1e3)


def test_sessions_share_the_robot_and_keep_their_own_setup(chain, params):
    sets, truth = cp.simulate_sessions(chain, params, 30, seed=5, sessions=3)
    first, first_truth = cp.simulate(chain, params, 30, seed=5)
    assert np.array_equal(sets[0].values, first.values) and np.array_equal(truth.x, first_truth.x)
    anchors = np.array([s.anchor for s in sets])
    assert len({tuple(a) for a in anchors}) == 3
    assert np.allclose([g.anchor for g in truth.sessions], anchors)
    assert np.allclose(truth.session(2).sensor.anchor, anchors[2]) and truth.session(2).x is truth.x
    assert not np.array_equal(sets[1].q, sets[2].q)  # each session its own poses
    given, _ = cp.simulate_sessions(chain, params, 10, seed=5, sessions=2, anchors_mm=[[500, 0, 0], [-500, 0, 0]])
    assert np.allclose(given[1].anchor, [-0.5, 0, 0])
    with pytest.raises(ArgumentError, match="anchors_mm"):
        cp.simulate_sessions(chain, params, 10, seed=5, sessions=3, anchors_mm=[[500, 0, 0]])
    with pytest.raises(ArgumentError, match="devices"):
        cp.simulate_sessions(chain, params, 10, seed=5, sessions=2, kind="position", devices=[pin.SE3.Identity()])


def test_position_sessions_each_have_their_own_device(chain, params):
    sets, truth = cp.simulate_sessions(chain, params, 20, seed=3, sessions=2, kind="position")
    frames = [g.frame for g in truth.sessions]
    assert np.linalg.norm(frames[0].translation - frames[1].translation) > 0.01
    result = cp.calibrate("irb120", sets, method="lm")
    for k, s in enumerate(result.sets):
        q = np.repeat(random_poses(chain, 200, np.random.default_rng(9)), 3, axis=0)
        index = np.tile(np.arange(3), 200)
        true = truth.session(k)
        error = s.model.predict(s.x, q, index) - true.model(chain, params).predict(true.x_model, q, index)
        assert np.sqrt(np.mean(np.sum(error ** 2, axis=1))) * 1e3 < 0.06  # 0.05 mm per axis of noise


def test_three_simulated_sessions_calibrate_to_the_truth(tmp_path, capsys):
    """calib-pin simulate --sessions 3 writes s_1..s_3.csv and one s.truth.json; the joint
    fit of the three files (each its own anchor, estimated) recovers the true robot: on
    fresh poses each session's model is within the noise floor of its noise-free truth."""
    out = tmp_path / "s.csv"
    assert simulate_main(["irb120", "--sessions", "3", "--poses", "60", "--seed", "4", "--out", str(out)]) == 0
    files = [tmp_path / f"s_{k}.csv" for k in (1, 2, 3)]
    assert all(f.is_file() for f in files) and not out.exists()
    assert len(json.loads((tmp_path / "s.truth.json").read_text())["sessions"]) == 3
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    truth = Truth.from_json(tmp_path / "s.truth.json", params)
    result = cp.calibrate("irb120", [str(f) for f in files], setup=setup_record(estimate=("anchor",)), method="lm")
    for k, s in enumerate(result.sets):
        assert np.allclose(s.model.geometry_at(None).anchor, truth.sessions[k].anchor, atol=1e-6)
        assert _fresh_rmse_mm(chain, params, truth, s, k) < 0.035  # reading noise 0.05 mm
    # once more without --force: refused, nothing replaced
    before = files[0].read_bytes()
    assert simulate_main(["irb120", "--sessions", "3", "--poses", "60", "--seed", "5", "--out", str(out)]) == 2
    assert files[0].read_bytes() == before and "exists" in capsys.readouterr().err
    assert simulate_main(["irb120", "--sessions", "2", "--anchor-mm", "1,2,3", "--out", str(tmp_path / "t.csv")]) == 2
    assert "once per session" in capsys.readouterr().err


def test_simulate_sessions_of_two_kinds_write_one_truth_and_calibrate_together(tmp_path, capsys):
    """calib-pin simulate --kinds cable,position: a drawstring session and a tracker session
    of one true robot, one truth naming each session's kind and noise; the two files fit
    together and each set's model is near its noise-free truth on fresh poses."""
    out = tmp_path / "m.csv"
    assert simulate_main(["irb120", "--kinds", "cable,position", "--poses", "60,10", "--noise-mm", "0.05,0.02",
                          "--seed", "1", "--out", str(out)]) == 0
    assert "2 session(s) (cable: 60 poses; position: 30 rows at 10 poses" in capsys.readouterr().out
    doc = json.loads((tmp_path / "m.truth.json").read_text())
    assert [(g["data_kind"], g["noise_mm"]) for g in doc["sessions"]] == [("cable", 0.05), ("position", 0.02)]
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    truth = Truth.from_json(tmp_path / "m.truth.json", params)
    result = cp.calibrate("irb120", [str(tmp_path / "m_1.csv"), str(tmp_path / "m_2.csv")], method="lm")
    assert [s.kind for s in result.sets] == ["cable", "position"]
    assert _fresh_rmse_mm(chain, params, truth, result.sets[0], 0) < 0.04  # reading noise 0.05 mm
    q = np.repeat(random_poses(chain, 200, np.random.default_rng(9)), 3, axis=0)
    index = np.tile(np.arange(3), 200)
    s, true = result.sets[1], truth.session(1)
    error = s.model.predict(s.x, q, index) - true.model(chain, params).predict(true.x_model, q, index)
    assert np.sqrt(np.mean(np.sum(error ** 2, axis=1))) * 1e3 < 0.05  # 0.02 mm per axis, 8 training poses

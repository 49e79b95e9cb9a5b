"""Several measurement sets wherever one set works: a validation session beside several
training sets (same=LABEL or register=K), --fix/--free/--nominal, compare's fresh-pose score,
and the all-sets table only of sets in one unit. One true robot, simulated with its truth."""

from __future__ import annotations

import numpy as np
import pytest

import calib_pin as cp
from calib_pin import FitSet, TestSet
from calib_pin.analysis.metrics import units_words
from calib_pin.calibration.record import write_calibration
from calib_pin.export.calibration_file import calibration_path
from calib_pin.measurements import write_measurements
from calib_pin.report.build import build_report
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import SENSORS, setup_record
from calib_pin.simulation import simulate_sessions

NOISE_MM = 0.02
#: Session 1 and 3 share the anchor (a validation on set a's set-up); session 2 is re-anchored.
#: Session 4 is re-anchored again (a validation on a new set-up).
ANCHORS_MM = [[600.0, 200.0, -100.0], [450.0, -350.0, 50.0], [600.0, 200.0, -100.0], [500.0, 400.0, 150.0]]


@pytest.fixture(scope="module")
def three(chain, params):
    """Four cable sessions of one true robot (40 poses each, 0.02 mm): a, b train; the third
    is a validation session on a's anchor, the fourth on a new one."""
    return simulate_sessions(chain, params, 40, 5, 4, anchors_mm=ANCHORS_MM, noise_mm=NOISE_MM)


def _fresh_mm(chain, params, truth, result, k=0) -> float:
    """RMSE [mm] of set k's model at 1000 fresh poses against session k's noise-free truth."""
    q = random_poses(chain, 1000, np.random.default_rng(99))
    true = truth.session(k)
    return float(np.sqrt(np.mean((result.sets[k].predict(q) - true.model(chain, params).predict(true.x_model, q))
                                 ** 2)) * 1e3)


def _training(sets):
    return [FitSet(sets[0], label="a"), FitSet(sets[1], label="b")]


def test_validation_on_a_named_training_set_up_is_scored_with_its_sensor(chain, params, three):
    sets, truth = three
    result = cp.calibrate("irb120", _training(sets), method="lm", test_data=TestSet(sets[2], same="a"))
    assert result.test_registration == {"data": "", "setup": "same", "same_as": "a"}
    assert all(not len(s.test) for s in result.sets)  # every training row trains
    assert len(result.train) == len(sets[0]) + len(sets[1])
    test = result.metrics["test"]
    assert test["before"].rmse_mm > 1.0 and test["after"].rmse_mm < 2.5 * NOISE_MM
    assert _fresh_mm(chain, params, truth, result) < 2 * NOISE_MM  # the robot, against the truth
    with pytest.raises(cp.CalibPinError, match="anchor_mm"):  # b's anchor is not the session's
        cp.calibrate("irb120", _training(sets), method="lm", test_data=TestSet(sets[2], same="b"))
    with pytest.raises(cp.ArgumentError, match="name the one whose set-up the session shares"):
        cp.calibrate("irb120", _training(sets), method="lm", test_data=sets[2])


@pytest.fixture(scope="module")
def tracked(chain, params):
    """Four tracker sessions of one true robot (25 poses of 3 markers each, 0.02 mm): a and b
    train from two placements; the third is measured from a's placement, the fourth from a
    new one (moved: turned about the vertical and shifted)."""
    _, drawn = simulate_sessions(chain, params, 5, 8, 4, kind="position", noise_mm=NOISE_MM)
    frames = [g.frame for g in drawn.sessions]
    return simulate_sessions(chain, params, 25, 8, 4, kind="position", noise_mm=NOISE_MM,
                             devices=[frames[0], frames[1], frames[0], frames[3]])


def test_validation_re_registered_beside_several_sets_scores_only_other_rows(chain, params, tracked):
    sets, truth = tracked
    result = cp.calibrate("irb120", _training(sets), method="lm", test_data=TestSet(sets[3], register=5))
    info = result.test_registration
    assert info["sensor_model_of"] == "a" and info["setup"] == "new" and info["fitted"]
    assert not set(info["registered_rows"]) & set(info["scored_rows"])
    assert len(info["registered_rows"]) == 15 and len(info["scored_rows"]) == len(sets[3]) - 15  # 5 poses x 3
    same = cp.calibrate("irb120", _training(sets), method="lm", test_data=TestSet(sets[2], same="a"))
    after = result.metrics["test"]["after"].rmse_mm
    assert after < 1.2 * same.metrics["test"]["after"].rmse_mm and after < 3 * NOISE_MM * np.sqrt(3)
    assert result.metrics["test"]["before"].rmse_mm > 5 * after  # the nominal robot, registered the same way
    with pytest.raises(cp.CalibPinError, match="device was moved"):  # never scored with a's registration
        cp.calibrate("irb120", _training(sets), method="lm", test_data=TestSet(sets[3], same="a"))


def test_fix_and_free_hold_shared_robot_and_per_set_sensor_unknowns(chain, params, three):
    sets, truth = three
    free = cp.calibrate("irb120", _training(sets), method="lm", setup=setup_record(estimate=("anchor",)))
    held = cp.calibrate("irb120", _training(sets), method="lm", setup=setup_record(estimate=("anchor",)), fix="theta_1,b:anchor_x")
    names = held.problem.model.names
    assert held.fixed == ("theta_1", "b:anchor_x")
    assert held.x[names.index("theta_1")] == 0.0 and held.x[names.index("b:anchor_x")] == 0.0
    assert free.x[names.index("b:anchor_x")] != 0.0
    assert held.sets[1].x[held.sets[1].model.names.index("theta_1")] == 0.0  # the robot is every set's
    for result in (free, held):  # a held unknown the data does not need costs nothing against the truth
        assert _fresh_mm(chain, params, truth, result) < 3 * NOISE_MM
    only = cp.calibrate("irb120", _training(sets), method="lm", free="a_2,a_3,d_4")
    robot = only.problem.model.sensor_start
    moved = [n for n, v in zip(names[:robot], only.x[:robot], strict=True) if v != 0.0]
    assert set(moved) <= {"a_2", "a_3", "d_4"} and moved


def test_nominal_with_several_sets_starts_every_set_there(chain, params, three, tmp_path):
    sets, truth = three
    first = cp.calibrate("irb120", _training(sets), method="lm")
    path = write_calibration(first, calibration_path(tmp_path, "irb120"))
    again = cp.calibrate("irb120", _training(sets), method="lm", nominal=path)
    assert again.start is not None and again.start.kind == "calibration"
    for k in (0, 1):  # started at the calibration, "before" is already its error
        assert again.sets[k].metrics["test"]["before"].rmse_mm < 3 * NOISE_MM
        assert first.sets[k].metrics["test"]["before"].rmse_mm > 1.0
    assert abs(_fresh_mm(chain, params, truth, again) - _fresh_mm(chain, params, truth, first)) < 0.1 * NOISE_MM


def test_all_sets_table_pools_one_unit_only(chain, params, monkeypatch):
    sets, _ = cp.simulate_sessions(chain, params, [30, 10], seed=2, kinds=["cable", "position"], noise_mm=0.02)
    both = [FitSet(sets[0], label="c"), FitSet(sets[1], label="t")]
    pooled = cp.calibrate("irb120", both, method="lm")
    assert units_words(pooled.sets) == "every set's row errors together, in mm" and "train" in pooled.metrics
    monkeypatch.setattr(SENSORS["position"], "value_unit", "deg")  # as a sensor of angles would say
    apart = cp.calibrate("irb120", both, method="lm")
    assert apart.metrics == {} and [s.unit for s in apart.sets] == ["mm", "deg"]
    assert any("no all-sets table: the sets' row errors are in different units (c: mm; t: deg)" in w
               for w in apart.warnings)
    assert np.array_equal(apart.x, pooled.x)  # the fit is the same; only the pooled table goes
    report = build_report(apart)
    assert "train" not in report and "different units" in report["metrics_pooled"]


def test_compare_on_several_simulated_sessions_gives_a_fresh_pose_score(chain, params, three, tmp_path):
    sets, truth = three
    files = []
    for k, data in enumerate(sets[:2], 1):
        files.append(tmp_path / f"sim_{k}.csv")
        write_measurements(files[-1], data)
    truth.to_json(tmp_path / "sim.truth.json")
    table = cp.compare("irb120", [str(f) for f in files], methods=["lm"])
    trial = table.trials[0]
    assert trial.before_fresh_rmse_mm is not None and trial.before_fresh_rmse_mm > 1.0
    assert trial.runs["lm"].fresh_rmse_mm < 3 * NOISE_MM
    (tmp_path / "sim.truth.json").unlink()  # no truth: no score, as for one set
    assert cp.compare("irb120", [str(f) for f in files], methods=["lm"]).trials[0].runs["lm"].fresh_rmse_mm is None


def test_compare_nominal_starts_every_method_at_the_robots_own_calibration(chain, params, three, tmp_path):
    sets, truth = three
    files = []
    for k, data in enumerate(sets[:2], 1):
        files.append(str(tmp_path / f"sim_{k}.csv"))
        write_measurements(files[-1], data)
    truth.to_json(tmp_path / "sim.truth.json")
    path = write_calibration(cp.calibrate("irb120", files, method="lm"), calibration_path(tmp_path, "irb120"))
    for data in (files, files[0]):  # several sets, and one
        catalogue = cp.compare("irb120", data, methods=["lm"])
        started = cp.compare("irb120", data, methods=["lm"], nominal=path)
        assert "started from irb120_calibration.json" in started.data
        before = started.trials[0].before.rmse_mm
        assert before < 3 * NOISE_MM < catalogue.trials[0].before.rmse_mm  # "before" is the start's
        assert started.trials[0].runs["lm"].test.rmse_mm == pytest.approx(
            catalogue.trials[0].runs["lm"].test.rmse_mm, abs=0.1 * NOISE_MM)
    fresh = cp.compare("irb120", files, methods=["lm"], nominal=path).trials[0]
    assert fresh.before_fresh_rmse_mm < 3 * NOISE_MM and fresh.runs["lm"].fresh_rmse_mm < 3 * NOISE_MM
    with pytest.raises(cp.ArgumentError, match="not simulated sets"):
        cp.compare("irb120", simulate_noise="gauss", poses=10, methods=["lm"], nominal=path)


def test_outliers_of_several_sets_are_named_with_their_set(three, tmp_path):
    """A robust fit of two files marks a gross reading in set b: report.json gives each outlier's
    set beside its file line, and calibrate prints the lines per set (a line number alone does
    not say which file it is in)."""
    from calib_pin.cli.calibrate import _outlier_lines

    sets, _ = three
    paths = []
    for name, data in (("a", sets[0]), ("b", sets[1])):
        paths.append(tmp_path / f"{name}.csv")
        write_measurements(paths[-1], data)
    lines = paths[1].read_text().splitlines()
    first = next(k for k, line in enumerate(lines) if line[:1].isdigit() or line[:1] == "-")
    cells = lines[first + 6].split(",")
    cells[-1] = f"{float(cells[-1]) + 5.0:.6f}"  # 5 mm off: a snagged cable on b's row 6
    lines[first + 6] = ",".join(cells)
    paths[1].write_text("\n".join(lines) + "\n")
    result = cp.calibrate("irb120", [FitSet(str(p), label=p.stem) for p in paths], method="lm", loss="huber",
                          test_fraction=0)
    report = build_report(result)
    assert len(report["outlier_sets"]) == len(report["outlier_lines"]) == len(report["outlier_rows"])
    assert ("b", first + 7) in set(zip(report["outlier_sets"], report["outlier_lines"], strict=True))
    shown = _outlier_lines(report)
    assert "b line" in shown and str(first + 7) in shown.split("b line")[1]
    assert _outlier_lines({"outlier_lines": [16, 19]}) == "file lines 16, 19"
    assert _outlier_lines({"outlier_lines": [16, 19, 20], "outlier_sets": ["a", "b", "b"]}) == "a line 16; b lines 19, 20"
    assert _outlier_lines({"outlier_lines": []}) == "file lines none"

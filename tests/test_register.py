"""Validation on a new set-up (issue 22): a session measured after the tracker was moved or
the drawstring re-anchored is re-registered on its stated rows with the calibrated robot
fixed, then scored on the others; without re-registration it is refused."""

import dataclasses
import json

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin import TestSet
from calib_pin.calibration.validation import registration_rows
from calib_pin.cli.calibrate import calibrate_main, validation_argument
from calib_pin.measurements import write_measurements
from calib_pin.simulation import simulate_sessions

#: The training placement of the tracker (the simulator's default) and a moved one (1.3 m away, turned 50 deg).
HOME = pin.SE3(pin.rpy.rpyToMatrix(0.02, -0.01, np.deg2rad(150.0)), np.array([2.0, 0.3, -0.4]))
MOVED = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.01, np.deg2rad(100.0)), np.array([1.5, -0.9, -0.3]))


@pytest.fixture(scope="module")
def tracker(chain, params):
    """One robot, three tracker sessions of 30 poses: training, validation from the same
    placement, validation after the tracker was moved."""
    return simulate_sessions(chain, params, 30, seed=4, sessions=3, kind="position", devices=[HOME, HOME, MOVED])


def test_moved_tracker_re_registered_on_5_poses_scores_like_the_same_set_up(tracker):
    """Re-registered on its first 5 poses (its device frame fitted, the calibrated robot
    and markers fixed), the moved session's test error is within 1.2 x that of a session
    from the training placement; no registration row is scored."""
    (train, same, moved), _ = tracker
    same_error = cp.calibrate("irb120", train, method="lm", test_data=same).metrics["test"]["after"].rmse_mm
    result = cp.calibrate("irb120", train, method="lm", test_data=TestSet(moved, register=5))
    moved_error = result.metrics["test"]["after"].rmse_mm
    assert moved_error < 1.2 * same_error
    assert result.metrics["test"]["before"].rmse_mm > 10 * moved_error  # the nominal robot, registered alike
    info = result.test_registration
    assert info["registered_rows"] == list(range(15)) and info["scored_rows"] == list(range(15, 90))
    assert info["fitted"] == [f"device_{a}" for a in ("x", "y", "z", "rx", "ry", "rz")]
    frame = info["geometry"]["device_frame"]
    np.testing.assert_allclose(frame["translation_mm"], MOVED.translation * 1e3, atol=1.0)


def test_moved_tracker_without_re_registration_is_refused(tracker):
    """Scored with the training placement's frame every row would be metres off: refused,
    naming the shift and the way out."""
    (train, _, moved), _ = tracker
    with pytest.raises(cp.DataError, match=r"device frame: the session's own is .* mm .*register=K"):
        cp.calibrate("irb120", train, method="lm", test_data=moved)
    with pytest.raises(cp.DataError, match="device frame"):  # naming the training set changes nothing
        cp.calibrate("irb120", train, method="lm", test_data=TestSet(moved, same=""))


def test_re_anchored_cable_re_registered(chain, params):
    """A drawstring re-anchored 1 m away: refused as the same set-up; re-registered on 20
    of its 60 poses (the anchor from its file, or pre-fitted without one) it scores the
    other 40 within 1.2 x of the calibrated robot with the true anchor."""
    anchors = [(600.0, 200.0, -100.0), (-300.0, 500.0, 0.0)]
    (train, moved), truth = simulate_sessions(chain, params, 60, seed=6, sessions=2, kind="cable", anchors_mm=anchors)
    with pytest.raises(cp.DataError, match="anchor_mm: the validation session has -300, 500, 0 mm"):
        cp.calibrate("irb120", train, method="lm", test_data=moved)
    calibrated = cp.calibrate("irb120", train, method="lm", test_fraction=0)
    scored = np.arange(20, 60)
    oracle = cp.CableModel(chain, params, truth.sessions[1]).predict(calibrated.x, moved.q[scored])
    oracle_mm = float(np.sqrt(np.mean((oracle - moved.values[scored]) ** 2)) * 1e3)
    rough = dataclasses.replace(moved, anchor=moved.anchor + [0.01, -0.008, 0.005])  # measured with a tape
    for session in (rough, dataclasses.replace(moved, anchor=None)):
        result = cp.calibrate("irb120", train, method="lm", test_fraction=0, test_data=TestSet(session, register=20))
        assert result.test_registration["scored_rows"] == scored.tolist()
        assert result.metrics["test"]["after"].rmse_mm < 1.2 * oracle_mm
        anchor = np.array(result.test_registration["geometry"]["anchor_mm"])
        np.testing.assert_allclose(anchor, anchors[1], atol=1.0)


def test_registration_rows_by_role_and_by_poses(tracker):
    """register=role takes the rows marked 'register' (whatever their order); register=k the
    first k poses in file order; nothing left to score, or no marked row, is refused."""
    (train, _, moved), _ = tracker
    role = np.array(["score"] * len(moved), dtype=object)
    role[[3, 4, 5, 60, 61, 62]] = "register"
    marked = dataclasses.replace(moved, extra={"role": role})
    registered, scored = registration_rows(marked, "role")
    assert registered.tolist() == [3, 4, 5, 60, 61, 62] and len(scored) == len(moved) - 6
    assert registration_rows(moved, 2)[0].tolist() == list(range(6))
    with pytest.raises(cp.DataError, match="nothing left to score"):
        registration_rows(moved, 30)
    with pytest.raises(cp.DataError, match="needs a 'role' column"):
        registration_rows(moved, "role")
    with pytest.raises(cp.ArgumentError, match="register"):
        TestSet(moved, register=0)
    one_marker = moved.subset(np.flatnonzero(moved.point_ids == 1)[:4])  # 1 pose: 3 values for a frame
    with pytest.raises(cp.DataError, match="1 registration rows give 3 values, fewer than the 6 set-up unknowns"):
        cp.calibrate("irb120", train, method="lm", test_data=TestSet(one_marker, register=1))


def test_cli_test_data_choice(tracker, tmp_path, capsys):
    """--test-data FILE:register=5 prints which rows registered and which were scored and
    writes them to report.json; a bad choice is one line naming the argument."""
    (train, _, moved), _ = tracker
    write_measurements(tmp_path / "train.csv", train)
    write_measurements(tmp_path / "moved.csv", moved)
    out = tmp_path / "out"
    argv = ["irb120", "--data", str(tmp_path / "train.csv"), "--method", "lm", "--no-html", "--out", str(out)]
    assert calibrate_main(argv + ["--test-data", f"{tmp_path / 'moved.csv'}:register=5"]) == 0
    printed = capsys.readouterr().out
    assert "15 rows (file lines 6-20) re-registered it (first 5 poses" in printed and "the other 75 rows" in printed
    report = json.loads((out / "report.json").read_text())
    assert report["test_registration"]["registered_rows"] == list(range(15))
    assert calibrate_main(argv + ["--test-data", f"{tmp_path / 'moved.csv'}:register=five"]) == 2
    assert "register: expected a number of poses" in capsys.readouterr().err
    assert validation_argument(f"{tmp_path / 'moved.csv'}:same=train") == TestSet(str(tmp_path / "moved.csv"), same="train")
    with pytest.raises(cp.ArgumentError, match="'other' is not the training set"):
        cp.calibrate("irb120", str(tmp_path / "train.csv"), method="lm",
                     test_data=TestSet(str(tmp_path / "moved.csv"), same="other"))


@pytest.fixture(scope="module")
def plates(chain, params):
    """One robot, three contact sessions: training, the same fixtures, and the fixtures
    moved 30 mm (a plate re-clamped); each recorded fixture by fixture (A's touches first)."""
    from calib_pin.sensors.contact import default_fixtures

    home = default_fixtures()
    moved = dataclasses.replace(home, points=home.points + [0.02, -0.015, 0.015], offsets=home.offsets + 0.02)
    sets, _ = simulate_sessions(chain, params, [60, 40, 40], seed=5, kinds=["contact"] * 3,
                                geometries=[home, home, moved])
    return [s.subset(np.argsort(_fixture_of(s), kind="stable")) for s in sets]


def _fixture_of(data: cp.MeasurementSet) -> np.ndarray:
    from calib_pin.sensors.contact import fixture_rows

    return fixture_rows(data)[2]


def test_a_contact_session_of_moved_fixtures_is_refused_unless_re_registered(plates):
    """Scored against the calibration's fixtures, a session of a moved plate gave a test
    error of the move (exit 0); its fixtures, located by its own touches, are refused 5 mm
    off; the same plate is scored; re-registered, the moved one scores like it."""
    train, same, moved = plates
    with pytest.raises(cp.DataError, match=r"fixtures: the session's own are 2\d\.?\d* mm \(RMS over its fixtures\) from the "
                                           r"calibration's: the fixtures \(a plate, a cube\) were moved .*register=K"):
        cp.calibrate("irb120", train, method="lm", test_data=moved)
    same_error = cp.calibrate("irb120", train, method="lm", test_data=same).metrics["test"]["after"].rmse_mm
    registered = cp.calibrate("irb120", train, method="lm", test_data=TestSet(moved, register=16))
    assert registered.metrics["test"]["after"].rmse_mm < 1.5 * same_error < 0.5


def test_register_k_takes_each_fixture_in_turn(plates):
    """A file recorded fixture by fixture: register=K took its first K rows (all of one
    socket: 'contact_id B is touched at 0 ... training rows'); now K poses one of each
    fixture in turn, file order within each; one target (a cable file): the first K."""
    _, _, moved = plates
    fixtures = _fixture_of(moved)
    rows, scored = registration_rows(moved, 8, fixtures)
    assert sorted(fixtures[rows].tolist()) == [0, 0, 1, 1, 2, 2, 3, 3] and len(scored) == len(moved) - 8
    assert rows.tolist() == sorted(rows.tolist()) and rows[0] == 0
    assert registration_rows(moved, 3)[0].tolist() == [0, 1, 2]
    with pytest.raises(cp.DataError, match=r"plane_id F is touched at 1 distinct configuration\(s\) of the "
                                           r"registration rows: a plane needs 3 or more \(register=4 took 4 poses, one "
                                           "of each fixture or point in turn"):
        cp.calibrate("irb120", plates[0], method="lm", test_data=TestSet(moved, register=4))

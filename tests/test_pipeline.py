"""The pipeline: nothing fitted on test rows, validation on a separate session, labels."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.measurements import write_measurements

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
WU2015 = ROBOTS / "irb120_wu2015.csv"
DEFAULT_CSV = ROBOTS / "irb120_default.csv"


def _with_test_rows_moved(data: cp.MeasurementSet, test: np.ndarray) -> cp.MeasurementSet:
    values = data.values.copy()
    values[test] += 5e-3  # 5 mm on every held-out value
    return dataclasses.replace(data, values=values)


@pytest.mark.parametrize("source", ["default", "positions"])
def test_no_estimate_depends_on_a_test_row(source):
    """Moving every held-out value by 5 mm changes neither the estimate (robot and sensor
    geometry, device frame and markers included) nor the training metrics."""
    data = cp.read_measurements(ROBOTS / "irb120_default.csv" if source == "default" else WU2015,
                                cp.load_chain("irb120"))
    setup = cp.prepare("irb120", data)
    _, test = setup.split(0.2, 3)
    first = cp.solve(setup, "lm", seed=3)
    moved = cp.solve(cp.prepare("irb120", _with_test_rows_moved(data, test)), "lm", seed=3)
    np.testing.assert_array_equal(first.x, moved.x)
    assert first.metrics["train"] == moved.metrics["train"]
    assert first.metrics["test"]["before"] != moved.metrics["test"]["before"]


def test_separate_validation_session_of_readings(tmp_path, session):
    """--test-data: every row of the calibration set trains; the test metrics are those of
    the other session's rows predicted by the calibrated model."""
    data, _ = session
    cal, val = data.subset(np.arange(90)), data.subset(np.arange(90, 120))
    write_measurements(tmp_path / "cal.csv", cal)
    write_measurements(tmp_path / "val.csv", val)
    result = cp.calibrate("irb120", tmp_path / "cal.csv", method="lm", test_data=tmp_path / "val.csv")
    assert len(result.train) == 90 and result.test_source.endswith("val.csv")
    errors = np.abs(result.predict(val.q) - val.values) * 1e3
    assert result.metrics["test"]["after"].rmse_mm == pytest.approx(np.sqrt(np.mean(errors**2)), rel=1e-5)  # the file rounds to 1 nm
    assert result.metrics["test"]["after"].rmse_mm < 0.1 < 1.0 < result.metrics["test"]["before"].rmse_mm


def test_validation_marker_never_seen_is_located_from_its_first_row(chain, params, tmp_path):
    """A marker only the validation session has is located from its first row through the
    calibrated model and device frame; its other rows are predicted to the noise level."""
    markers = ((60.0, 0.0, 40.0), (-30.0, 52.0, 40.0), (-30.0, -52.0, 40.0), (0.0, 80.0, 20.0))
    data, _ = cp.simulate_positions(chain, params, 50, seed=4, noise_mm=0.02, markers_mm=markers)
    cal = data.subset(np.flatnonzero((data.point_ids < 4) & (data.pose_ids <= 36)))
    val = data.subset(np.flatnonzero((data.point_ids == 4) & (data.pose_ids > 36)))
    write_measurements(tmp_path / "cal.csv", cal)
    write_measurements(tmp_path / "val.csv", val)
    result = cp.calibrate("irb120", tmp_path / "cal.csv", method="lm", test_data=tmp_path / "val.csv")
    after, before = result.metrics["test"]["after"], result.metrics["test"]["before"]
    assert after.mean_mm < 0.1 < 1.0 < before.mean_mm


def test_predict_takes_the_files_point_labels(chain, params):
    """result.predict(q, point_ids) uses the file's point_id labels; an unknown one is refused."""
    data, truth = cp.simulate_positions(chain, params, 30, seed=2, noise_mm=0.0)
    shifted = dataclasses.replace(data, point_ids=data.point_ids + 10)  # labels 11, 12, 13
    result = cp.calibrate("irb120", shifted, method="lm")
    q = data.q[:3]
    expected = truth.model(chain, params).predict(truth.x, q, np.arange(3))
    np.testing.assert_allclose(result.predict(q, [11, 12, 13]), expected, atol=1e-6)
    with pytest.raises(cp.DataError, match="point_id 2 is not a marker of this calibration"):
        result.predict(q, [2, 2, 2])


def test_robot_line_may_name_the_urdf_path(tmp_path):
    """'# robot:' may be the URDF path given to the command, not only the robot's name."""
    urdf = str(ROBOTS / "irb120.urdf")
    text = (ROBOTS / "irb120_default.csv").read_text().replace("# robot: irb120", f"# robot: {urdf}")
    (tmp_path / "s.csv").write_text(text)
    result = cp.calibrate(urdf, tmp_path / "s.csv", method="lm")
    assert result.metrics["test"]["after"].rmse_mm < 0.1


def test_a_test_fraction_that_holds_out_nothing_says_so():
    """--test-fraction 0.001 rounds to no test pose: a warning, no test metrics."""
    result = cp.calibrate("irb120", method="lm", test_fraction=0.001)
    assert "test" not in result.metrics and "holds out no pose" in result.warnings[0]


def test_import_pulls_in_no_optional_dependency():
    """import calib_pin (and its pipeline) loads neither serial, minimalmodbus nor matplotlib."""
    code = ("import sys, calib_pin; calib_pin.calibrate; calib_pin.CableModel; "
            "print([m for m in ('serial', 'minimalmodbus', 'matplotlib') if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_the_sensor_frame_is_fitted_once_when_every_row_trains(device_fits):
    """With test_fraction 0 the run's problem is the calibration's (one device-frame fit),
    and the calibration is the one made with two fits; with a test fraction the training
    rows get their own fit, made once for every method of that split."""
    calls = device_fits
    setup = cp.prepare("irb120", WU2015)
    assert calls == [len(setup.data)]
    once = cp.solve(setup, "lm", holdout=0)
    assert calls == [len(setup.data)] and once.problem is setup.problem
    cp.solve(setup, "lm", holdout=0.2)
    assert len(calls) == 2 and calls[-1] < len(setup.data)
    cp.solve(setup, "ekf", holdout=0.2)  # the same training rows: the same problem
    assert len(calls) == 2
    fresh = cp.solve(setup, "lm", holdout=0)
    assert fresh.x.tobytes() == once.x.tobytes() and fresh.metrics == once.metrics and len(calls) == 2


def test_problem_on_without_reuse_fits_anew(device_fits):
    """``reuse=False`` fits the sensor's start again even on every row (what a benchmark
    times), to the same problem values as the kept one."""
    calls = device_fits
    setup = cp.prepare("irb120", WU2015)
    rows = np.arange(len(setup.data))
    assert setup.problem_on(rows) is setup.problem and len(calls) == 1
    fresh = setup.problem_on(rows, reuse=False)
    assert len(calls) == 2 and fresh is not setup.problem
    assert fresh.residual(None).tobytes() == setup.problem.residual(None).tobytes()


def test_values_are_counted_against_the_directions_the_rows_identify(session):
    """23 readings for 24 unknowns (20 of them identifiable) calibrate: the count is against
    the identifiable directions, not every unknown (refused before); 10 readings with 2 free
    unknowns calibrate too; 19 readings that identify 19 directions (every value fitted
    exactly) are refused saying which count; a cross-validation fold's rows are named so."""
    data, _ = session
    result = cp.calibrate("irb120", data.subset(np.arange(23)), method="lm", test_fraction=0)
    assert result.metrics["train"]["after"].rmse_mm < result.metrics["train"]["before"].rmse_mm
    free = cp.calibrate("irb120", data.subset(np.arange(10)), method="lm", test_fraction=0, free="theta_2,theta_3")
    assert free.metrics["train"]["after"].rmse_mm < free.metrics["train"]["before"].rmse_mm
    with pytest.raises(cp.DataError, match=r"19 training rows give 19 values, no more than the 19 directions they "
                                           r"identify \(of the 24 unknowns\): every value would be fitted exactly"):
        cp.calibrate("irb120", data.subset(np.arange(19)), method="lm", test_fraction=0)
    with pytest.raises(cp.DataError, match=r"of the 3 free unknowns, 21 held"):
        cp.calibrate("irb120", data.subset(np.arange(3)), method="lm", test_fraction=0, free="theta_2,theta_3,d_1")
    with pytest.raises(cp.DataError, match=r"19 fitting rows of cross-validation fold 1 of 3 \(the other folds'\) give"):
        cp.solve(cp.prepare("irb120", data.subset(np.arange(29))), "lm", holdout=cp.Folds(3))


def test_a_fraction_that_holds_out_every_pose_says_so(chain, params):
    """One pose at test fraction 0.6 leaves no training row: said as such, not as 'every set
    has role test' (prepare refuses those)."""
    import pytest

    one = cp.simulate(chain, params, 1, seed=1)[0]
    with pytest.raises(cp.DataError, match="test fraction 0.6 holds out every pose of its 1 rows: nothing to fit"):
        cp.calibrate("irb120", one, method="lm", test_fraction=0.6)

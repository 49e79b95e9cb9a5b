"""Position measurements: the model's Jacobian, the device fit, simulated and real data."""

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.cli.calibrate import calibrate_main
from calib_pin.report.build import build_report
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import fit_device

ROOT = Path(__file__).resolve().parents[1]
WU2015 = ROOT / "robots" / "irb120_wu2015.csv"


def _fd(f, x, h=1e-7):
    return np.stack([(f(x + h * e) - f(x - h * e)) / (2 * h) for e in np.eye(len(x))], axis=-1)


@pytest.fixture(scope="module")
def position_session(chain, params):
    """36 poses x 3 markers, 0.05 mm per axis, nominal position error 2 mm."""
    return cp.simulate_positions(chain, params, 36, seed=3)


@pytest.mark.parametrize("name", ["dh", "placement"])
def test_position_jacobian_matches_finite_differences(chain, name):
    """Robot, device-frame and marker columns of the analytic Jacobian equal central
    differences away from zero."""
    params = cp.parameter_model(chain, name)
    rng = np.random.default_rng(0)
    device = cp.PositionDevice(pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.array([1.0, 2.0, 3.0])),
                               rng.normal(size=(3, 3)) * 0.05, (1, 2, 5))
    model = cp.PositionModel(chain, params, device)
    q = random_poses(chain, 5, rng)
    markers = np.array([0, 1, 2, 0, 2])
    x = rng.normal(size=model.n_params) * model.scale * 3
    _, jac = model.predict_with_jacobian(x, q, markers)
    np.testing.assert_allclose(jac, _fd(lambda y: model.predict(y, q, markers), x), atol=1e-7)


def test_device_fit_recovers_frame_and_markers(chain, params):
    """With the robot nominal and no noise, the best fit is the true device exactly."""
    data, truth_all = cp.simulate_positions(chain, params, 12, seed=1, noise_mm=0.0, nominal_rmse_mm=0.0)
    truth = truth_all.sensor
    markers = data.point_ids - 1
    fit = fit_device(chain, params, data.q, data.positions, markers, (1, 2, 3))
    np.testing.assert_allclose(fit.frame.homogeneous, truth.frame.homogeneous, atol=1e-8)
    np.testing.assert_allclose(fit.markers, truth.markers, atol=1e-8)


def test_simulated_positions_calibrate_to_the_noise_floor(chain, params, position_session):
    """Every Kalman, search and LM method predicts fresh poses' marker positions (device
    frame) within 0.06 mm RMS of the truth, from 2 mm before."""
    data, truth_all = position_session
    x_true, device = truth_all.x, truth_all.sensor
    q = np.repeat(random_poses(chain, 200, np.random.default_rng(5)), 3, axis=0)
    markers = np.tile(np.arange(3), 200)
    truth = cp.PositionModel(chain, params, device, estimate=()).predict(x_true, q, markers)
    setup = cp.prepare("irb120", data)
    assert setup.problem.n_params == 24 + 6 + 9
    for method in ("lm", "ekf-qibas", "ekf"):
        result = cp.solve(setup, method)
        fresh = np.sqrt(np.mean(np.sum((result.predict(q, markers + 1) - truth) ** 2, axis=1))) * 1e3
        assert fresh < 0.06, method
        assert result.metrics["test"]["after"].rmse_mm < 0.15 < 1.0 < result.metrics["test"]["before"].rmse_mm


def test_position_split_keeps_poses_together(position_session):
    """A pose's three markers are on the same side of the split."""
    data, _ = position_session
    train, test = cp.prepare("irb120", data).split(0.2, 0)
    assert not set(data.pose_ids[train]) & set(data.pose_ids[test])
    assert len(test) == 3 * 7


def test_real_irb120_positions_fit_far_below_the_nominal_model():
    """Wu et al. 2015's real IRB120 set (36 configurations x 3 markers): the nominal
    model with a best-fit device frame leaves about 5 mm; calibrated, the training fit
    and the held-out configurations are below 0.5 mm (the authors: 0.27 mm mean on
    their own test set)."""
    data = cp.read_measurements(WU2015, cp.load_chain("irb120"))
    assert data.kind == "position" and len(data) == 108 and len(np.unique(data.pose_ids)) == 36
    result = cp.calibrate("irb120", WU2015, method="lm")
    before, after = result.metrics["train"]["before"], result.metrics["train"]["after"]
    assert 4.5 < before.rmse_mm < 6.5
    assert after.rmse_mm < 0.5 and result.metrics["test"]["after"].mean_mm < 0.5
    default = cp.calibrate("irb120", WU2015)
    assert default.metrics["test"]["after"].mean_mm < 0.5


def test_position_sets_round_trip(tmp_path, position_session, chain):
    data, _ = position_session
    path = tmp_path / "p.csv"
    cp.write_measurements(path, data)
    back = cp.read_measurements(path, chain)
    np.testing.assert_allclose(back.positions, data.positions, atol=1e-9)
    np.testing.assert_array_equal(back.point_ids, data.point_ids)
    np.testing.assert_array_equal(back.pose_ids, data.pose_ids)


HEADER = "pose,point_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm"
ROW = "1,1,0,10,10,0,20,0,400,10,600"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (HEADER + ",length_mm\n" + ROW + ",500\n", "has both length and x/y/z columns"),
        (HEADER.replace(",z_mm", "") + "\n" + ROW.rsplit(",", 1)[0] + "\n", "missing column z_mm"),
        (HEADER + "\n" + ROW + "\n" + ROW + "\n", "bad.csv:3: pose: pose 1 point 1 appears twice"),
        (HEADER + "\n" + ROW.replace("400", "4o0") + "\n", "bad.csv:2: x_mm: .4o0. is not a number"),
    ],
)
def test_bad_position_files(tmp_path, chain, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(cp.DataError, match=message):
        cp.read_measurements(path, chain)


def test_cli_calibrates_real_positions_and_refuses_cable_options(tmp_path, capsys):
    assert calibrate_main(["irb120", "--no-html", "--data", str(WU2015), "--method", "lm", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "108 rows at 36 poses" in out and "Euclidean position error" in out
    assert (tmp_path / "irb120_calibrated.urdf").is_file()
    code = calibrate_main(["irb120", "--no-html", "--data", str(WU2015), "--estimate", "anchor", "--out", str(tmp_path / "x")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "the device frame and the marker points are always estimated" in err[0]


# --- real files (issue 20, 3): string marker labels -----------------------------------

LABELS = {"1": "SMR1", "2": "T2", "3": "A"}


def _real_copy(path: Path, poses: range = range(36), new_label: str | None = None) -> Path:
    """The Wu set's poses ``poses`` as another lab might write it: marker labels SMR1, T2, A
    (``new_label`` for marker 3 instead), extra columns (temperature, standard deviation, a
    time stamp), ';' separators and decimal commas."""
    lines = WU2015.read_text().splitlines()
    out = [line for line in lines[:4]]
    out.append(lines[4].replace(",", ";") + ";temp_C;sigma_mm;time")
    for k, row in enumerate(lines[5:]):
        fields = row.split(",")
        if int(fields[0]) not in poses:
            continue
        fields[1] = new_label if new_label and fields[1] == "3" else LABELS[fields[1]]
        fields += [f"{20 + k % 5 / 10:.1f}", "0.015", f"2015-03-02 09:{k % 60:02d}:00"]
        out.append(";".join(f.replace(".", ",") for f in fields))
    path.write_text("\n".join(out) + "\n")
    return path


def _numeric_copy(path: Path, poses: range, new_label: str | None = None) -> Path:
    """The Wu set's poses ``poses`` as shipped (``new_label`` for marker 3)."""
    lines = WU2015.read_text().splitlines()
    rows = [r for r in lines[5:] if int(r.split(",")[0]) in poses]
    if new_label:
        rows = [r.replace(",3,", f",{new_label},", 1) for r in rows]
    path.write_text("\n".join(lines[:5] + rows) + "\n")
    return path


def test_string_labels_and_european_csv_calibrate_to_the_same_numbers(tmp_path):
    """The Wu set with string labels, extra columns and ';'/decimal commas calibrates to the
    numbers of the original file (1e-9 mm); predict and the markers keep the labels."""
    original = cp.calibrate("irb120", WU2015, method="lm")
    real = cp.calibrate("irb120", _real_copy(tmp_path / "real.csv"), method="lm")
    assert real.data.point_ids.tolist()[:3] == ["SMR1", "T2", "A"]
    for name, value in original.deviations.items():
        assert abs(real.deviations[name] - value) < 1e-9, name
    for split in ("train", "test"):
        assert abs(real.metrics[split]["after"].rmse_mm - original.metrics[split]["after"].rmse_mm) < 1e-9
    markers = real.sensor.to_dict()["markers_mm"]
    assert list(markers) == ["A", "SMR1", "T2"]
    for label, number in LABELS.items():
        np.testing.assert_allclose(markers[number], original.sensor.to_dict()["markers_mm"][label], atol=1e-9)
    q = original.data.q[:4]
    np.testing.assert_allclose(real.predict(q, ["SMR1", "T2", "A", "SMR1"]), original.predict(q, [1, 2, 3, 1]),
                               atol=1e-12)
    assert real.sensor_corrections.keys() >= {"markerSMR1_x_mm", "markerA_z_mm"}
    with pytest.raises(cp.DataError, match="point_id B is not a marker of this calibration .markers: A, SMR1, T2."):
        real.predict(q[:1], ["B"])
    assert any("ignored columns: temp_C, sigma_mm, time" in w for w in real.warnings)
    report = build_report(real)
    assert report["ignored_columns"] == ["temp_C", "sigma_mm", "time"] and list(report["markers_mm"]) == list(markers)
    assert any("ignored columns" in w for w in report["warnings"]) and build_report(original)["ignored_columns"] == []


def test_test_data_scores_string_labels_like_numbers(tmp_path):
    """--test-data on a labelled session (a marker it never saw included) gives the
    original numbers' test metrics."""
    original = cp.calibrate("irb120", _numeric_copy(tmp_path / "c.csv", range(24)), method="lm",
                            test_data=_numeric_copy(tmp_path / "v.csv", range(24, 36)))
    real = cp.calibrate("irb120", _real_copy(tmp_path / "rc.csv", range(24)), method="lm",
                        test_data=_real_copy(tmp_path / "rv.csv", range(24, 36)))
    for stage in ("before", "after"):
        assert abs(real.metrics["test"][stage].rmse_mm - original.metrics["test"][stage].rmse_mm) < 1e-9
    original = cp.calibrate("irb120", tmp_path / "c.csv", method="lm",
                            test_data=_numeric_copy(tmp_path / "n.csv", range(24, 36), new_label="9"))
    new = cp.calibrate("irb120", tmp_path / "rc.csv", method="lm",
                       test_data=_real_copy(tmp_path / "nv.csv", range(24, 36), new_label="Z9"))
    for stage in ("before", "after"):  # marker Z9 (9) is located from its first row
        assert abs(new.metrics["test"][stage].rmse_mm - original.metrics["test"][stage].rmse_mm) < 1e-9
    assert new.metrics["test"]["after"].rmse_mm < new.metrics["test"]["before"].rmse_mm / 5
    assert any("(in nv.csv" in w for w in new.warnings)


def test_device_geometry_keeps_label_types():
    """to_dict/from_dict keep whole-number labels as ints and text labels as text."""
    for labels in ((1, 2, 3), ("SMR1", "T2", "A")):
        device = cp.PositionDevice(pin.SE3.Identity(), np.eye(3) * 0.05, labels)
        back = cp.PositionDevice.from_dict(device.to_dict())
        assert back.labels == labels and all(type(a) is type(b) for a, b in zip(back.labels, labels, strict=True))
        np.testing.assert_allclose(back.markers, device.markers)


def test_labelled_position_sets_round_trip(tmp_path, chain):
    """A set with text labels and extra columns is written (standard dialect) and read back unchanged."""
    data = cp.read_measurements(_real_copy(tmp_path / "real.csv"), chain)
    cp.write_measurements(tmp_path / "back.csv", data)
    text = (tmp_path / "back.csv").read_text()
    assert ";" not in text.split("pose,")[1]
    back = cp.read_measurements(tmp_path / "back.csv", chain)
    assert back.point_ids.tolist() == data.point_ids.tolist()
    np.testing.assert_allclose(back.positions, data.positions, atol=1e-12)
    assert back.extra["time"].tolist() == data.extra["time"].tolist()


def test_hand_made_sets_may_use_text_labels_but_not_mixed(chain, params, position_session):
    """A MeasurementSet built in memory with text labels calibrates; numbers mixed with text are refused."""
    data, _ = position_session
    text = dataclasses.replace(data, point_ids=np.array([f"P{v}" for v in data.point_ids], dtype=object))
    result = cp.calibrate("irb120", text, method="lm")
    assert result.sensor.labels == ("P1", "P2", "P3")
    mixed = dataclasses.replace(data, point_ids=np.array([v if v < 3 else "P3" for v in data.point_ids], dtype=object))
    with pytest.raises(cp.DataError, match=r"point_id: mixes whole numbers \(1\) and text labels \(P3\)"):
        cp.calibrate("irb120", mixed, method="lm")


def test_too_few_positions_for_the_device_are_refused_before_the_fit(chain, params):
    """One pose of 3 markers (9 values) cannot fit a device frame and 3 markers (15
    unknowns): refused naming the file (scipy's 'lm' raised ValueError)."""
    data, _ = cp.simulate_positions(chain, params, 2, seed=1)
    with pytest.raises(cp.DataError, match=r"t\.csv: 3 training rows give 9 values, fewer than the 15 set-up unknowns "
                                           r"\(the device frame and 3 marker\(s\)\)"):
        fit_device(chain, params, data.q[:3], data.positions[:3], data.point_ids[:3] - 1, (1, 2, 3), "t.csv")

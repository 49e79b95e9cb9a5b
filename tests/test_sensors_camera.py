"""A camera and a board: the lens, the Jacobian, the start, simulated sets calibrated from their CSV."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.calibration.holdout import Fraction, TestSet
from calib_pin.calibration.sets import FitSet
from calib_pin.estimators import get_method, run_method
from calib_pin.measurements import write_measurements
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import Board, CameraModel, CameraRig, CameraSetup, Intrinsics
from calib_pin.sensors.camera_view import seen
from calib_pin.sensors.lens import project
from calib_pin.simulation import simulate_sessions, simulate_set

cv2 = pytest.importorskip("cv2")

LENS = Intrinsics(1000.0, 990.0, 640.0, 512.0, 1280, 1024, -0.05, 0.01, 0.001, -0.0005, 0.002)


def _session(robot: str, mount: str, seed: int = 1, n: int = 40, noise_px: float = 0.1):
    chain = cp.load_chain(robot)
    params = cp.parameter_model(chain)
    data, truth = simulate_set(CameraModel, chain, params, n, seed, setup={"camera_mount": mount, "noise_px": noise_px})
    return chain, params, data, truth


def _fresh(chain, truth, n: int = 150, seed: int = 99) -> np.ndarray:
    """Fresh poses that see the board."""
    true_model = truth.model(chain, cp.parameter_model(chain))
    q = random_poses(chain, 40 * n, np.random.default_rng(seed))
    return q[seen(true_model, truth.x_model, q).sum(axis=1) >= 12][:n]


def _camera_to_board(model, x, q) -> list[pin.SE3]:
    """T_CW at each pose: the camera's pose relative to the board (what the images see)."""
    rig = model.geometry_at(x)
    rot, origin = model.end_frames(x, q)
    ends = [pin.SE3(r, p) for r, p in zip(rot, origin, strict=True)]
    if rig.in_hand:
        return [rig.camera.inverse() * e.inverse() * rig.board_pose for e in ends]
    return [rig.camera.inverse() * e * rig.board_pose for e in ends]


def _pose_rms(a: list[pin.SE3], b: list[pin.SE3]) -> tuple[float, float]:
    """RMS translation [mm] and rotation [deg] between two lists of placements."""
    t = np.sqrt(np.mean([np.sum((x.translation - y.translation) ** 2) for x, y in zip(a, b, strict=True)])) * 1e3
    r = np.sqrt(np.mean([np.sum(pin.log3(x.rotation.T @ y.rotation) ** 2) for x, y in zip(a, b, strict=True)]))
    return float(t), float(np.rad2deg(r))


def _gauge_free(model, x, q, true_points) -> float:
    """RMS [mm] of the flange origin after the best rigid motion of the base and the best point of the end frame.

    What the images can tell of the robot: they see the flange only through the placement
    of the camera (or the board) on it, and the base only through the other placement.
    """
    rot, origin = model.end_frames(x, q)
    b = np.zeros(3)
    for _ in range(50):
        points = origin + rot @ b
        ca, cb = points.mean(axis=0), true_points.mean(axis=0)
        u, _, vt = np.linalg.svd((points - ca).T @ (true_points - cb))
        a = vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))]) @ u.T
        shift = cb - a @ ca
        b = np.linalg.lstsq(np.einsum("ij,njk->nik", a, rot).reshape(-1, 3),
                            (true_points - shift - origin @ a.T).reshape(-1), rcond=None)[0]
    points = (origin + rot @ b) @ a.T + shift
    return float(np.sqrt(np.mean(np.sum((points - true_points) ** 2, axis=1))) * 1e3)


def test_projection_is_opencvs_and_its_derivatives_are_exact():
    """The pinhole and plumb-bob projection equals cv2.projectPoints; its derivatives central differences."""
    rng = np.random.default_rng(0)
    points = rng.normal(size=(20, 3)) * 0.1 + [0.0, 0.0, 0.6]
    uv, d_point, d_lens = LENS.project(points, jacobian=True)
    opencv = cv2.projectPoints(points, np.zeros(3), np.zeros(3), LENS.matrix(), LENS.distortion())[0].reshape(-1, 2)
    np.testing.assert_allclose(uv, opencv, atol=1e-9)
    h = 1e-7
    fd = np.stack([(LENS.project(points + h * e)[0] - LENS.project(points - h * e)[0]) / (2 * h) for e in np.eye(3)], -1)
    np.testing.assert_allclose(d_point, fd, rtol=1e-6, atol=1e-3)
    k = LENS.vector()
    fd = np.stack([(project(k + h * e, points)[0] - project(k - h * e, points)[0]) / (2 * h) for e in np.eye(9)], -1)
    np.testing.assert_allclose(d_lens, fd, atol=1e-5)


def test_board_corners_are_numbered_as_opencvs_charuco_board():
    """Corner id = row * (columns - 1) + column at ((column + 1) s, (row + 1) s, 0)."""
    board = Board(9, 7, 30.0, 22.0)
    assert board.n_corners == 48
    np.testing.assert_allclose(board.points[[0, 1, 8]], [[0.03, 0.03, 0], [0.06, 0.03, 0], [0.03, 0.06, 0]])
    charuco = cv2.aruco.CharucoBoard((9, 7), 0.03, 0.022, cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_5X5_100))
    np.testing.assert_allclose(charuco.getChessboardCorners(), board.points, atol=1e-9)


@pytest.mark.parametrize("mount", ["eye-in-hand", "eye-to-hand"])
@pytest.mark.parametrize("name", ["dh", "placement"])
def test_camera_jacobian_matches_finite_differences(mount, name):
    """Robot, camera, board and intrinsics columns of the analytic Jacobian equal central differences."""
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain, name)
    rng = np.random.default_rng(0)
    q = np.repeat(random_poses(chain, 3, rng), 4, axis=0)
    corners = np.tile([0, 5, 20, 47], 3)
    probe = CameraModel(chain, params, CameraRig(mount, pin.SE3.Identity(), pin.SE3.Identity(), Board(9, 7, 30, 22),
                                                 LENS), ())
    rot, origin = probe.end_frames(None, q[:1])
    end = pin.SE3(rot[0], origin[0])
    if mount == "eye-in-hand":
        camera = pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.array([0.05, 0.02, 0.1]))
        board = end * camera * pin.SE3(pin.rpy.rpyToMatrix(0.2, 0.1, 0.0), np.array([-0.1, -0.1, 0.5]))
    else:
        board = pin.SE3(pin.rpy.rpyToMatrix(3.0, 0.1, 0.2), np.array([0.05, 0.02, 0.05]))
        placed = end * board
        camera = pin.SE3(placed.rotation, placed.translation - placed.rotation @ np.array([0.0, 0.0, 0.6]))
    model = CameraModel(chain, params, CameraRig(mount, camera, board, Board(9, 7, 30, 22), LENS),
                        ("camera", "board", "intrinsics"))
    x = rng.normal(size=model.n_params) * model.scale
    _, jac = model.predict_with_jacobian(x, q, corners)
    h = 1e-6
    fd = np.stack([(model.predict(x + h * s * e, q, corners) - model.predict(x - h * s * e, q, corners)) / (2 * h * s)
                   for e, s in zip(np.eye(model.n_params), model.scale, strict=True)], axis=-1)
    np.testing.assert_allclose(jac, fd, rtol=1e-5, atol=1e-7 * np.abs(jac).max())


@pytest.mark.parametrize(("robot", "mount"), [("irb120", "eye-in-hand"), ("irb120", "eye-to-hand"),
                                              ("ur5", "eye-in-hand"), ("ur5", "eye-to-hand")])
def test_a_simulated_camera_set_calibrates_from_its_csv(tmp_path, robot, mount):
    """40 poses at 0.1 px: held-out reprojection within 0.12 px per coordinate; the robot as good as an LM fit
    started from the true model (gauge-free, at the flange origin); the camera's pose relative to the board at
    fresh poses within 0.05 mm and 0.01 deg RMS of the truth."""
    chain, params, data, truth = _session(robot, mount)
    path = tmp_path / "camera.csv"
    write_measurements(path, data)
    result = cp.solve(cp.prepare(robot, path), "lm", holdout=Fraction(0.25), seed=0)
    assert result.sets[0].unit == "px"
    per_coordinate = result.metrics["test"]["after"].rmse_mm / np.sqrt(2)
    assert 0.08 < per_coordinate < 0.12 < result.metrics["test"]["before"].rmse_mm
    # the oracle: Levenberg-Marquardt from the true robot and placements, on the same training rows
    model = result.problem.model.one
    training = result.problem.subset(result.train)

    def correction(start: pin.SE3, true: pin.SE3) -> np.ndarray:
        return np.concatenate([true.translation - start.translation, pin.log3(start.rotation.T @ true.rotation)])

    x_true = np.concatenate([truth.x, correction(model.rig.camera, truth.sensor.camera),
                             correction(model.rig.board_pose, truth.sensor.board_pose)])
    oracle = run_method(get_method("lm"), training, x_true, seed=0, noise=1e-4, loss="linear").x
    fresh = _fresh(chain, truth)
    true_model = truth.model(chain, params)
    flange = true_model.points_at(truth.x_model, fresh, np.zeros(3))
    assert _gauge_free(model, result.x, fresh, flange) <= 1.2 * _gauge_free(model, oracle, fresh, flange)
    assert _gauge_free(model, result.x, fresh, flange) < 0.1 * _gauge_free(model, np.zeros(model.n_params), fresh,
                                                                            flange)
    mm, deg = _pose_rms(_camera_to_board(model, result.x, fresh), _camera_to_board(true_model, truth.x_model, fresh))
    assert mm < 0.05 and deg < 0.01


def test_the_intrinsics_are_calibrated_in_the_same_fit():
    """Intrinsics given 8 px off are estimated with the robot: each within 3.5 of its standard deviations."""
    chain, params, data, truth = _session("irb120", "eye-in-hand", seed=3)
    k = truth.sensor.intrinsics
    wrong = dataclasses.replace(k, fx=k.fx + 8, fy=k.fy - 6, cx=k.cx + 4, k1=k.k1 + 0.01)
    result = cp.calibrate("irb120", data, method="lm", setup=CameraSetup(intrinsics=wrong, estimate="intrinsics"))
    assert result.metrics["test"]["after"].rmse_mm / np.sqrt(2) < 0.12
    names = result.problem.model.names
    for name in ("fx", "fy", "cx", "cy", "k1", "k2"):
        error = getattr(result.sensor.intrinsics, name) - getattr(k, name)
        assert abs(error) < 3.5 * result.uncertainty.std[names.index(name)], name
    assert "fx_px" in result.sensor_corrections and "k1" in result.sensor_corrections


def test_a_camera_set_and_a_cable_set_beat_each_alone():
    """One robot's camera set (eye in hand) and drawstring set fitted together predict fresh poses better than
    either alone: each sensor's own predictions against the truth."""
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    sets, truth = simulate_sessions(chain, params, [40, 60], 5, kinds=["camera", "cable"],
                                    setup={"camera_mount": "eye-in-hand", "noise_px": 0.1})
    camera, cable = truth.session(0), truth.session(1)
    fresh = _fresh(chain, camera)
    rows, corners = np.nonzero(seen(camera.model(chain, params), camera.x_model, fresh))  # the corners it sees
    true_px = camera.model(chain, params).predict(camera.x_model, fresh[rows], corners)
    true_mm = cable.model(chain, params).predict(cable.x_model, fresh)

    def px(s) -> float:
        return float(np.sqrt(np.mean((s.model.predict(s.x, fresh[rows], corners) - true_px) ** 2)))

    def mm(s) -> float:
        return float(np.sqrt(np.mean((s.model.predict(s.x, fresh) - true_mm) ** 2)))

    both = cp.calibrate("irb120", [FitSet(sets[0], "cam"), FitSet(sets[1], "cab")], method="lm")
    assert px(both.sets[0]) < px(cp.calibrate("irb120", sets[0], method="lm").sets[0])
    assert mm(both.sets[1]) < mm(cp.calibrate("irb120", sets[1], method="lm").sets[0])


@pytest.mark.parametrize("mount", ["eye-in-hand", "eye-to-hand"])
def test_a_moved_session_is_re_registered_or_refused(mount):
    """A second session with the cell-side part moved: re-registered on 8 poses it scores at the noise; scored
    as the same set-up it is refused, naming the move."""
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    sets, _ = simulate_sessions(chain, params, 40, 3, kinds=["camera", "camera"],
                                setup={"camera_mount": mount, "noise_px": 0.1})
    result = cp.calibrate("irb120", sets[0], method="lm", test_data=TestSet(sets[1], register=8))
    assert result.metrics["test"]["after"].rmse_mm < 0.17 < 1.0 < result.metrics["test"]["before"].rmse_mm
    moved = "board" if mount == "eye-in-hand" else "camera"
    assert result.test_registration["fitted"] == [f"{moved}_{a}" for a in ("x", "y", "z", "rx", "ry", "rz")]
    with pytest.raises(cp.DataError, match="moved between the sessions"):
        cp.calibrate("irb120", sets[0], method="lm", test_data=TestSet(sets[1]))


def test_the_gauge_leaves_the_last_link_nominal_and_the_camera_takes_the_rest():
    """The camera data cannot see the last link's placement apart from the camera's: the calibration keeps
    a_6, d_6, alpha_6, theta_6 at zero, says so, and the camera's placement carries the rest."""
    chain, params, data, truth = _session("irb120", "eye-in-hand")
    result = cp.calibrate("irb120", data, method="lm")
    names = result.problem.model.names
    for name in ("a_6", "d_6", "alpha_6", "theta_6"):
        assert abs(result.x[names.index(name)]) < 1e-9, name
    assert "last link" in result.sets[0].geometry["gauge_note"]
    assert result.sets[0].model.measured_points(result.x)[0][0] == "camera centre"


def test_a_camera_setup_is_read_from_the_file_and_the_flags(tmp_path):
    """The simulated file states the set-up; a flag overrides it; without intrinsics it is one line."""
    chain, params, data, truth = _session("irb120", "eye-to-hand", n=12)
    path = tmp_path / "c.csv"
    write_measurements(path, data)
    read = cp.read_measurements(path)
    assert read.kind == "camera" and read.values.shape == (len(data), 2) and read.point_ids.dtype.kind == "i"
    filed = CameraModel.setup_of(read)
    assert filed.camera_mount == "eye-to-hand" and filed.board == truth.sensor.board
    assert filed.intrinsics == truth.sensor.intrinsics and filed.noise_px == 0.1
    lines = [line for line in path.read_text().splitlines() if not line.startswith("# camera_") or "mount" in line]
    (tmp_path / "bare.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(cp.DataError, match="no camera intrinsics: .*--intrinsics"):
        cp.calibrate("irb120", tmp_path / "bare.csv", method="lm")
    result = cp.calibrate("irb120", tmp_path / "bare.csv", method="lm",
                          setup=CameraSetup(intrinsics=truth.sensor.intrinsics.spec()))
    assert result.metrics["test"]["after"].rmse_mm < 0.5 < result.metrics["test"]["before"].rmse_mm


def test_a_pose_of_fewer_than_four_corners_is_dropped_with_a_note():
    """Its rows are left out when the set is loaded, and the result's warnings name the pose."""
    chain, params, data, truth = _session("irb120", "eye-in-hand", n=20)
    rows = np.flatnonzero(data.pose_ids == data.pose_ids[0])
    keep = np.setdiff1d(np.arange(len(data)), rows[3:])
    result = cp.calibrate("irb120", data.subset(keep), method="lm")
    assert any(f"pose(s) dropped, fewer than 4 corners (pose (corners)): {data.pose_ids[0]} (3)" in w
               for w in result.warnings)
    assert len(result.sets[0].problem.q) == len(keep) - 3


def test_simulate_and_calibrate_a_camera_set_from_the_command_line(tmp_path, capsys):
    """simulate --kinds camera writes a set and its truth; calibrate prints px and the gauge note."""
    from calib_pin.cli.calibrate import calibrate_main
    from calib_pin.cli.simulate import simulate_main

    out = tmp_path / "cam.csv"
    assert simulate_main(["irb120", "--kinds", "camera", "--camera-mount", "eye-to-hand", "--poses", "20",
                          "--noise-px", "0.2", "--seed", "2", "--out", str(out)]) == 0
    assert "noise 0.2 px" in capsys.readouterr().out
    assert Path(str(out).replace(".csv", ".truth.json")).is_file()
    assert calibrate_main(["irb120", "--data", str(out), "--method", "lm", "--no-html", "--out",
                           str(tmp_path / "o")]) == 0
    printed = capsys.readouterr().out
    assert "RMSE px" in printed and "reprojection 0.2 px (file)" in printed and "last link" in printed
    assert calibrate_main(["irb120", "--data", str(out), "--noise-px", "0.3", "--method", "lm", "--no-html", "--out",
                           str(tmp_path / "o2")]) == 0
    assert "reprojection 0.3 px (caller)" in capsys.readouterr().out
    result = cp.calibrate("irb120", out, method="lm", setup=CameraSetup(noise_px=0.3))
    assert result.sets[0].sigma == pytest.approx(0.3e-3) and result.sets[0].sigma_origin == "caller"


def test_without_opencv_a_camera_set_is_one_line_with_the_install_hint(monkeypatch):
    """OpenCV missing: the camera set is refused with the pip command of the camera extra."""
    chain, params, data, truth = _session("irb120", "eye-in-hand", n=12)
    monkeypatch.setitem(__import__("sys").modules, "cv2", None)
    with pytest.raises(cp.CalibPinError, match=r"opencv-python-headless': pip install 'calib-pin\[camera\]'"):
        cp.calibrate("irb120", data, method="lm")


def test_analyze_names_the_hand_eye_gauge(capsys):
    """--analyze of the shipped camera example lists the last link with the camera's placement."""
    from calib_pin.cli.calibrate import calibrate_main

    example = Path(__file__).resolve().parents[1] / "robots" / "irb120_camera_example.csv"
    assert calibrate_main(["irb120", "--data", str(example), "--analyze"]) == 0
    printed = capsys.readouterr().out
    assert "a_6 +1 mm with camera_x -1 mm" in printed and "px noise" in printed

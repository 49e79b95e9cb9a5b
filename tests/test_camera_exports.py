"""A camera calibration's exports: the camera and board frames in the URDF, the hand-eye YAML, the lens written back."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest
import yaml

import calib_pin as cp
from calib_pin.calibration.sets import FitSet
from calib_pin.cli.calibrate import calibrate_main
from calib_pin.export.hand_eye import placement_of
from calib_pin.measurements import write_measurements
from calib_pin.report.bundle import write_outputs
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import CameraModel, Intrinsics
from calib_pin.sensors.lens_file import intrinsics_text, read_intrinsics
from calib_pin.simulation import simulate_sessions, simulate_set

pytest.importorskip("cv2")


def _simulated(robot: str, mount: str, n: int = 16, seed: int = 2):
    chain = cp.load_chain(robot)
    return simulate_set(CameraModel, chain, cp.parameter_model(chain), n, seed,
                        setup={"camera_mount": mount, "noise_px": 0.1})


def _same(a: pin.SE3, b: pin.SE3) -> None:
    np.testing.assert_allclose(a.translation, b.translation, atol=1e-9)
    np.testing.assert_allclose(a.rotation, b.rotation, atol=1e-9)


@pytest.mark.parametrize(("robot", "mount"), [("irb120", "eye-in-hand"), ("ur5", "eye-to-hand")])
def test_the_calibrated_urdf_holds_the_camera_and_board_where_the_model_has_them(tmp_path, robot, mount):
    """The calibrated URDF loads in Pinocchio; its camera and board frames at any q are the calibrated model's
    (the camera on the end frame and the board on the base eye in hand, the other way round eye to hand)."""
    data, _ = _simulated(robot, mount)
    result = cp.calibrate(robot, data, method="lm")
    write_outputs(result, tmp_path, html=False)
    urdf = pin.buildModelFromUrdf(str(tmp_path / f"{robot}_calibrated.urdf"))
    frames = urdf.createData()
    s = result.sets[0]
    rig = s.model.geometry_at(s.x)
    q = random_poses(result.chain, 5, np.random.default_rng(0))
    rot, origin = s.model.end_frames(s.x, q)
    for k in range(len(q)):
        pin.framesForwardKinematics(urdf, frames, q[k])
        end = pin.SE3(rot[k], origin[k])
        camera, board = (end * rig.camera, rig.board_pose) if rig.in_hand else (rig.camera, end * rig.board_pose)
        _same(frames.oMf[urdf.getFrameId("camera_optical_frame")], camera)
        _same(frames.oMf[urdf.getFrameId("calibration_board")], board)


def test_the_hand_eye_yaml_is_easy_handeyes_layout_with_the_gauge(tmp_path, capsys):
    """calibrate writes <robot>_hand_eye.yaml, lists it, and it holds the calibrated camera (T_EC) and board (T_BW)
    in the frames the URDF names, easy_handeye's parameters and transformation, and the gauge note."""
    data, _ = _simulated("irb120", "eye-in-hand")
    write_measurements(tmp_path / "cam.csv", data)
    assert calibrate_main(["irb120", "--data", str(tmp_path / "cam.csv"), "--method", "lm", "--no-html",
                           "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    path = tmp_path / "out" / "irb120_hand_eye.yaml"
    assert f"wrote {path}" in out and "gauge: the camera (T_EC) placement shares a gauge" in out
    text = path.read_text()
    assert "# gauge: the camera (T_EC) placement shares a gauge with the last link's deviations" in text
    doc = yaml.safe_load(text)
    assert doc["camera_mount"] == "eye-in-hand" and doc["parent_frame"] == "tool0"
    assert doc["parameters"] == {"namespace": "irb120_eye_on_hand", "move_group_namespace": "/",
                                 "move_group": "manipulator", "eye_on_hand": True, "robot_base_frame": "base_link",
                                 "robot_effector_frame": "tool0", "tracking_base_frame": "camera_optical_frame",
                                 "tracking_marker_frame": "calibration_board"}
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    camera, board = report["sets"][0]["camera_frame"], report["sets"][0]["board_frame"]
    he, placed = placement_of(doc["transformation"]), placement_of(doc["board"]["transformation"])
    np.testing.assert_allclose(he.translation * 1e3, camera["translation_mm"], atol=1e-9)
    np.testing.assert_allclose(np.rad2deg(pin.rpy.matrixToRpy(he.rotation)), camera["rpy_deg"], atol=1e-9)
    np.testing.assert_allclose(placed.translation * 1e3, board["translation_mm"], atol=1e-9)
    assert abs(np.linalg.norm([doc["transformation"][k] for k in ("qx", "qy", "qz", "qw")]) - 1) < 1e-12
    assert report["exports"]["hand_eye"] == str(path)


def test_several_camera_sets_name_their_frames_and_files_by_label(tmp_path):
    """Two camera sets of one robot: each its own frames in the URDF and its own hand-eye file; a later run of
    another sensor into the folder removes them (an earlier run's stale outputs)."""
    chain = cp.load_chain("irb120")
    sets, _ = simulate_sessions(chain, cp.parameter_model(chain), 14, 3, kinds=["camera", "camera"],
                                setup={"camera_mount": "eye-in-hand", "noise_px": 0.1})
    result = cp.calibrate("irb120", [FitSet(sets[0], "a"), FitSet(sets[1], "b")], method="lm")
    done = write_outputs(result, tmp_path, html=False)
    names = sorted(p.name for p in done.files)
    assert "irb120_a_hand_eye.yaml" in names and "irb120_b_hand_eye.yaml" in names
    urdf = (tmp_path / "irb120_calibrated.urdf").read_text()
    assert all(f'<link name="{n}"/>' in urdf for n in ("camera_optical_frame_a", "calibration_board_b"))
    cable, _ = simulate_set(cp.sensors.CableModel, chain, cp.parameter_model(chain), 30, 1)
    again = write_outputs(cp.calibrate("irb120", cable, method="lm"), tmp_path, html=False)
    assert {p.name for p in again.removed} >= {"irb120_a_hand_eye.yaml", "irb120_b_hand_eye.yaml"}
@pytest.fixture(scope="module")
def camera_csv(tmp_path_factory):
    """A simulated eye-in-hand camera set of 16 poses, its file with the true intrinsics in its notes."""
    chain = cp.load_chain("irb120")
    data, truth = simulate_set(CameraModel, chain, cp.parameter_model(chain), 16, 2,
                               setup={"camera_mount": "eye-in-hand", "noise_px": 0.1})
    path = tmp_path_factory.mktemp("cam") / "cam.csv"
    write_measurements(path, data)
    return path, truth


@pytest.mark.parametrize(("layout", "per_set"), [("opencv", False), ("ros", True), (None, False)])
def test_calibrated_intrinsics_are_written_back_in_the_users_layout(tmp_path, capsys, camera_csv, layout, per_set):
    """--intrinsics FILE.yaml (or --data cam.csv:intrinsics=FILE.yaml) with --estimate intrinsics: the calibrated
    intrinsics go out in the layout given (ROS's camera_info when none was given), listed in the printout,
    each nearer the truth than the start."""
    path, truth = camera_csv
    k = truth.sensor.intrinsics
    start = Intrinsics(k.fx + 6, k.fy - 4, k.cx + 3, k.cy, k.width, k.height, k.k1, k.k2, k.p1, k.p2, k.k3)
    argv = ["irb120", "--method", "lm", "--estimate", "intrinsics", "--no-html", "--out", str(tmp_path / "out")]
    if layout is None:
        argv += ["--data", str(path), "--intrinsics", start.spec()]
    else:
        lens = tmp_path / "lens.yaml"
        lens.write_text(intrinsics_text(start, layout, "wrist_camera"))
        argv += ["--data", f"{path}:intrinsics={lens}"] if per_set else ["--data", str(path), "--intrinsics", str(lens)]
    assert calibrate_main(argv) == 0
    written = tmp_path / "out" / "irb120_intrinsics.yaml"
    assert f"wrote {written}" in capsys.readouterr().out
    back = read_intrinsics(written)
    assert back.source.format == (layout or "ros")
    for name in ("fx", "fy", "cx"):
        assert abs(getattr(back, name) - getattr(k, name)) < abs(getattr(start, name) - getattr(k, name)), name
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["exports"]["intrinsics"] == str(written)


def test_without_estimating_the_intrinsics_no_lens_file_is_written(tmp_path, camera_csv):
    """The intrinsics given and kept: nothing to write back (the hand-eye file is written)."""
    path, _ = camera_csv
    assert calibrate_main(["irb120", "--data", str(path), "--method", "lm", "--no-html", "--out", str(tmp_path)]) == 0
    assert not (tmp_path / "irb120_intrinsics.yaml").exists() and (tmp_path / "irb120_hand_eye.yaml").is_file()


def test_a_urdf_that_has_the_frames_gets_them_placed_anew(tmp_path):
    """A URDF an earlier calibration wrote (its camera frame on the same fixed joint) gets the frame placed anew,
    not twice; a frame named as another link of the URDF is refused, naming it."""
    from calib_pin.export.urdf import AddedFrame, calibrated_urdf

    chain = cp.load_chain("irb120")
    zero = cp.parameter_model(chain).deltas(np.zeros(len(cp.parameter_model(chain).names)))
    first = AddedFrame("camera_optical_frame", "end", pin.SE3(np.eye(3), np.array([0.1, 0.0, 0.0])))
    (tmp_path / "a.urdf").write_bytes(calibrated_urdf(chain, zero, frames=[first]))
    again = cp.load_chain(str(tmp_path / "a.urdf"))
    moved = AddedFrame("camera_optical_frame", "end", pin.SE3(np.eye(3), np.array([0.2, 0.0, 0.0])))
    text = calibrated_urdf(again, zero, frames=[moved]).decode()
    assert text.count('<link name="camera_optical_frame"/>') == 1 and 'xyz="0.2 0 0"' in text
    with pytest.raises(cp.RobotError, match="already has a link or joint 'link_1'"):
        calibrated_urdf(chain, zero, frames=[AddedFrame("link_1", "base", pin.SE3.Identity())])

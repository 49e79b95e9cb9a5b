"""A camera set from images: simulate --images, detect, calibrate; a chessboard's numbering; images left out."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.cli import command
from calib_pin.measurements.csv_writer import write_poses
from calib_pin.measurements.pose_list import read_pose_list
from calib_pin.sensors import Board, CameraModel
from calib_pin.sensors.camera_detect import (
    detect_images,
    find_corners,
    grown_quads,
    marker_widths,
    orient_chessboards,
    refine_clear_of_markers,
)
from calib_pin.sensors.camera_render import opencv_board, pixel_rays, render_image, render_images
from calib_pin.sensors.camera_view import default_board, default_intrinsics
from calib_pin.simulation import simulate_set

cv2 = pytest.importorskip("cv2")

ROOT = Path(__file__).resolve().parent.parent
LENS = "1000,1000,642,509,1280,1024,-0.08,0.05,0.0005,-0.0003,0"


def _images(folder: Path, board: Board | None = None, n: int = 6, seed: int = 3, mount: str = "eye-in-hand"):
    """``n`` rendered images of a simulated set and their joints file in ``folder``; the truth and its model."""
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    setup = {"camera_mount": mount, "noise_px": 0.0, **({"board": board} if board else {})}
    data, truth = simulate_set(CameraModel, chain, params, n, seed, setup=setup)
    pose_ids, first = np.unique(data.pose_ids, return_index=True)
    q = data.q[first]
    model = truth.model(chain, params)
    folder.mkdir(parents=True, exist_ok=True)
    names = np.array([f"view {k}.png" for k in pose_ids])
    for name, image in zip(names, render_images(model, truth.x_model, q, np.random.default_rng(0)), strict=True):
        cv2.imwrite(str(folder / name), image)
    write_poses(folder / "joints.csv", q, robot="irb120", pose_ids=pose_ids, extra={"image": names})
    return chain, truth, model


def test_simulated_images_detected_calibrate_at_the_detection_noise(tmp_path, capsys):
    """simulate --images writes 40 images and joints.csv; detect writes the camera set; calibrate fits it to the
    detected corners' noise (held-out reprojection within 0.3 px per coordinate, 20 times below the start)."""
    assert command("simulate")(["irb120", "--kinds", "camera", "--poses", "40", "--noise-px", "0.1", "--seed", "1",
                                "--images", str(tmp_path / "img"), "--out", str(tmp_path / "cam.csv")]) == 0
    assert "wrote 40 images to" in capsys.readouterr().out
    assert len(list((tmp_path / "img").glob("pose_*.png"))) == 40
    assert command("detect")(["irb120", "--images", str(tmp_path / "img"), "--board", "charuco,9x7,30,22,DICT_5X5_100",
                              "--intrinsics", LENS, "--camera-mount", "eye-in-hand", "--out",
                              str(tmp_path / "det.csv")]) == 0
    out = capsys.readouterr().out
    assert "40 of 40 images used" in out and "ms an image (median)" in out
    detected = cp.read_measurements(tmp_path / "det.csv")
    assert detected.kind == "camera" and detected.notes["camera_mount"] == "eye-in-hand"
    result = cp.calibrate("irb120", tmp_path / "det.csv", method="lm")
    test = result.metrics["test"]
    assert test["after"].rmse_mm / np.sqrt(2) < 0.3 and test["after"].rmse_mm < test["before"].rmse_mm / 20


def test_a_chessboards_numbering_follows_the_robot(tmp_path):
    """A chessboard looks the same turned half a turn: each image's corner 0 is chosen by the robot's motion, so
    every image's corners are numbered alike (as the board frame numbers them, or all half a turn round: the
    board's placement takes that). The simulator keeps the poses that see the whole board: each image is used."""
    board = Board(8, 6, 30.0, None, "", "chessboard")
    chain, truth, model = _images(tmp_path, board, n=12, seed=4)
    poses = read_pose_list(tmp_path / "joints.csv", chain)
    data, outcomes = detect_images(poses, tmp_path, board, truth.sensor.intrinsics, None, chain)
    assert data is not None and all(o.reason is None for o in outcomes), [o.reason for o in outcomes]
    ids = np.asarray(data.point_ids, dtype=int)
    errors = [np.sqrt(np.mean((data.values - model.image_points(truth.x_model, data.q, k)) ** 2))
              for k in (ids, board.n_corners - 1 - ids)]
    assert min(errors) < 0.3 < max(errors)
    # OpenCV's numbering of some images half a turn round: the robot's motion turns them back
    poses_used = np.unique(data.pose_ids)
    found = [(ids[data.pose_ids == p], data.values[data.pose_ids == p]) for p in poses_used]
    q = [data.q[data.pose_ids == p][0] for p in poses_used]
    turned = [(board.n_corners - 1 - k, uv) if j % 2 else (k, uv) for j, (k, uv) in enumerate(found)]
    again = orient_chessboards(cv2, board, truth.sensor.intrinsics, chain, q, turned)
    assert all(np.array_equal(a[0], b[0]) for a, b in zip(again, found, strict=True))


def test_images_that_cannot_be_used_are_left_out_with_the_reason(tmp_path):
    """An unreadable file, a missing one, an image named twice, one of another size, a blank one: each left out
    with its reason, the others used."""
    chain, truth, _ = _images(tmp_path, n=6)
    poses = read_pose_list(tmp_path / "joints.csv", chain)
    names = list(poses.extra["image"])
    (tmp_path / names[0]).write_bytes(b"not an image")
    (tmp_path / names[1]).unlink()
    cv2.imwrite(str(tmp_path / names[3]), np.full((480, 640), 128, np.uint8))
    cv2.imwrite(str(tmp_path / names[4]), np.full((1024, 1280), 200, np.uint8))
    twice = dataclasses.replace(poses, extra={"image": np.array(names[:5] + [names[2]])})  # pose 6 names pose 3's
    data, outcomes = detect_images(twice, tmp_path, truth.sensor.board, truth.sensor.intrinsics, None, chain)
    reasons = [o.reason for o in outcomes]
    assert reasons[0] == "cannot be read as an image" and reasons[1] == "no such file"
    assert reasons[2] is None and "640x480 px, the lens's intrinsics are 1280x1024 px" in reasons[3]
    assert reasons[4].startswith("board not found") and reasons[5].startswith("already pose")
    assert data is not None and set(np.unique(data.pose_ids)) == {int(poses.pose_ids[2])}


def test_charuco_corners_refined_clear_of_the_markers_are_nearer_the_truth():
    """Rendered eye-to-hand images (the board on the flange, often seen steeply): the corners refined with the
    markers painted out are nearer the true projection than OpenCV's own, RMS and the worst; an image without
    markers keeps OpenCV's corners."""
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    data, truth = simulate_set(CameraModel, chain, params, 8, 2, setup={"camera_mount": "eye-to-hand", "noise_px": 0.0})
    model = truth.model(chain, params)
    board = truth.sensor.board
    q = data.q[np.unique(data.pose_ids, return_index=True)[1]]
    ours, opencv = [], []
    for qk, image in zip(q, render_images(model, truth.x_model, q, np.random.default_rng(0)), strict=True):
        corners, ids, _, _ = cv2.aruco.CharucoDetector(opencv_board(cv2, board)).detectBoard(image)
        ids = np.asarray(ids, dtype=int).reshape(-1)
        true = model.image_points(truth.x_model, np.repeat(qk[None], len(ids), axis=0), ids)
        opencv.append(np.asarray(corners, dtype=float).reshape(-1, 2) - true)
        found, uv = find_corners(cv2, image, board)
        assert np.array_equal(found, ids)
        ours.append(uv - true)
    ours_n, opencv_n = (np.linalg.norm(np.concatenate(e), axis=1) for e in (ours, opencv))
    assert np.sqrt(np.mean(ours_n**2)) < 0.5 * np.sqrt(np.mean(opencv_n**2))
    assert ours_n.max() < opencv_n.max()
    uv = np.array([[10.0, 20.0]])
    assert np.array_equal(refine_clear_of_markers(cv2, np.zeros((50, 50), np.uint8), uv, np.zeros((0, 4, 2)), board), uv)


def test_corners_of_a_board_seen_steeply_are_refined_within_its_narrow_squares():
    """A board tilted 70 deg from the camera's axis (its squares a third as wide one way): the corners refined
    clear of the markers are within half a pixel of the truth, OpenCV's own a few beyond."""
    board, lens = default_board(), default_intrinsics()
    rays, rng = pixel_rays(cv2, lens), np.random.default_rng(3)
    ours, opencv = [], []
    for _ in range(3):
        axis = np.append(rng.normal(size=2), 0.0)
        turn = pin.exp3(axis / np.linalg.norm(axis) * np.deg2rad(70.0)) @ pin.exp3(np.array([0, 0, rng.uniform(-3, 3)]))
        pose = pin.SE3(turn, np.array([0.0, 0.0, 0.6]) - turn @ board.centre)
        image = render_image(cv2, board, lens, pose, rays, rng)
        for clear, out in ((True, ours), (False, opencv)):
            ids, uv = find_corners(cv2, image, board, clear_of_markers=clear)
            true = cv2.projectPoints(board.points[ids], cv2.Rodrigues(turn)[0], pose.translation, lens.matrix(),
                                     lens.distortion())[0].reshape(-1, 2)
            out.append(np.linalg.norm(uv - true, axis=1))
    ours_n, opencv_n = np.concatenate(ours), np.concatenate(opencv)
    assert len(ours_n) >= 60 and ours_n.max() < 0.5 < opencv_n.max()
    assert np.sqrt(np.mean(ours_n**2)) < 0.5 * np.sqrt(np.mean(opencv_n**2))


def test_a_markers_narrowest_width_and_its_sides_moved_out():
    """A 10 x 4 parallelogram is 4 px wide across its long sides; a unit square's sides moved out by 1 px make
    a 3 px square about the same middle, whichever way its corners go round."""
    assert marker_widths(np.array([[[0, 0], [10, 0], [13, 4], [3, 4]]], dtype=float)) == pytest.approx([4.0])
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    grown = grown_quads(np.stack([square, square[::-1]]), np.array([1.0, 1.0]))
    assert np.allclose(grown[0], [[-1, -1], [2, -1], [2, 2], [-1, 2]])
    assert np.allclose(grown[1], [[-1, 2], [2, 2], [2, -1], [-1, -1]])

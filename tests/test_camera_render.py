"""Rendered images of a board: the lens's inverse, the printed face, corners where the model projects them."""

from __future__ import annotations

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.sensors import Board, CameraModel
from calib_pin.sensors.camera_detect import find_corners
from calib_pin.sensors.camera_render import board_texture, pixel_rays, render_images
from calib_pin.sensors.camera_view import default_intrinsics
from calib_pin.simulation import simulate_set

cv2 = pytest.importorskip("cv2")


def test_pixel_rays_are_the_lens_inverse():
    """Each pixel's ray projects back onto that pixel (OpenCV's plumb-bob model) to 1e-9 px."""
    lens = default_intrinsics()
    rays = pixel_rays(cv2, lens)
    assert rays.shape == (lens.height, lens.width, 2)
    points = np.concatenate([rays.reshape(-1, 2), np.ones((rays.size // 2, 1))], axis=1)
    grid = np.stack(np.meshgrid(np.arange(lens.width), np.arange(lens.height)), axis=-1).reshape(-1, 2)
    np.testing.assert_allclose(lens.project(points)[0], grid, atol=1e-9)


@pytest.mark.parametrize("board", [Board(9, 7, 30.0, 22.0), Board(8, 6, 25.0, None, "", "chessboard")])
def test_the_printed_face_has_its_corners_where_the_board_frame_puts_them(board):
    """A board's texture, searched by OpenCV, shows corner k at margin + point_k x scale (pixel centres at
    whole numbers), to a tenth of a pixel."""
    texture, margin = board_texture(cv2, board, 4.0)
    ids, uv = find_corners(cv2, texture, board)
    assert len(ids) == board.n_corners
    scale = (texture.shape[1] - 2 * margin) / (board.columns * board.square_mm)
    expected = margin + board.points[ids, :2] * 1e3 * scale - 0.5
    if board.kind == "chessboard" and np.linalg.norm(uv[0] - expected[0]) > 1:  # half a turn: the same board
        expected = expected[::-1]
    np.testing.assert_allclose(uv, expected, atol=0.1)


@pytest.mark.parametrize("mount", ["eye-in-hand", "eye-to-hand"])
def test_rendered_corners_are_found_where_the_true_model_projects_them(mount):
    """8 rendered images of a simulated set: the corners ChArUco detection finds lie at the true robot's and
    camera's projection, unbiased (mean below 0.01 px), 0.05 px RMS per coordinate or better, none 0.5 px off."""
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    data, truth = simulate_set(CameraModel, chain, params, 8, 2, setup={"camera_mount": mount, "noise_px": 0.0})
    model = truth.model(chain, params)
    q = data.q[np.unique(data.pose_ids, return_index=True)[1]]
    images = render_images(model, truth.x_model, q, np.random.default_rng(0))
    assert all(im.shape == (1024, 1280) and im.dtype == np.uint8 for im in images)
    errors = []
    for qk, image in zip(q, images, strict=True):
        ids, uv = find_corners(cv2, image, truth.sensor.board)
        errors.append(uv - model.image_points(truth.x_model, np.repeat(qk[None], len(ids), axis=0), ids))
    error = np.concatenate(errors)
    assert len(error) >= 100
    assert np.all(np.abs(error.mean(axis=0)) < 0.01)
    assert np.sqrt(np.mean(error**2)) < 0.05
    assert np.linalg.norm(error, axis=1).max() < 0.5


def test_rendering_is_seeded():
    """The same seed renders the same images; another seed other noise."""
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    data, truth = simulate_set(CameraModel, chain, params, 1, 2, setup={"noise_px": 0.0})
    model = truth.model(chain, params)
    one = render_images(model, truth.x_model, data.q[:1], np.random.default_rng(5))[0]
    assert np.array_equal(one, render_images(model, truth.x_model, data.q[:1], np.random.default_rng(5))[0])
    assert not np.array_equal(one, render_images(model, truth.x_model, data.q[:1], np.random.default_rng(6))[0])

"""Rendered camera images of a printed board: what a simulated camera would have taken, for the detection path.

:func:`render_images` draws, for each pose, the image the camera of a camera model takes of
its board (:mod:`.camera`): each pixel's ray through the lens (OpenCV's inverse of the
plumb-bob distortion) meets the board's plane, where the board's printed face
(:func:`board_texture`, OpenCV's own drawing of a ChArUco board, or a chessboard) is sampled;
off the board the image is a mid grey. Each pixel is the mean of :data:`SAMPLES` x
:data:`SAMPLES` points over its area, as a sensor's pixel integrates the light on it (a
point sample per pixel would snap the squares' edges to the pixel grid), on a board drawn at
about :data:`SUPERSAMPLE` times the image's own scale at its middle; then the image is
blurred (a Gaussian of ``blur_px``, the optics) and given Gaussian grey-level noise
(``noise_grey``, of 255), 8-bit.

So a corner's place in a rendered image is where the model projects it, to the detector's
accuracy: the images are the true robot's and camera's when the model is.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..util.optional import require
from .lens import OPENCV_EXTRA, Board, Intrinsics

#: The board is drawn at about this many times the image's scale at the board's middle.
SUPERSAMPLE = 4.0
#: A pixel is the mean of SAMPLES x SAMPLES points spread over its area (no aliased edges).
SAMPLES = 3
#: The white paper around the printed squares, in squares (each side).
MARGIN_SQUARES = 0.5
#: Grey level of the scene off the board (of 255).
BACKGROUND = 110
#: A rendered image's blur (Gaussian sigma) [px] and grey-level noise (sigma, of 255) by default.
BLUR_PX = 0.6
NOISE_GREY = 2.0


def aruco_dictionary(cv2: Any, board: Board) -> Any:
    """OpenCV's ArUco dictionary of a ChArUco board (``DICT_5X5_100``...)."""
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, board.dictionary))


def opencv_board(cv2: Any, board: Board) -> Any:
    """OpenCV's ``CharucoBoard`` of ``board`` (sizes in mm)."""
    return cv2.aruco.CharucoBoard((board.columns, board.rows), board.square_mm, board.marker_mm,
                                  aruco_dictionary(cv2, board))


def board_texture(cv2: Any, board: Board, px_per_mm: float) -> tuple[np.ndarray, float]:
    """The board's printed face at about ``px_per_mm``, 8-bit grey, and the width of its white margin [px].

    The squares' outer corner (the board frame's origin) lies at the margin's inner edge; x
    to the right, y down, as the board frame's (module :mod:`.lens`).
    """
    square = max(int(round(board.square_mm * px_per_mm)), 4)  # whole pixels: the texture's scale is exact
    margin = int(round(MARGIN_SQUARES * square))
    size = (board.columns * square + 2 * margin, board.rows * square + 2 * margin)
    if board.kind == "charuco":
        return opencv_board(cv2, board).generateImage(size, marginSize=margin, borderBits=1), float(margin)
    u = (np.arange(size[0]) + 0.5 - margin) / square
    v = (np.arange(size[1]) + 0.5 - margin) / square
    inside = ((u >= 0) & (u < board.columns))[None, :] & ((v >= 0) & (v < board.rows))[:, None]
    black = ((np.floor(u)[None, :] + np.floor(v)[:, None]) % 2 == 0) & inside
    return np.where(black, 0, 255).astype(np.uint8), float(margin)


def pixel_rays(cv2: Any, intrinsics: Intrinsics) -> np.ndarray:
    """Each pixel's ray in the camera frame, (x / z, y / z), shape (height, width, 2): the lens's inverse."""
    w, h = int(intrinsics.width), int(intrinsics.height)
    grid = np.stack(np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64)), axis=-1)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
    points, k, dist = grid.reshape(-1, 1, 2), intrinsics.matrix(), intrinsics.distortion()
    if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4
        rays = cv2.undistortPointsIter(points, k, dist, None, None, criteria)
    else:  # OpenCV 5: the same, its criteria a keyword of undistortPoints
        rays = cv2.undistortPoints(points, k, dist, R=None, P=None, criteria=criteria)
    return rays.reshape(h, w, 2)


def render_image(cv2: Any, board: Board, intrinsics: Intrinsics, board_in_camera: Any, rays: np.ndarray,
                 rng: np.random.Generator, blur_px: float = BLUR_PX, noise_grey: float = NOISE_GREY) -> np.ndarray:
    """The camera's 8-bit grey image of the board at T_CW ``board_in_camera`` (pin.SE3, [m]), (height, width).

    ``rays``: :func:`pixel_rays` of the intrinsics.
    """
    rot, t = board_in_camera.rotation, board_in_camera.translation * 1e3  # mm
    g = np.column_stack([rot[:, 0], rot[:, 1], t])  # (X, Y, 1) of the board [mm] -> the camera frame [mm]
    h, w = rays.shape[:2]
    ray = np.concatenate([rays, np.ones((h, w, 1))], axis=-1)
    plane = ray @ np.linalg.inv(g).T  # (X, Y, 1) / z
    ahead = plane[..., 2] > 1e-12
    scale = np.where(ahead, 1.0 / np.where(ahead, plane[..., 2], 1.0), 0.0)
    centre = board_in_camera.act(board.centre)
    px_per_mm = SUPERSAMPLE * intrinsics.fx / max(float(np.linalg.norm(centre)) * 1e3, 1.0)
    texture, margin = board_texture(cv2, board, float(np.clip(px_per_mm, 0.5, 40.0)))
    step = (texture.shape[1] - 2 * margin) / board.columns / board.square_mm  # the texture's px per mm
    map_u = np.where(ahead, margin + plane[..., 0] * scale * step - 0.5, np.nan)
    map_v = np.where(ahead, margin + plane[..., 1] * scale * step - 0.5, np.nan)
    # a pixel is the mean of SAMPLES x SAMPLES points over its area (the maps' local slopes move each point)
    slopes = [np.nan_to_num(np.gradient(m, axis=axis)).astype(np.float32) for m in (map_u, map_v) for axis in (1, 0)]
    map_u, map_v = (np.nan_to_num(m, nan=-1e6).astype(np.float32) for m in (map_u, map_v))
    offsets = (np.arange(SAMPLES, dtype=np.float32) + 0.5) / SAMPLES - 0.5
    total = np.zeros(map_u.shape, dtype=np.float32)
    for dx in offsets:
        for dy in offsets:
            total += cv2.remap(texture, map_u + dx * slopes[0] + dy * slopes[1], map_v + dx * slopes[2] + dy * slopes[3],
                               cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=BACKGROUND)
    image = total.astype(np.float64) / SAMPLES**2
    if blur_px > 0:
        image = cv2.GaussianBlur(image, (0, 0), blur_px)
    image += rng.normal(size=image.shape) * noise_grey
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def render_images(model: Any, x: np.ndarray | None, q: np.ndarray, rng: np.random.Generator,
                  blur_px: float = BLUR_PX, noise_grey: float = NOISE_GREY) -> list[np.ndarray]:
    """The images ``model``'s camera takes of its board at each pose of q [rad] with unknowns x (module docstring).

    Raises:
        CalibPinError: OpenCV is not installed (the line names the extra).
    """
    cv2 = require("cv2", OPENCV_EXTRA)
    rig = model.geometry_at(x)
    rays = pixel_rays(cv2, rig.intrinsics)
    return [render_image(cv2, rig.board, rig.intrinsics, t, rays, rng, blur_px, noise_grey)
            for t in model.camera_to_board(x, np.atleast_2d(q))]

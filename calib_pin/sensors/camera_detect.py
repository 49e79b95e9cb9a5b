"""A camera set from images: each pose's image, its board's corners found by OpenCV, one row per corner.

:func:`detect_images` takes a pose list whose ``image`` column names each pose's image and
finds the board's corners in each (:func:`find_corners`): a ChArUco board by OpenCV's
``CharucoDetector`` (the markers, then the corners between them), each corner refined again
with the markers painted out (:func:`refine_clear_of_markers`), a chessboard by
``findChessboardCornersSB`` (all its inner corners or none). An image that cannot be read,
is not of the lens's size, or shows fewer than :data:`~.camera_rig.MIN_CORNERS` corners is
left out, with the reason (:class:`ImageOutcome`); the usable ones make the set.

A chessboard looks the same turned half a turn, so which of its corners is corner 0 is
not in one image: each image's numbering is chosen so that its board pose (PnP) turns from
the first usable image's as the robot's end frame does (a rotation's angle is the same
whatever the hand-eye transform), which needs the lens (``intrinsics``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..exceptions import DataError
from ..util.optional import require
from .camera_rig import MIN_CORNERS, board_notes, intrinsics_notes
from .lens import OPENCV_EXTRA, Board, Intrinsics

if TYPE_CHECKING:
    from ..measurements import MeasurementSet
    from ..robot.chain import Chain

#: Image files a folder is searched for (lower case suffixes).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm")


@dataclass(frozen=True)
class ImageOutcome:
    """What detection made of one pose's image.

    Attributes:
        pose: The pose's id in the pose list.
        image: The image's name as the pose list gives it.
        corners: Corners found (0 when the image is left out).
        reason: Why the image is left out (None: used).
        seconds: Time to read and search the image [s].
    """

    pose: int
    image: str
    corners: int
    reason: str | None
    seconds: float


def find_corners(cv2: Any, gray: np.ndarray, board: Board, clear_of_markers: bool = True
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The board's corners found in an 8-bit grey image: their ids (k,) and places (k, 2) [px].

    OpenCV's pixel convention ((0, 0) the top-left pixel's centre); none found: empty arrays.
    A ChArUco board's corners are refined again clear of its markers (:func:`refine_clear_of_markers`;
    ``clear_of_markers`` False: OpenCV's own, for a comparison); a chessboard's are numbered as
    OpenCV returns them (see the module docstring).
    """
    if board.kind == "charuco":
        from .camera_render import opencv_board

        corners, ids, markers, _ = cv2.aruco.CharucoDetector(opencv_board(cv2, board)).detectBoard(gray)
        if ids is None or len(ids) == 0:
            return np.zeros(0, dtype=int), np.zeros((0, 2))
        uv = np.asarray(corners, dtype=float).reshape(-1, 2)
        quads = np.asarray(markers, dtype=float).reshape(-1, 4, 2)
        if clear_of_markers:
            uv = refine_clear_of_markers(cv2, gray, uv, quads, board)
        return np.asarray(ids, dtype=int).reshape(-1), uv
    pattern = (board.columns - 1, board.rows - 1)
    found, corners = cv2.findChessboardCornersSB(gray, pattern, flags=cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY)
    if not found:
        return np.zeros(0, dtype=int), np.zeros((0, 2))
    return np.arange(board.n_corners), np.asarray(corners, dtype=float).reshape(-1, 2)


#: The refinement window's half-size [px]: half the corner's square's narrowest width less 1, within these.
WINDOW_PX = (2, 10)
#: A painted-out marker's edges are moved out by this [px] (the blur of its border), at most PAINT_GAP of its white gap.
PAINT_PX, PAINT_GAP = 1.5, 0.4
def marker_widths(markers: np.ndarray) -> np.ndarray:
    """Each quadrilateral's narrowest width, across opposite sides, shape (m,) [px]; ``markers`` (m, 4, 2) [px].

    Each corner's distance from the line of the side opposite it (the side two corners on), the least.
    """
    edge = np.roll(markers, -1, axis=1) - markers
    normal = np.stack([-edge[..., 1], edge[..., 0]], axis=-1) / np.linalg.norm(edge, axis=-1, keepdims=True)
    return np.abs(np.einsum("mki,mki->mk", np.roll(markers, -2, axis=1) - markers, normal)).min(axis=1)


def grown_quads(markers: np.ndarray, by: np.ndarray) -> np.ndarray:
    """Convex quadrilaterals (m, 4, 2) [px] with each side moved out by ``by`` (m,) [px]."""
    edge = np.roll(markers, -1, axis=1) - markers  # side k: corner k to corner k + 1
    normal = np.stack([edge[..., 1], -edge[..., 0]], axis=-1) / np.linalg.norm(edge, axis=-1, keepdims=True)
    inward = np.einsum("mki,mki->mk", normal, markers.mean(axis=1, keepdims=True) - markers) > 0
    normal[inward] *= -1  # outward
    offset = np.einsum("mki,mki->mk", normal, markers) + by[:, None]  # side k's line: normal . p = offset
    lines = np.stack([np.roll(normal, 1, axis=1), normal], axis=2)  # corner k on sides k - 1 and k
    return np.linalg.solve(lines, np.stack([np.roll(offset, 1, axis=1), offset], axis=2)[..., None])[..., 0]


def refine_clear_of_markers(cv2: Any, gray: np.ndarray, uv: np.ndarray, markers: np.ndarray, board: Board
                            ) -> np.ndarray:
    """ChArUco corners (k, 2) [px] refined again with the found markers (m, 4, 2) [px] painted out.

    OpenCV refines a ChArUco corner in a window that stops short of its two markers' nearest
    corners only along its sides: the window reaches into the markers, and their black borders
    pull the corner, unequally when the board is seen steeply. Here each marker is filled with
    the white of the paper around it (the median of the image half-way across its white gap),
    its sides moved out by the blur (:data:`PAINT_PX`), so a corner's neighbourhood holds only
    the two lines of the squares' edges that cross at it; each corner is then refined by
    ``cornerSubPix`` in a window of half the narrowest width of its square in the image (its
    nearest marker's, scaled), less 1 px (:data:`WINDOW_PX`). A corner the refinement moves by
    more than half its window keeps OpenCV's place (the refinement gone astray).
    """
    marker_mm = board.marker_mm
    if not len(uv) or not len(markers) or marker_mm is None:
        return uv
    h, w = gray.shape[:2]
    image = gray.astype(np.float32)
    centre = markers.mean(axis=1, keepdims=True)
    # the white half-way across the gap: each corner moved out from the centre by half the gap (in proportion)
    ring = centre + (markers - centre) * (1 + 0.5 * (board.square_mm - marker_mm) / marker_mm)
    steps = np.linspace(0.0, 1.0, 8, endpoint=False)[None, None, :, None]
    points = (ring[:, :, None] + steps * (np.roll(ring, -1, axis=1) - ring)[:, :, None]).reshape(len(markers), -1, 2)
    cols = np.clip(np.rint(points[..., 0]).astype(int), 0, w - 1)
    rows = np.clip(np.rint(points[..., 1]).astype(int), 0, h - 1)
    white = np.median(image[rows, cols], axis=1)
    narrowest = marker_widths(markers)
    gap = (board.square_mm - marker_mm) / 2 / marker_mm * narrowest  # the narrowest white gap [px]
    for quad, level in zip(grown_quads(markers, np.minimum(PAINT_PX, PAINT_GAP * gap)), white, strict=True):
        cv2.fillConvexPoly(image, np.rint(quad * 16).astype(np.int32), float(level), shift=4)
    nearest = np.linalg.norm(uv[:, None] - markers.reshape(-1, 2)[None], axis=-1).argmin(axis=1) // 4
    square = narrowest[nearest] * board.square_mm / marker_mm  # the square's narrowest width [px]
    window = np.clip(np.floor(square / 2) - 1, *WINDOW_PX).astype(int)
    refined = uv.copy()
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
    for size in np.unique(window):
        at = np.flatnonzero(window == size)
        start = uv[at].astype(np.float32).reshape(-1, 1, 2)
        refined[at] = cv2.cornerSubPix(image, start.copy(), (int(size), int(size)), (-1, -1), criteria).reshape(-1, 2)
    astray = np.linalg.norm(refined - uv, axis=1) > window
    refined[astray] = uv[astray]
    return refined


def image_path(name: str, folder: Path) -> Path:
    """Where a pose list's image name points: itself when absolute, else within ``folder``."""
    path = Path(name)
    return path if path.is_absolute() else folder / path


def _read(cv2: Any, path: Path) -> np.ndarray | None:
    """The image at ``path`` in 8-bit grey, None when it cannot be read as an image."""
    if not path.is_file():
        return None
    raw = np.fromfile(str(path), dtype=np.uint8)  # imdecode: any file name, never a crash on bytes
    return cv2.imdecode(raw, cv2.IMREAD_GRAYSCALE) if raw.size else None


def _flipped(board: Board) -> np.ndarray:
    """A chessboard's corner ids read half a turn round: id k -> n - 1 - k."""
    return np.arange(board.n_corners)[::-1].copy()


def orient_chessboards(cv2: Any, board: Board, intrinsics: Intrinsics, chain: Chain, q: list[np.ndarray],
                        found: list[tuple[np.ndarray, np.ndarray]]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each image's chessboard numbering chosen to turn as the robot's end frame turns (module docstring)."""
    from ..robot.kinematics import Kinematics
    from .camera_fit import board_poses

    def pose_of(ids: np.ndarray, uv: np.ndarray) -> pin.SE3 | None:
        return board_poses(cv2, board, intrinsics, uv, ids, np.zeros(len(ids), dtype=int), 1)[0]

    ends = Kinematics(chain).frames(np.asarray(q))[0]  # the nominal end frame's rotations in the base
    first = pose_of(*found[0])
    if first is None:
        return found
    out = [found[0]]
    for end, (ids, uv) in zip(ends[1:], found[1:], strict=True):
        robot = np.linalg.norm(pin.log3(ends[0].T @ end))
        best, chosen = np.inf, (ids, uv)
        for numbering in (ids, _flipped(board)[ids]):
            seen = pose_of(numbering, uv)
            if seen is None:
                continue
            gap = float(abs(np.linalg.norm(pin.log3(first.rotation @ seen.rotation.T)) - robot))
            if gap < best:
                best, chosen = gap, (numbering, uv)
        out.append(chosen)
    return out


def detect_images(poses: MeasurementSet, folder: Path, board: Board, intrinsics: Intrinsics | None = None,
                  mount: str | None = None, chain: Chain | None = None,
                  progress: Callable[[ImageOutcome], None] | None = None
                  ) -> tuple[MeasurementSet | None, list[ImageOutcome]]:
    """A camera set of the corners found in each pose's image, and what became of each image.

    Args:
        poses: A pose list (:func:`~calib_pin.measurements.pose_list.read_pose_list`) with an ``image``
            column: each pose's image, relative to ``folder`` or absolute.
        folder: Where the images are.
        board: The printed board.
        intrinsics: The lens (its size is checked against each image's; it is written into
            the set's notes). Needed for a chessboard (its numbering, module docstring).
        mount: ``eye-in-hand`` or ``eye-to-hand``, written into the set's notes when given.
        chain: The robot (a chessboard's numbering).
        progress: Called with each image's outcome as it is done.

    Returns:
        The set (None when no image is usable) and one outcome per pose, in order.

    Raises:
        CalibPinError: OpenCV is not installed.
        DataError: the pose list has no ``image`` column, or names no image; a chessboard
            without the lens.
    """
    from ..measurements import MeasurementSet

    cv2 = require("cv2", OPENCV_EXTRA)
    source = poses.source or "the pose list"
    names = next((v for k, v in poses.extra.items() if k.strip().lower() == "image"), None)
    if names is None:
        raise DataError(source, "no 'image' column: name each pose's image file (relative to the images folder)",
                        None, "image")
    if board.kind == "chessboard" and (intrinsics is None or chain is None):
        raise DataError(source, "a chessboard's corner numbering needs the lens (--intrinsics): it looks the same "
                        "turned half a turn", None, "intrinsics")
    outcomes: list[ImageOutcome] = []
    kept: list[tuple[int, np.ndarray, tuple[np.ndarray, np.ndarray]]] = []
    owner: dict[Path, int] = {}  # each image's first pose
    pose_list = poses.pose_ids if poses.pose_ids is not None else np.arange(1, len(poses) + 1)
    for r, (pose, name) in enumerate(zip(pose_list, names, strict=True)):
        start = time.perf_counter()
        text = str(name).strip()
        reason = None
        path = image_path(text, folder).resolve() if text else None
        first = owner.setdefault(path, int(pose)) if path is not None else None
        gray = _read(cv2, path) if path is not None and first == int(pose) else None
        if path is None:
            reason = "no image named"
        elif first != int(pose):
            reason = f"already pose {first}'s image (one image cannot show two poses)"
        elif gray is None:
            reason = "no such file" if not path.is_file() else "cannot be read as an image"
        elif intrinsics is not None and (gray.shape[1], gray.shape[0]) != (intrinsics.width, intrinsics.height):
            reason = (f"{gray.shape[1]}x{gray.shape[0]} px, the lens's intrinsics are {intrinsics.width:g}x"
                      f"{intrinsics.height:g} px (another camera's or resolution's?)")
        ids, uv = find_corners(cv2, gray, board) if reason is None and gray is not None else \
            (np.zeros(0, dtype=int), np.zeros((0, 2)))
        if reason is None and len(ids) < MIN_CORNERS:
            reason = (f"board not found ({len(ids)} corners; {MIN_CORNERS} needed)" if len(ids) else
                      f"board not found ({board.describe()}; its size counts squares, not inner corners)")
        outcome = ImageOutcome(int(pose), text, 0 if reason else len(ids), reason, time.perf_counter() - start)
        outcomes.append(outcome)
        if reason is None:
            kept.append((r, poses.q[r], (ids, uv)))
        if progress is not None:
            progress(outcome)
    if not kept:
        return None, outcomes
    found = [k[2] for k in kept]
    if board.kind == "chessboard":
        assert intrinsics is not None and chain is not None
        found = orient_chessboards(cv2, board, intrinsics, chain, [k[1] for k in kept], found)
    q = np.concatenate([np.repeat(k[1][None, :], len(f[0]), axis=0) for k, f in zip(kept, found, strict=True)])
    pose_ids = np.concatenate([np.full(len(f[0]), pose_list[k[0]]) for k, f in zip(kept, found, strict=True)])
    notes, meta = board_notes(board)
    if intrinsics is not None:
        notes.update(intrinsics_notes(intrinsics))
    if mount is not None:
        notes["camera_mount"] = mount
    notes["source"] = f"calib-pin detect: {len(kept)} of {len(outcomes)} images of {folder}, {board.describe()}"
    data = MeasurementSet(q=q, values=np.concatenate([f[1] for f in found]), kind="camera", robot=poses.robot,
                          end_frame=poses.end_frame, pose_ids=pose_ids,
                          point_ids=np.concatenate([f[0] for f in found]), sensor_meta=meta, notes=notes)
    return data, outcomes

"""Where a camera's placements start: PnP of each image, then OpenCV's hand-eye solvers, then a polish.

:func:`fit_rig` takes the training rows of a camera set and the nominal robot:

1. each pose's board in the camera frame, T_CW, by ``cv2.solvePnP`` (IPPE, the planar
   solver, then its iterative refinement) from the corners and the intrinsics;
2. the camera's and the board's placements by OpenCV's robot-world hand-eye solver,
   ``cv2.calibrateRobotWorldHandEye`` (A X = Z B: T_CW T_WB = T_CE T_EB eye in hand,
   T_CW T_WE = T_CB T_BE eye to hand), with the classic hand-eye solver
   ``cv2.calibrateHandEye`` (A X = X B) and the mean of the other placement as the
   fallback when it fails or fits the corners worse;
3. both placements polished together by scipy's least squares on the reprojection error
   with the nominal robot (the intrinsics as given): where the joint fit starts.

OpenCV is the optional ``camera`` extra (``pip install 'calib-pin[camera]'``): without
it, a camera set is refused with that line.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..exceptions import DataError
from ..util.optional import require
from .base import refuse_too_few
from .camera_rig import PX, CameraRig
from .lens import OPENCV_EXTRA, Board, Intrinsics

if TYPE_CHECKING:
    from ..parameters import ParameterModel
    from ..robot.chain import Chain

#: A start whose corners miss by more than this (RMS) [px] is tried again with the classic hand-eye solver.
FALLBACK_PX = 20.0
#: Poses a hand-eye start needs at least (two motions between them).
MIN_POSES = 3
#: The board's size is refused when the robot's motion measures its squares this far (relative) from the size given.
SCALE_TOLERANCE = 0.03
#: The board's size by the robot's motion: a pose whose loop misses by more than this many times the median is
#: left out, for at most SCALE_ROUNDS rounds.
SCALE_OUTLIER, SCALE_ROUNDS = 3.0, 5


def _project(m: np.ndarray) -> np.ndarray:
    """The rotation nearest to a 3x3 matrix (Frobenius).

    Raises:
        ValueError: a matrix that is not finite (a solver that failed).
    """
    if not np.all(np.isfinite(m)):
        raise ValueError("not finite")
    u, _, vt = np.linalg.svd(m)
    return u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt


def _mean(frames: list[pin.SE3]) -> pin.SE3:
    """The mean of nearly equal placements: the rotations' projected sum, the translations' mean."""
    return pin.SE3(_project(sum(f.rotation for f in frames)), np.mean([f.translation for f in frames], axis=0))


def board_poses(cv2: Any, board: Board, intrinsics: Intrinsics, values: np.ndarray, corners: np.ndarray,
                inverse: np.ndarray, m: int) -> list[pin.SE3 | None]:
    """Each pose's board in the camera frame, T_CW, by PnP.

    None where it fails, or has fewer than 4 corners or corners of one line only.

    Args:
        values: Image points (n_rows, 2) [px]; ``corners``: each row's corner index;
            ``inverse``: each row's pose index in 0..m-1.
    """
    k, dist = intrinsics.matrix(), intrinsics.distortion()
    out: list[pin.SE3 | None] = []
    for j in range(m):
        rows = np.flatnonzero(inverse == j)
        if len(rows) < 4:
            out.append(None)
            continue
        obj = board.points[corners[rows]].astype(np.float64)
        spread = np.linalg.svd(obj[:, :2] - obj[:, :2].mean(axis=0), compute_uv=False)
        if spread[1] < 0.5e-3 * board.square_mm:  # corners of one line: no board pose
            out.append(None)
            continue
        img = np.asarray(values[rows], dtype=np.float64).reshape(-1, 1, 2)
        try:
            ok, rvec, tvec = cv2.solvePnP(obj, img, k, dist, flags=cv2.SOLVEPNP_IPPE)
            if ok:
                ok, rvec, tvec = cv2.solvePnP(obj, img, k, dist, rvec, tvec, useExtrinsicGuess=True,
                                              flags=cv2.SOLVEPNP_ITERATIVE)
        except cv2.error:
            ok = False
        ok = ok and bool(np.all(np.isfinite(rvec)) and np.all(np.isfinite(tvec)))
        out.append(pin.SE3(cv2.Rodrigues(rvec)[0], np.asarray(tvec, dtype=float).reshape(3)) if ok else None)
    return out


def _arrays(frames: list[pin.SE3]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The rotations (3, 3) and translations (3, 1) of ``frames`` as OpenCV reads them (C-ordered float64)."""
    return ([np.ascontiguousarray(f.rotation, dtype=np.float64) for f in frames],
            [np.ascontiguousarray(f.translation, dtype=np.float64).reshape(3, 1) for f in frames])


def _robot_world(cv2: Any, in_hand: bool, ends: list[pin.SE3], boards: list[pin.SE3],
                 method: int) -> tuple[pin.SE3, pin.SE3]:
    """(camera, board placement) by ``cv2.calibrateRobotWorldHandEye``."""
    b = [e.inverse() for e in ends] if in_hand else ends  # eye in hand: T_EB; eye to hand: T_BE
    r_x, t_x, r_z, t_z = cv2.calibrateRobotWorldHandEye(*_arrays(boards), *_arrays(b), method=method)
    x, z = pin.SE3(_project(np.asarray(r_x)), np.asarray(t_x, float).reshape(3)), \
        pin.SE3(_project(np.asarray(r_z)), np.asarray(t_z, float).reshape(3))
    return z.inverse(), x.inverse()  # Z = T_CE (T_CB), X = T_WB (T_WE)


def _hand_eye(cv2: Any, in_hand: bool, ends: list[pin.SE3], boards: list[pin.SE3],
              method: int) -> tuple[pin.SE3, pin.SE3]:
    """(camera, board placement) by ``cv2.calibrateHandEye``, the other placement the mean of each pose's."""
    g = ends if in_hand else [e.inverse() for e in ends]  # gripper2base, or base2gripper for eye to hand
    r, t = cv2.calibrateHandEye(*_arrays(g), *_arrays(boards), method=method)
    camera = pin.SE3(_project(np.asarray(r)), np.asarray(t, float).reshape(3))  # T_EC, or T_BC
    return camera, _mean([gk * camera * bk for gk, bk in zip(g, boards, strict=True)])


#: OpenCV's hand-eye methods, by name: robot-world (A X = Z B) and classic (A X = X B) solvers and their flags.
HAND_EYE_METHODS = (("shah", "robot_world", "CALIB_ROBOT_WORLD_HAND_EYE_SHAH"),
                    ("li", "robot_world", "CALIB_ROBOT_WORLD_HAND_EYE_LI"),
                    ("tsai", "hand_eye", "CALIB_HAND_EYE_TSAI"), ("park", "hand_eye", "CALIB_HAND_EYE_PARK"),
                    ("horaud", "hand_eye", "CALIB_HAND_EYE_HORAUD"),
                    ("andreff", "hand_eye", "CALIB_HAND_EYE_ANDREFF"),
                    ("daniilidis", "hand_eye", "CALIB_HAND_EYE_DANIILIDIS"))


def hand_eye_alone(model: Any, q: np.ndarray, values: np.ndarray, corners: np.ndarray) -> dict[str, CameraRig]:
    """Each of OpenCV's hand-eye methods alone on the rows, with the nominal robot: its camera and board placements.

    PnP per pose (:func:`board_poses`), the end frames of ``model``'s nominal robot, then each
    method of :data:`HAND_EYE_METHODS` (the classic ones take the other placement as the mean
    of each pose's); no polish. A method that fails is left out.

    Args:
        model: A camera's measurement model (its mount, board and intrinsics are used).
        q, values, corners: The rows' joint angles [rad], image points [px], corner indices.

    Raises:
        CalibPinError: OpenCV is not installed.
        DataError: PnP finds the board in fewer than 3 poses.
    """
    cv2 = require("cv2", OPENCV_EXTRA)
    rig = model.rig
    poses, inverse = np.unique(np.asarray(q, dtype=float), axis=0, return_inverse=True)
    found = board_poses(cv2, rig.board, rig.intrinsics, values, corners, inverse.reshape(-1), len(poses))
    good = [j for j, f in enumerate(found) if f is not None]
    if len(good) < MIN_POSES:
        raise DataError("the measurement set", f"PnP finds the board in {len(good)} of the {len(poses)} poses: a "
                        f"hand-eye solution needs {MIN_POSES}")
    rot, origin = model.end_frames(None, poses[good])
    ends = [pin.SE3(r, t) for r, t in zip(rot, origin, strict=True)]
    boards = [found[j] for j in good]
    out = {}
    for name, kind, flag in HAND_EYE_METHODS:
        solve = _robot_world if kind == "robot_world" else _hand_eye
        try:
            camera, placed = solve(cv2, rig.in_hand, ends, boards, getattr(cv2, flag))
        except (cv2.error, np.linalg.LinAlgError, ValueError):
            continue
        out[name] = CameraRig(rig.mount, camera, placed, rig.board, rig.intrinsics)
    return out


def fit_rig(cls: Any, chain: Chain, params: ParameterModel, mount: str, board: Board, intrinsics: Intrinsics, q: np.ndarray,
            values: np.ndarray, corners: np.ndarray, source: str = "", rows: str = "training rows",
            labels: np.ndarray | None = None, lines: np.ndarray | None = None) -> CameraRig:
    """The camera's and board's placements that fit the rows best with the nominal robot (module docstring).

    Args:
        cls: The camera's measurement model (:class:`~calib_pin.sensors.camera.CameraModel`).
        q: Joint angles of the rows, shape (n_rows, n_joints), [rad].
        values: Image points, shape (n_rows, 2), [px].
        corners: Each row's corner index.
        source, rows: The data's name and what its rows are called, for a refusal.
        labels, lines: Each row's pose label and file line, for a refusal (None: not known).

    Raises:
        CalibPinError: OpenCV is not installed (the line names the extra).
        DataError: fewer than 3 poses whose board pose PnP finds, or too few values.
    """
    cv2 = require("cv2", OPENCV_EXTRA)
    refuse_too_few(source, len(q), 2 * len(q), 12, "the camera's and the board's placements", rows)
    poses, inverse = np.unique(np.asarray(q, dtype=float), axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    model = cls(chain, params, CameraRig(mount, pin.SE3.Identity(), pin.SE3.Identity(), board, intrinsics))
    rot, origin = model.end_frames(None, poses)
    found = board_poses(cv2, board, intrinsics, values, corners, inverse, len(poses))
    good = [j for j, f in enumerate(found) if f is not None]
    if len(good) < MIN_POSES:
        raise DataError(source or "the measurement set", f"PnP finds the board in {len(good)} of the {len(poses)} poses "
                        f"of the {rows}: a hand-eye start needs {MIN_POSES} (more poses, each of 4 corners or more)")
    in_hand = mount == "eye-in-hand"

    def start(use: list[int]) -> tuple[CameraRig, float, np.ndarray]:
        """The best hand-eye start of the poses ``use``, the board's scale and each of those poses' loop misfit [m]."""
        ends, boards = [pin.SE3(rot[j], origin[j]) for j in use], [found[j] for j in use]
        starts: list[tuple[float, CameraRig]] = []
        for solve, method in ((_robot_world, cv2.CALIB_ROBOT_WORLD_HAND_EYE_SHAH),
                              (_robot_world, cv2.CALIB_ROBOT_WORLD_HAND_EYE_LI),
                              (_hand_eye, cv2.CALIB_HAND_EYE_TSAI), (_hand_eye, cv2.CALIB_HAND_EYE_PARK)):
            if solve is _hand_eye and starts and min(s[0] for s in starts) < FALLBACK_PX:
                break  # the robot-world start fits: no fallback
            try:
                camera, placed = solve(cv2, in_hand, ends, boards, method)
            except (cv2.error, np.linalg.LinAlgError, ValueError):
                continue
            rig = CameraRig(mount, camera, placed, board, intrinsics)
            starts.append((_rms(cls(chain, params, rig, estimate=()), q, values, corners), rig))
        if not starts:
            raise DataError(source or "the measurement set", "OpenCV's hand-eye solvers found no camera placement on "
                            f"the {rows} (poses too alike: turn the flange about more axes between images)")
        best = min(starts, key=lambda s: s[0])[1]
        return (best, *board_loops(in_hand, ends, boards, best.camera.rotation))

    best, scale, misfit = start(good)
    if not 1.0 / MOTION_MISMATCH < scale < MOTION_MISMATCH:
        raise DataError(source or "the measurement set", f"the images do not follow the robot's motion (the board's "
                        f"squares would measure {scale * board.square_mm:.3g} mm): the wrong --camera-mount ({mount} "
                        "given), or images of other poses (the joints file's image names in the wrong order?)",
                        None, "camera_mount")
    if abs(scale - 1.0) > SCALE_TOLERANCE:
        raise DataError(source or "the measurement set", f"the board's squares measure {scale * board.square_mm:.1f} mm "
                        f"by the robot's motion, not the {board.square_mm:g} mm given: a camera measures lengths in "
                        "the board's squares, so a wrong size scales the whole robot (measure the printed board; "
                        "--board)", None, "board_square_mm")
    loose = misfit > max(STRAY_TIMES * float(np.median(misfit)), STRAY_MM * 1e-3)  # PnP gone wrong, or a stray
    if loose.any() and len(good) - loose.sum() >= MIN_POSES:  # the start of the others, then every pose's pixels
        best = start([j for j, out in zip(good, loose, strict=True) if not out])[0]
        rows_in = ~np.isin(inverse, np.asarray(good)[loose])
        best = polish(cls(chain, params, best), q[rows_in], values[rows_in], corners[rows_in])
    error = np.linalg.norm(cls(chain, params, best, estimate=()).image_points(None, q, corners) - values, axis=1)
    per_pose = np.sqrt(np.bincount(inverse, weights=error**2) / np.maximum(np.bincount(inverse), 1))
    far = np.flatnonzero(per_pose > max(STRAY_TIMES * float(np.median(per_pose)), STRAY_PX))
    if len(far):
        refuse_strays(far, per_pose, inverse, source, labels, lines)
    return polish(cls(chain, params, best), q, values, corners)


#: The board's scale by the robot's motion beyond this factor (either way) is no board's misprint: the images
#: and the joints do not belong together.
MOTION_MISMATCH = 1.5
#: A pose whose board the robot's motion puts this many times the median pose's loop away, and STRAY_MM, is
#: left out of the start (a PnP gone wrong on a few corners, or an image not of its pose); a pose whose corners
#: then miss by this many times the median pose's, and STRAY_PX, does not belong to its joints (refused).
STRAY_TIMES, STRAY_MM, STRAY_PX = 10.0, 20.0, 30.0


def refuse_strays(stray: np.ndarray, per_pose: np.ndarray, inverse: np.ndarray, source: str,
                  labels: np.ndarray | None, lines: np.ndarray | None) -> None:
    """Refuse the poses ``stray`` (indices of the distinct poses) whose image does not belong to their joints.

    ``per_pose``: each pose's RMS reprojection error at the start [px].

    Raises:
        DataError: naming the poses (their labels and file lines).
    """
    named = []
    for j in stray[:5]:
        rows = np.flatnonzero(inverse == j)
        label = f"pose {labels[rows[0]]}" if labels is not None else f"the pose of row {rows[0] + 1}"
        where = f" (lines {int(lines[rows].min())}-{int(lines[rows].max())})" if lines is not None else ""
        named.append(f"{label}{where} {per_pose[j]:.0f} px off")
    more = f" and {len(stray) - 5} more" if len(stray) > 5 else ""
    raise DataError(source or "the measurement set", f"{len(stray)} pose(s) whose corners do not belong to their "
                    f"joints: {', '.join(named)}{more}, where the median pose is {np.median(per_pose):.1f} px off at "
                    "the start: an image of another pose, or turned? (remove those "
                    "rows, or fix the joints file's image names)", None, "pose")


def board_loops(in_hand: bool, ends: list[pin.SE3], boards: list[pin.SE3],
                camera_rotation: np.ndarray) -> tuple[float, np.ndarray]:
    """The board's scale by the robot's motion (1: as given), and how far each pose's loop misses then [m].

    PnP's translations scale with the board's size and the robot's do not: with the camera's
    rotation (which the size does not change), the translations of every pose's loop, eye in
    hand R_BE R_EC (s t_CW) + R_BE t_EC + t_BE = t_BW and eye to hand R_BC (s t_CW) + t_BC =
    R_BE t_EW + t_BE, are linear in the scale s and the two unknown translations: least
    squares, then again without the poses whose loop misses by more than
    :data:`SCALE_OUTLIER` times the median (a PnP gone wrong on a few corners).

    Args:
        ends: The end frame's placement in the base at each pose (nominal robot).
        boards: PnP's board in the camera frame at each pose, T_CW, with the given size.
        camera_rotation: R_EC eye in hand, R_BC eye to hand.
    """
    a, b = [], []
    for end, board in zip(ends, boards, strict=True):
        if in_hand:
            a.append(np.column_stack([end.rotation @ camera_rotation @ board.translation, end.rotation, -np.eye(3)]))
            b.append(-end.translation)
        else:
            a.append(np.column_stack([camera_rotation @ board.translation, np.eye(3), -end.rotation]))
            b.append(end.translation)
    keep = np.ones(len(a), dtype=bool)
    for _ in range(SCALE_ROUNDS):  # a pose whose PnP went wrong (a few corners, the planar flip) left out
        solution = np.linalg.lstsq(np.concatenate([a[i] for i in np.flatnonzero(keep)]),
                                   np.concatenate([b[i] for i in np.flatnonzero(keep)]), rcond=None)[0]
        misfit = np.array([np.linalg.norm(ak @ solution - bk) for ak, bk in zip(a, b, strict=True)])
        kept = misfit <= SCALE_OUTLIER * np.median(misfit)
        if np.array_equal(kept, keep) or kept.sum() < MIN_POSES:
            break
        keep = kept
    return float(solution[0]), misfit


def _rms(model: Any, q: np.ndarray, values: np.ndarray, corners: np.ndarray) -> float:
    """RMS reprojection error [px] of ``model``'s rig with the nominal robot (inf where a corner is behind the camera)."""
    if np.any(model.camera_points(None, q, corners)[:, 2] <= 0):
        return float("inf")
    return float(np.sqrt(np.mean((model.image_points(None, q, corners) - values) ** 2)))


def polish(model: Any, q: np.ndarray, values: np.ndarray, corners: np.ndarray) -> CameraRig:
    """``model``'s placements (its estimated unknowns) refined on the reprojection error with the nominal robot.

    By scipy's Levenberg-Marquardt.
    """
    from scipy.optimize import least_squares  # imported here: scipy.optimize is slow to import

    zero = np.zeros(model.sensor_start)
    readings = np.asarray(values, dtype=float)

    def residual(e: np.ndarray) -> np.ndarray:
        return (model.image_points(np.concatenate([zero, e]), q, corners) - readings).reshape(-1)

    def jacobian(e: np.ndarray) -> np.ndarray:
        jac = model.predict_with_jacobian(np.concatenate([zero, e]), q, corners)[1]
        return jac[:, :, model.sensor_start :].reshape(2 * len(q), -1) / PX

    fit = least_squares(residual, np.zeros(model.n_params - model.sensor_start), jac=jacobian, method="lm")
    return model.geometry_at(np.concatenate([zero, fit.x]))


def refit_fixed(calibrated: Any, x: np.ndarray, q: np.ndarray, values: np.ndarray, corners: np.ndarray,
                source: str) -> CameraRig:
    """The calibration's rig with its part fixed in the cell (the board eye in hand, the camera eye to hand) moved.

    Each pose's placement of that part from PnP and the calibrated robot and flange-side
    part, averaged: where a re-registered session starts.

    Raises:
        DataError: PnP finds the board in no registration pose.
    """
    cv2 = require("cv2", OPENCV_EXTRA)
    rig = calibrated.geometry_at(x)
    poses, inverse = np.unique(np.asarray(q, dtype=float), axis=0, return_inverse=True)
    rot, origin = calibrated.end_frames(x, poses)
    found = board_poses(cv2, rig.board, rig.intrinsics, values, corners, inverse.reshape(-1), len(poses))
    placed = []
    for j, board in enumerate(found):
        if board is None:
            continue
        end = pin.SE3(rot[j], origin[j])
        placed.append(end * rig.camera * board if rig.in_hand else end * rig.board_pose * board.inverse())
    if not placed:
        raise DataError(source, f"PnP finds the board in none of the {len(poses)} registration poses (each needs 4 "
                        "corners or more)", None, "register")
    moved = _mean(placed)
    if rig.in_hand:
        return CameraRig(rig.mount, rig.camera, moved, rig.board, rig.intrinsics)
    return CameraRig(rig.mount, moved, rig.board_pose, rig.board, rig.intrinsics)

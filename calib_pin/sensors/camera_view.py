"""What a camera sees: the field of view, the default set-ups, and simulated camera sets.

A board corner is seen when it is in front of the camera (:data:`MIN_DEPTH_M`), in the
image (:data:`EDGE_PX` inside its edges), and the board faces the camera: its normal is
within :data:`FACING_DEG` of the line of sight to its middle (a board seen more edge-on is
not detected). A pose is usable when at least :data:`MIN_SEEN` corners are seen, every one
of a chessboard's (found all or none: :func:`min_seen`).

The planner (``plan-poses --sensor camera``) chooses among poses that see :data:`MIN_SEEN`
corners or more with the board's middle in the lens's focus range (:func:`focus_range`, or the
caller's), each pose's information from the corners it sees only (:func:`planning_rows`).

The default set-ups are made for the robot (:func:`default_rig`): eye in hand, a camera
beside the flange looking along it and a board lying face up where the camera looks down
most often; eye to hand, the board on the flange facing out along it and a camera 0.7 m
out from the middle of the workspace looking at it. The default camera
(:func:`default_intrinsics`) is a 1280x1024 sensor with a 1000 px focal length and a
little distortion; the default board (:func:`default_board`) a 9x7 ChArUco board of 30 mm
squares.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np
import pinocchio as pin

from ..exceptions import CalibPinError
from .camera_rig import MOUNTS, CameraRig, setup_notes
from .lens import Board, Intrinsics

if TYPE_CHECKING:
    from ..measurements import MeasurementSet
    from ..parameters import ParameterModel
    from ..robot.chain import Chain

#: A corner nearer the camera than this (along its axis) is not seen, [m].
MIN_DEPTH_M = 0.05
#: A corner nearer the image's edge than this is not seen, [px].
EDGE_PX = 2.0
#: The board is seen when its normal is within this angle of the line of sight to its middle, [deg].
FACING_DEG = 70.0
#: A simulated pose is kept when it sees at least this many corners.
MIN_SEEN = 12
#: Simulated pixel noise when the caller gives none, 1 sigma per coordinate, [px].
SIMULATED_NOISE_PX = 0.5
#: How far the camera looks at the board in the default set-ups, [m].
VIEW_DISTANCE_M = (0.45, 0.7)
#: Spread of a later simulated session's moved part (the board eye in hand, the camera eye to
#: hand): a turn about the vertical [deg] and a shift per horizontal axis [mm].
SESSION_TURN_DEG = 10.0
SESSION_SHIFT_MM = 40.0


def default_board() -> Board:
    """A 9x7 ChArUco board of 30 mm squares and 22 mm markers (DICT_5X5_100): 48 inner corners."""
    return Board(9, 7, 30.0, 22.0, "DICT_5X5_100", "charuco")


def default_intrinsics() -> Intrinsics:
    """A 1280x1024 camera, fx = fy = 1000 px, the principal point near the middle, a little distortion."""
    return Intrinsics(1000.0, 1000.0, 642.0, 509.0, 1280, 1024, -0.08, 0.05, 0.0005, -0.0003, 0.0)


def _look(axis: np.ndarray) -> np.ndarray:
    """A camera's rotation (columns x, y, z) whose optical axis is ``axis`` and whose y points as far down as it can."""
    z = axis / np.linalg.norm(axis)
    down = np.array([0.0, 0.0, -1.0])
    y = down - (down @ z) * z
    y = y / np.linalg.norm(y) if np.linalg.norm(y) > 1e-6 else np.array([1.0, 0.0, 0.0])
    return np.column_stack([np.cross(y, z), y, z])


def default_rig(cls: Any, chain: Chain, params: ParameterModel, mount: str, board: Board | None = None,
                intrinsics: Intrinsics | None = None) -> CameraRig:
    """The simulator's set-up for ``chain`` (module docstring), made from its nominal workspace (seeded).

    ``cls``: the camera's measurement model (:class:`~calib_pin.sensors.camera.CameraModel`).
    """
    from ..robot.poses import random_poses

    board = board or default_board()
    intrinsics = intrinsics or default_intrinsics()
    probe = cls(chain, params, CameraRig(mount, pin.SE3.Identity(), pin.SE3.Identity(), board, intrinsics), ())
    rot, origin = probe.end_frames(None, random_poses(chain, 2000, np.random.default_rng(0)))
    face_up = np.diag([1.0, -1.0, -1.0])  # the board's z (into it) down: its face up, or out along the flange
    if mount == MOUNTS[0]:
        camera = pin.SE3(pin.rpy.rpyToMatrix(0.04, -0.03, 0.02), np.array([0.06, 0.0, 0.05]))
        axis = rot @ camera.rotation[:, 2]
        eye = origin + rot @ camera.translation
        down = axis[:, 2] < -0.8
        if down.sum() < 20:
            raise CalibPinError(f"robot '{chain.name}': its flange seldom looks down; give the camera set-up "
                                "(geometry) to simulate eye in hand")
        target = np.median(eye[down] + VIEW_DISTANCE_M[0] * axis[down], axis=0)
        board_pose = pin.SE3(face_up, target - face_up @ board.centre)
        return CameraRig(mount, camera, board_pose, board, intrinsics)
    board_pose = pin.SE3(face_up, np.array([0.0, 0.0, 0.02]) - face_up @ board.centre)
    middle = np.median(origin, axis=0)
    out = np.array([middle[0], middle[1], 0.0])
    out = out / np.linalg.norm(out) if np.linalg.norm(out) > 1e-3 else np.array([1.0, 0.0, 0.0])
    eye = middle + VIEW_DISTANCE_M[1] * out + np.array([0.0, 0.0, 0.3])
    return CameraRig(mount, pin.SE3(_look(middle - eye), eye), board_pose, board, intrinsics)


def seen(model: Any, x: np.ndarray | None, q: np.ndarray) -> np.ndarray:
    """Which corners each pose of q sees at x (module docstring), shape (n_poses, n_corners)."""
    rig = model.geometry_at(x)
    n, k = len(q), rig.board.n_corners
    corners = np.tile(np.arange(k), n)
    points = model.camera_points(x, np.repeat(q, k, axis=0), corners).reshape(n, k, 3)
    front = points[:, :, 2] > MIN_DEPTH_M
    uv = model.image_points(x, np.repeat(q, k, axis=0), corners).reshape(n, k, 2)
    inside = rig.intrinsics.inside(uv.reshape(-1, 2), EDGE_PX).reshape(n, k) & front
    centre = model.camera_points(x, q, np.full(n, k // 2))
    normal = _board_normals(model, x, q)
    sight = centre / np.linalg.norm(centre, axis=1, keepdims=True)
    facing = np.einsum("ni,ni->n", normal, sight) >= np.cos(np.deg2rad(FACING_DEG))
    return inside & facing[:, None]


#: Random poses see a whole chessboard rarely (about 1 in 130 with the default set-up): so many batches of
#: twice the poses are drawn at most for one.
WHOLE_BATCHES = 1000


def min_seen(board: Board) -> int:
    """Corners a usable pose sees: :data:`MIN_SEEN`; a chessboard's every inner corner (it is found all or none)."""
    return board.n_corners if board.kind == "chessboard" else MIN_SEEN


def focus_range(mount: str) -> tuple[float, float]:
    """The default distance range [mm] a planned pose keeps the board's middle in: half to twice the view distance.

    The default set-up's (:data:`VIEW_DISTANCE_M`) for ``mount``: 225-900 mm eye in hand, 350-1400 mm eye to hand.
    """
    d = VIEW_DISTANCE_M[MOUNTS.index(mount)] * 1e3
    return 0.5 * d, 2.0 * d


def board_distance(model: Any, x: np.ndarray | None, q: np.ndarray) -> np.ndarray:
    """How far the board's middle is from the camera at each pose of q, shape (n,), [mm]."""
    rig = model.geometry_at(x)
    centre = model.camera_points(x, q, np.full(len(q), rig.board.n_corners // 2))
    return np.linalg.norm(centre, axis=1) * 1e3


def planned_views(model: Any, q: np.ndarray, focus_mm: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The poses of q a plan may choose (the nominal robot's): :func:`min_seen` corners seen or more, the board's
    middle within ``focus_mm`` [mm] of the camera; and which corners each sees, (n_kept, n_corners)."""
    near, far = focus_mm
    visible = seen(model, None, q)
    distance = board_distance(model, None, q)
    keep = (visible.sum(axis=1) >= min_seen(model.rig.board)) & (distance >= near) & (distance <= far)
    return q[keep], visible[keep]


#: Poses whose Jacobian is made at once when planning (bounds the memory: poses x corners x 2 x unknowns).
PLAN_BATCH = 256


def planning_rows(model: Any, q: np.ndarray, visible: np.ndarray) -> np.ndarray:
    """Each pose's scaled identification rows of the corners it sees, compressed, shape (n, n_params, n_params).

    The R factor of the pose's rows (2 a corner seen; its unseen corners none): the same
    information (R^T R = J^T J), few rows, so that the D-optimal choice
    (:func:`calib_pin.analysis.planning.plan_poses`) weighs a pose by what it sees.
    """
    k = model.rig.board.n_corners
    out = np.zeros((len(q), model.n_params, model.n_params))
    for start in range(0, len(q), PLAN_BATCH):
        block = q[start : start + PLAN_BATCH]
        rows = np.repeat(block, k, axis=0)
        jac = model.predict_with_jacobian(np.zeros(model.n_params), rows, np.tile(np.arange(k), len(block)))[1]
        jac = (jac * model.scale).reshape(len(block), k, 2, -1) * visible[start : start + PLAN_BATCH, :, None, None]
        r = cast(np.ndarray, np.linalg.qr(jac.reshape(len(block), 2 * k, -1), mode="r"))
        out[start : start + len(block), : r.shape[1]] = r
    return out


def _board_normals(model: Any, x: np.ndarray | None, q: np.ndarray) -> np.ndarray:
    """The board's z axis (into it) in the camera frame at each pose, shape (n, 3)."""
    rig = model.geometry_at(x)
    rot, _ = model.end_frames(x, q)
    r_c, r_w = rig.camera.rotation, rig.board_pose.rotation
    if rig.in_hand:  # R_CW = R_EC^T R_BE^T R_BW
        return np.einsum("ji,nkj,k->ni", r_c, rot, r_w[:, 2])
    return np.einsum("ji,njk,k->ni", r_c, rot, r_w[:, 2])  # R_CW = R_BC^T R_BE R_EW


def simulate_camera(cls: Any, draw: Any, geometry: CameraRig | None) -> tuple[MeasurementSet, CameraRig]:
    """A simulated camera set (:meth:`~calib_pin.sensors.base.MeasurementModel.simulate_rows`).

    Random poses that see :func:`min_seen` corners or more of the nominal robot's board (a
    chessboard whole: :data:`WHOLE_BATCHES` batches drawn at most), the true robot's image
    points of the corners it sees there (a chessboard: of the poses the true robot sees it
    whole), each coordinate with Gaussian noise ``draw.setup["noise_px"]`` (else
    :data:`SIMULATED_NOISE_PX`); ``geometry`` None: :func:`default_rig` of ``draw.setup``'s
    ``camera_mount`` (else eye in hand), ``board`` and ``intrinsics``.
    """
    from ..measurements import MeasurementSet

    setup = draw.setup
    mount = setup.get("camera_mount") or MOUNTS[0]
    rig = geometry if geometry is not None else default_rig(cls, draw.chain, draw.params, mount, setup.get("board"),
                                                            setup.get("intrinsics"))
    model = cls(draw.chain, draw.params, rig, estimate=())
    needed = min_seen(rig.board)
    whole = rig.board.kind == "chessboard"
    poses = draw.poses(lambda q: seen(model, None, q).sum(axis=1) >= needed,
                       f"see {needed} corners of the board (the camera set-up cannot see it?)",
                       WHOLE_BATCHES if whole else 50)
    flange = rig.camera.translation if rig.in_hand else rig.board_pose.act(rig.board.centre)
    nominal = model.points_at(None, poses, flange)
    draw.deviations(lambda x: np.linalg.norm(model.points_at(x, poses, flange) - nominal, axis=1))
    truth = cls(draw.chain, draw.params, rig, estimate=(), compliance=draw.compliance)
    visible = seen(truth, draw.x_model, poses)
    keep = visible.sum(axis=1) >= (needed if whole else 4)
    pose_of, corner = np.nonzero(visible[keep])
    q = poses[keep][pose_of]
    given = setup.get("noise_px")
    noise_px = (float(given) if given is not None else SIMULATED_NOISE_PX) if draw.noise_mm > 0 or given else 0.0
    uv = truth.image_points(draw.x_model, q, corner) + draw.rng.normal(size=(len(q), 2)) * noise_px
    notes, meta = setup_notes(rig, noise_px)
    data = MeasurementSet(
        q=q, values=uv, kind=cls.kind, robot=draw.chain.name, end_frame=draw.chain.end_frame,
        pose_ids=np.flatnonzero(keep)[pose_of] + 1, point_ids=corner, sensor_meta=meta,
        notes={**notes, "source": f"calib-pin camera simulator ({rig.mount}), seed {draw.seed}, noise {noise_px:g} px"})
    return data, rig


def session_rig(first: CameraRig, rng: np.random.Generator) -> CameraRig:
    """A later session's set-up: the part fixed in the cell moved (the board eye in hand, the camera eye to hand).

    Turned about the vertical through its middle within :data:`SESSION_TURN_DEG` and
    shifted within :data:`SESSION_SHIFT_MM` per horizontal axis.
    """
    turn = pin.rpy.rpyToMatrix(0.0, 0.0, np.deg2rad(rng.uniform(-1, 1) * SESSION_TURN_DEG))
    shift = np.array([*rng.uniform(-1, 1, 2) * SESSION_SHIFT_MM * 1e-3, 0.0])
    if first.in_hand:
        centre = first.board_pose.act(first.board.centre)
        moved = pin.SE3(turn @ first.board_pose.rotation, turn @ (first.board_pose.translation - centre) + centre + shift)
        return CameraRig(first.mount, first.camera, moved, first.board, first.intrinsics)
    camera = pin.SE3(turn @ first.camera.rotation, first.camera.translation + shift)
    return CameraRig(first.mount, camera, first.board_pose, first.board, first.intrinsics)

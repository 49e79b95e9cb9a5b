"""A camera and a printed board: image points of the board's corners, the sixth sensor type.

Two set-ups (:data:`MOUNTS`), each with two unknown placements:

- ``eye-in-hand``: the camera on the flange, T_EC (the camera frame C in the end frame E),
  the board fixed in the cell, T_BW (the board frame W in the base B);
- ``eye-to-hand``: the camera fixed in the cell, T_BC, the board on the flange, T_EW.

A row is one detected corner k of the board at joint angles q: the corner's point P_k in
the board frame goes to the camera frame, p_C = T_CE T_EB(q, x) T_BW P_k (eye in hand) or
p_C = T_CB T_BE(q, x) T_EW P_k (eye to hand), and to the image through the pinhole and
plumb-bob lens of :class:`~calib_pin.sensors.lens.Intrinsics`. The residual is the
reprojection error (u, v), 2 values a row, in pixels; the noise ``# noise_px`` (default
:data:`DEFAULT_NOISE_PX`, estimated from the residual when unstated and it matters).

Pixels are carried as 1e-3 (:data:`PX`), as millimetres are carried in metres, so that
every report's "x 1000" shows pixels (``value_unit`` px): a model's ``predict`` gives
image points times :data:`PX`; :meth:`CameraModel.image_points` gives them in pixels.

The unknowns are the robot's, then each placement's correction around its start (a
translation [m] and a right rotation vector [rad]: R = R0 exp3(rho), t = t0 + tau;
``camera_x/y/z``, ``camera_rx/ry/rz``, ``board_x/y/z``, ``board_rx/ry/rz``), then with
``estimate=intrinsics`` the nine intrinsics (``fx, fy, cx, cy`` [px], ``k1, k2, p1, p2, k3``).
The placements start from OpenCV's PnP and robot-world hand-eye solvers on the nominal
robot (:mod:`.camera_fit`). The Jacobian is analytic: the robot's part through the end
frame's point Jacobians of :meth:`~calib_pin.sensors.base.MeasurementModel.points_with_jacobians`.

The camera's placement in the end frame (eye in hand) and the last link's deviations
move the camera alike: the data sees their sum only, so the hand-eye transform alone is
the true one only on a robot whose last link is nominal (the gauge keeps the robot at its
start along what the data does not see, and the placement takes the rest). The board's
placement shares a gauge with the base in the same way.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements.schema import SCHEMAS, Schema
from ..robot.chain import Chain
from ..robot.deflection import ComplianceSpec
from ..robot.kinematics import cross_matrices
from .base import MeasurementModel, NoisePart, SetupExports, chosen, fit_rows_name, frame_unknowns
from .camera_fit import fit_rig, hand_eye_alone, refit_fixed
from .camera_rig import (
    CAMERA_EXTRAS,
    DEFAULT_NOISE_PX,
    MIN_CORNERS,
    MOUNTS,
    PX,
    CameraRig,
    CameraSetup,
    corner_index,
    gauge_note,
    setup_from_notes,
)
from .camera_view import (
    board_distance,
    default_rig,
    focus_range,
    min_seen,
    planned_views,
    planning_rows,
    session_rig,
    simulate_camera,
)
from .lens import INTRINSIC_NAMES, INTRINSIC_SCALE, INTRINSIC_UNITS, Board, Intrinsics
from .lens import project as project_points
from .problem import SetProblem
from .setup import SensorSetup

if TYPE_CHECKING:
    from ..measurements import MeasurementSet
    from ..parameters import ParameterModel

class CameraModel(MeasurementModel):
    """Image points of a board's corners seen by a camera, on a chain whose deviations follow a parameter model."""

    schema: ClassVar[Schema] = SCHEMAS["camera"]
    values_per_row = 2
    value_unit = "px"
    error_name = "reprojection error (u, v)"
    pose_name, row_name = "image", "corners"
    geometry_type = CameraRig
    setup_type = CameraSetup
    estimable = ("intrinsics",)
    fits_setup = True
    fitted_setup = "camera and board placements"
    moved_setup = ("board or camera placement", "the board or the camera was moved between the sessions?")

    def __init__(self, chain: Chain, params: ParameterModel, rig: CameraRig, estimate: Any = ("camera", "board"),
                 compliance: ComplianceSpec | None = None, noise_px: float = DEFAULT_NOISE_PX,
                 noise_from: str = "caller") -> None:
        if not isinstance(rig, CameraRig):
            raise ArgumentError("rig", f"expected a CameraRig (mount, placements, board, intrinsics), got "
                                f"{type(rig).__name__}")
        if not noise_px > 0:
            raise ArgumentError("noise_px", f"must be positive, got {noise_px} px")
        self.estimate = chosen(estimate, CAMERA_EXTRAS, "a camera")
        extra: list[tuple[str, str, float]] = []
        if "camera" in self.estimate:
            extra += frame_unknowns("camera", 1e-3, 2e-3)
        if "board" in self.estimate:
            extra += frame_unknowns("board", 1e-3, 2e-3)
        if "intrinsics" in self.estimate:
            extra += list(zip(INTRINSIC_NAMES, INTRINSIC_UNITS, INTRINSIC_SCALE, strict=True))
        #: Which of the 21 corrections (camera 6, board 6, intrinsics 9) x holds.
        sizes = {"camera": 6, "board": 6, "intrinsics": 9}
        starts = {"camera": 0, "board": 6, "intrinsics": 12}
        self._parts = np.array([starts[n] + i for n in CAMERA_EXTRAS if n in self.estimate for i in range(sizes[n])],
                               dtype=int)
        super().__init__(chain, params, extra, compliance)
        self.rig = rig
        self.noise_px = float(noise_px)
        #: Where :attr:`noise_px` came from: ``caller``, ``file``, ``default`` or ``estimate``.
        self.noise_from = noise_from

    # --- set-up -------------------------------------------------------------------------

    @classmethod
    def setup_of(cls, data: MeasurementSet) -> CameraSetup | None:
        return setup_from_notes(data)

    @classmethod
    def usable(cls, data: MeasurementSet) -> MeasurementSet:
        """The set without its poses of fewer than :data:`MIN_CORNERS` corners, each named in ``data.dropped``.

        Raises:
            DataError: no ``pose`` column, or no pose left.
        """
        source = data.source or "the measurement set"
        if data.pose_ids is None:
            raise DataError(source, "a camera set needs a pose column (which image each corner was detected in)",
                            None, "pose")
        poses, inverse, counts = np.unique(data.pose_ids, return_inverse=True, return_counts=True)
        thin = counts < MIN_CORNERS
        if not thin.any():
            return data
        if thin.all():
            raise DataError(source, f"no pose has {MIN_CORNERS} corners or more (a board pose needs {MIN_CORNERS})",
                            None, "corner_id")
        keep = np.flatnonzero(~thin[inverse])
        shown = ", ".join(f"{p} ({c})" for p, c in zip(poses[thin][:8], counts[thin][:8], strict=True))
        more = f" and {int(thin.sum()) - 8} more" if thin.sum() > 8 else ""
        note = (f"{source}: {int(thin.sum())} pose(s) dropped, fewer than {MIN_CORNERS} corners (pose (corners)): "
                f"{shown}{more}")
        out = data.subset(keep)
        out.dropped = (*data.dropped, note)
        return out

    @classmethod
    def stated_noise(cls, data: MeasurementSet, options: Mapping[str, Any]) -> tuple[float, str] | None:
        """The caller's ``noise_px``, else the file's ``# noise_px``, as carried (px x PX); None if neither."""
        given = options.get("noise_px")
        if given is not None:
            return float(given) * PX, "caller"
        filed = setup_from_notes(data)
        return (float(filed.noise_px) * PX, "file") if filed is not None and filed.noise_px is not None else None

    @classmethod
    def options_of(cls, data: MeasurementSet, options: Mapping[str, Any]) -> tuple[str, Board, Intrinsics, float, str]:
        """The set-up a set is calibrated with: the caller's over its file's.

        Returns:
            The mount, board, intrinsics, noise [px] and where the noise came from.

        Raises:
            DataError: a set-up item given nowhere, naming the file and the key.
            ArgumentError: a millimetre noise for a camera set.
        """
        source = data.source or "the measurement set"
        if options.get("noise_mm") is not None:
            raise ArgumentError("noise_mm", f"a camera set's noise is in pixels ({source}): give noise_px "
                                "(--noise-px, or '# noise_px' in its file)")
        filed = setup_from_notes(data)
        caller = CameraSetup(**{k: v for k, v in options.items() if k in CameraSetup.field_names() and k != "estimate"
                                and v is not None})

        def pick(name: str) -> Any:
            value = getattr(caller, name)
            return value if value is not None else getattr(filed, name) if filed is not None else None

        mount, board, intrinsics = pick("camera_mount"), pick("board"), pick("intrinsics")
        if intrinsics is None:
            start = " (--estimate intrinsics refines a starting lens: give one, the nominal values will do)" \
                if "intrinsics" in (options.get("estimate") or ()) else ""
            raise DataError(source, "no camera intrinsics: add '# camera_fx_px', '# camera_fy_px', '# camera_cx_px', "
                            "'# camera_cy_px', '# camera_width_px', '# camera_height_px' (and distortion "
                            "'# camera_k1' ...) or pass --intrinsics fx,fy,cx,cy,width,height[,k1,k2,p1,p2,k3]"
                            f"{start}", None, "intrinsics")
        if board is None:
            raise DataError(source, "no board: add '# board_columns', '# board_rows', '# board_square_mm' (and "
                            "'# board_marker_mm') or pass --board charuco,COLSxROWS,SQUARE_MM,MARKER_MM", None, "board")
        if mount is None:
            raise DataError(source, f"no camera mount: add '# camera_mount: eye-in-hand' (or eye-to-hand) or pass "
                            f"--camera-mount {MOUNTS[0]}", None, "camera_mount")
        noise = pick("noise_px")
        origin = "caller" if caller.noise_px is not None else "file" if noise is not None else "default"
        return mount, board, intrinsics, float(noise if noise is not None else DEFAULT_NOISE_PX), origin

    @classmethod
    def check_rows(cls, data: MeasurementSet, board: Board, intrinsics: Intrinsics) -> np.ndarray:
        """Each row's corner index, the corners on the board and the pixels in the image.

        Raises:
            DataError: a corner id not on the board, a pixel outside the image, naming the line.
        """
        corners = corner_index(data.point_ids, board, data)
        values = np.asarray(data.values, dtype=float).reshape(len(data), 2)
        outside = ~intrinsics.inside(values)
        if outside.any():
            r = int(np.argmax(outside))
            u, v = values[r]
            field = "u_px" if not -0.5 <= u <= intrinsics.width - 0.5 else "v_px"
            raise DataError(data.source or "the measurement set", f"({u:g}, {v:g}) px is outside the "
                            f"{intrinsics.width}x{intrinsics.height} image of the intrinsics (another camera's, or "
                            "another resolution's?)", None if data.lines is None else int(data.lines[r]), field)
        return corners

    @classmethod
    def problem_for(cls, chain: Chain, params: ParameterModel, data: MeasurementSet,
                    fit_rows: np.ndarray, options: Mapping[str, Any]) -> SetProblem:
        """The placements start from PnP and hand-eye with the nominal robot on ``fit_rows`` (:mod:`.camera_fit`)."""
        cls.refuse_foreign(options, data)
        intrinsics_too = chosen(options.get("estimate") or (), cls.estimable, "a camera")
        mount, board, intrinsics, noise, origin = cls.options_of(data, options)
        corners = cls.check_rows(data, board, intrinsics)
        fit_rows = np.asarray(fit_rows, dtype=int)
        labels = data.pose_ids[fit_rows] if data.pose_ids is not None else None
        lines = data.lines[fit_rows] if data.lines is not None else None
        rig = fit_rig(cls, chain, params, mount, board, intrinsics, data.q[fit_rows], data.values[fit_rows],
                      corners[fit_rows], data.source, fit_rows_name(options), labels, lines)
        model = cls(chain, params, rig, ("camera", "board", *intrinsics_too), options.get("compliance"), noise, origin)
        return SetProblem(model, data.q, np.asarray(data.values, dtype=float) * PX, corners)

    @classmethod
    def registration_problem(cls, chain: Chain, params: ParameterModel, session: MeasurementSet, rows: np.ndarray,
                             calibrated: MeasurementModel, x: np.ndarray,
                             options: Mapping[str, Any]) -> SetProblem:
        """A session with the fixed part moved: the board (eye in hand) or the camera (eye to hand) estimated.

        What rides on the flange (the camera, or the board) and the intrinsics stay as
        calibrated; the moved part starts from PnP on ``rows`` with the calibrated robot.
        """
        assert isinstance(calibrated, CameraModel)
        known = calibrated.geometry_at(x)
        corners = cls.check_rows(session, known.board, known.intrinsics)
        rig = refit_fixed(calibrated, x, session.q[rows], session.values[rows], corners[rows],
                          session.source or "test_data")
        moved = "board" if rig.in_hand else "camera"
        model = cls(chain, params, rig, (moved,), options.get("compliance"), calibrated.noise_px,
                    calibrated.noise_from)
        return SetProblem(model, session.q, np.asarray(session.values, dtype=float) * PX, corners)

    @classmethod
    def row_targets(cls, data: MeasurementSet) -> np.ndarray | None:
        """None: a camera's registration poses are taken in file order (a row's corner is no target)."""
        return None

    # --- simulation -----------------------------------------------------------------------

    @classmethod
    def simulate_rows(cls, draw: Any, geometry: CameraRig | None) -> tuple[MeasurementSet, CameraRig]:
        """A simulated camera set: :func:`.camera_view.simulate_camera`."""
        return simulate_camera(cls, draw, geometry)

    @classmethod
    def session_geometry(cls, first: CameraRig, rng: np.random.Generator) -> CameraRig:
        """A later session's set-up, its part fixed in the cell moved: :func:`.camera_view.session_rig`."""
        return session_rig(first, rng)

    # --- the camera's pose, and hand-eye alone ---------------------------------------------

    def render_images(self, x: np.ndarray | None, q: np.ndarray, rng: np.random.Generator) -> list[np.ndarray]:
        """The 8-bit grey image the camera takes of the board at each pose of q [rad] (:mod:`.camera_render`)."""
        from .camera_render import render_images

        return render_images(self, x, q, rng)

    def camera_to_board(self, x: np.ndarray | None, q: np.ndarray) -> list[pin.SE3]:
        """The board's pose in the camera frame at each pose of q (T_CW, [m]): what PnP reads of an image."""
        rig = self.geometry_at(x)
        rot, origin = self.end_frames(x, q)
        ends = [pin.SE3(r, t) for r, t in zip(rot, origin, strict=True)]
        if rig.in_hand:  # T_CE T_EB T_BW
            return [rig.camera.inverse() * end.inverse() * rig.board_pose for end in ends]
        return [rig.camera.inverse() * end * rig.board_pose for end in ends]  # T_CB T_BE T_EW

    def hand_eye_alone(self, q: np.ndarray, values: np.ndarray, corners: np.ndarray) -> dict[str, CameraRig]:
        """OpenCV's hand-eye methods alone on the rows with the nominal robot: :func:`.camera_fit.hand_eye_alone`."""
        return hand_eye_alone(self, q, values, corners)

    # --- planning (plan-poses --sensor camera) ----------------------------------------------

    @classmethod
    def planning_model(cls, chain: Chain, params: ParameterModel, setup: SensorSetup | None,
                       focus_mm: tuple[float, float] | None = None) -> CameraModel:
        """The simulator's set-up for the robot (:func:`.camera_view.default_rig`) with the caller's mount, board and
        lens; the placements estimated, and the intrinsics with ``estimate``.

        Args:
            setup: The caller's :class:`CameraSetup` (None: eye in hand, the default board and lens).
            focus_mm: The distance range [mm] a planned pose keeps the board's middle in
                (default :func:`.camera_view.focus_range` of the mount).

        Raises:
            ArgumentError: a focus range that is not 0 < near < far.
        """
        setup = setup if isinstance(setup, CameraSetup) else CameraSetup()
        mount = setup.camera_mount or MOUNTS[0]
        rig = default_rig(cls, chain, params, mount, setup.board, setup.intrinsics)
        estimate = ("camera", "board", *chosen(setup.estimate, cls.estimable, "a camera"))
        model = cls(chain, params, rig, estimate, noise_px=setup.noise_px or DEFAULT_NOISE_PX)
        near, far = focus_mm if focus_mm is not None else focus_range(mount)
        if not 0 < near < far:
            raise ArgumentError("focus_mm", f"expected 0 < near < far, got {near:g}, {far:g} mm")
        model.focus_mm = (float(near), float(far))
        return model

    #: The distance range [mm] a planned pose keeps the board's middle in (:meth:`planning_model` sets it).
    focus_mm: tuple[float, float] | None = None

    @property
    def plan_rule(self) -> str:
        """What a candidate pose must do to be planned, for people."""
        near, far = self.focus_mm or focus_range(self.rig.mount)
        return f"see {min_seen(self.rig.board)} corners or more of the board, its middle {near:g} to {far:g} mm from the camera"

    def plan_candidates(self, n: int, rng: np.random.Generator, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """Of ``n`` random poses within the joint limits less ``margin`` [rad], those that see the board in focus.

        Returns their joint angles (m, n_joints) [rad] and the corners each sees (m, n_corners):
        :func:`.camera_view.planned_views`.
        """
        from ..robot.poses import random_poses

        return planned_views(self, random_poses(self.chain, n, rng, margin=margin),
                             self.focus_mm or focus_range(self.rig.mount))

    def planning_rows(self, q: np.ndarray, visible: np.ndarray) -> np.ndarray:
        """Each candidate's information from the corners it sees: :func:`.camera_view.planning_rows`."""
        return planning_rows(self, q, np.asarray(visible, dtype=bool))

    def planning_problem(self, q: np.ndarray, visible: np.ndarray) -> SetProblem:
        """The problem of the corners each pose of q sees (``visible``, (n, n_corners)), at the nominal robot."""
        pose, corner = np.nonzero(np.asarray(visible, dtype=bool))
        rows = np.asarray(q, dtype=float)[pose]
        return SetProblem(self, rows, self.predict(None, rows, corner), corner)

    def plan_summary(self, q: np.ndarray, visible: np.ndarray) -> str:
        """The planned poses' corners in view and board distances, one line."""
        counts = np.asarray(visible, dtype=bool).sum(axis=1)
        distance = board_distance(self, None, q)
        return (f"corners in view per planned pose: {counts.min()} to {counts.max()} of {self.rig.board.n_corners} "
                f"(median {np.median(counts):g}); the board's middle {distance.min():.0f} to {distance.max():.0f} mm "
                f"from the camera ({self.rig.mount}, {self.rig.board.describe()})")

    # --- geometry -------------------------------------------------------------------------

    def _corrections(self, x: np.ndarray | None) -> np.ndarray:
        """All 21 corrections (zero for a part not estimated)."""
        e = np.zeros(21)
        if x is not None and len(self._parts):
            e[self._parts] = self.sensor_part(x)
        return e

    def geometry_at(self, x: np.ndarray | None) -> CameraRig:
        """The placements and intrinsics x implies."""
        if x is None or not self.estimate:
            return self.rig
        e = self._corrections(x)
        rig = self.rig
        camera = pin.SE3(rig.camera.rotation @ pin.exp3(e[3:6]), rig.camera.translation + e[:3])
        board = pin.SE3(rig.board_pose.rotation @ pin.exp3(e[9:12]), rig.board_pose.translation + e[6:9])
        intrinsics = rig.intrinsics.with_vector(rig.intrinsics.vector() + e[12:]) if "intrinsics" in self.estimate \
            else rig.intrinsics
        return CameraRig(rig.mount, camera, board, rig.board, intrinsics)

    def geometry_report(self, x: np.ndarray | None) -> dict:
        return {**self.geometry_at(x).to_dict(), "gauge_note": gauge_note(self.rig.mount)}

    def describe(self) -> str:
        estimated = "placements and intrinsics" if "intrinsics" in self.estimate else "placements"
        return (f"camera {self.rig.mount}, {self.rig.board.describe()}, {estimated} estimated (noise "
                f"{self.noise_px:.4g} px)")

    def setup_exports(self, x: np.ndarray, links: tuple[str, str], tag: str = "") -> SetupExports:
        """The camera's and the board's frames for the URDF, the hand-eye YAML and, when calibrated, the intrinsics.

        The frames: ``camera_optical_frame`` (x right, y down, z the optical axis) and
        ``calibration_board`` (its corners' frame), each on a fixed joint from the end frame's
        link or the base link, by the mount. ``hand_eye.yaml``: :mod:`calib_pin.export.hand_eye`,
        with the gauge note. ``intrinsics.yaml`` (with ``estimate`` intrinsics): the calibrated
        intrinsics in the layout they were read in (:mod:`.lens_file`), ROS's ``camera_info``
        when they were not read from a file.
        """
        from ..export.hand_eye import HandEye, hand_eye_text
        from ..export.urdf import AddedFrame
        from .lens_file import intrinsics_text

        rig = self.geometry_at(x)
        base, end = links
        camera, board = f"camera_optical_frame{tag}", f"calibration_board{tag}"
        on = ("end", "base") if rig.in_hand else ("base", "end")
        frames = (AddedFrame(camera, on[0], rig.camera), AddedFrame(board, on[1], rig.board_pose))
        gauge = f"gauge: {gauge_note(rig.mount)}"
        namespace = f"{self.chain.name}{tag}_eye_{'on_hand' if rig.in_hand else 'on_base'}"
        files = {"hand_eye.yaml": hand_eye_text(HandEye(rig.in_hand, rig.camera, rig.board_pose, base, end, camera,
                                                         board), namespace, [gauge])}
        if "intrinsics" in self.estimate:
            source = rig.intrinsics.source
            start = f" from {source.path}" if source is not None else ""
            note = (f"calib-pin: intrinsics calibrated with the robot '{self.chain.name}' and the hand-eye placements"
                    f"{start}")
            files["intrinsics.yaml"] = intrinsics_text(rig.intrinsics, source.format if source else "ros",
                                                       (source.camera_name if source else "") or "camera", [note])
        return SetupExports(frames, files)

    @property
    def reference_point(self) -> np.ndarray:
        """The camera's optical centre (eye in hand) or the board's middle (eye to hand), end frame [m]."""
        rig = self.rig
        return np.asarray(rig.camera.translation if rig.in_hand else rig.board_pose.act(rig.board.centre), dtype=float)

    def measured_points(self, x: np.ndarray | None) -> tuple[tuple[str, np.ndarray], ...]:
        """The camera's optical centre (eye in hand) or the board's origin (eye to hand), end frame [m]."""
        rig = self.geometry_at(x)
        if rig.in_hand:
            return (("camera centre", np.asarray(rig.camera.translation, dtype=float)),)
        return (("board origin", np.asarray(rig.board_pose.translation, dtype=float)),)

    def point_index(self, labels: Any, n_rows: int, source: str = "") -> np.ndarray:
        """Corner indices of ``n_rows`` rows whose ``corner_id`` are ``labels``.

        Raises:
            ArgumentError: no labels (every row names its corner).
            DataError: a corner not on the board.
        """
        if labels is None:
            raise ArgumentError("point_ids", f"give each row's corner_id (0 to {self.rig.board.n_corners - 1})")
        return corner_index(labels, self.rig.board)

    def grid_points(self, n_poses: int) -> tuple[np.ndarray, np.ndarray | None]:
        k = self.rig.board.n_corners
        return np.repeat(np.arange(n_poses), k), np.tile(np.arange(k), n_poses)

    # --- noise ----------------------------------------------------------------------------

    def noise_parts(self) -> tuple[NoisePart, ...]:
        """One part, the pixels, in px (so that a camera set's noise is never pooled with a length's)."""
        return (NoisePart("reprojection", "px", 1.0 / PX, self.noise_px * PX, self.noise_from),)

    def part_residuals(self, x: np.ndarray | None, q: np.ndarray, readings: np.ndarray,
                       points: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """The reprojection errors (u, v of every row) flattened, [px x PX]."""
        return ((self.predict(x, q, points) - readings).reshape(-1),)

    def part_entries(self, n_rows: int) -> tuple[np.ndarray, ...]:
        return (np.arange(2 * n_rows),)

    def with_part_noise(self, sigmas: tuple[float, ...], origin: str) -> CameraModel:
        """A copy whose pixel noise is ``sigmas[0]`` [px x PX]; a stated noise keeps its origin."""
        sigma = float(sigmas[0])
        if not sigma > 0:
            raise ArgumentError("noise", f"the pixel noise must be positive, got {sigma / PX} px")
        out = copy.copy(self)
        out.noise_px = sigma / PX
        out.noise_from = origin if self.noise_from == "default" else self.noise_from
        return out

    # --- predictions ----------------------------------------------------------------------

    def image_points(self, x: np.ndarray | None, q: np.ndarray, corners: np.ndarray) -> np.ndarray:
        """Where each row's corner is in the image at q, shape (n_rows, 2), [px]."""
        return self._project(x, q, corners, False)[0]

    def camera_points(self, x: np.ndarray | None, q: np.ndarray, corners: np.ndarray) -> np.ndarray:
        """Each row's corner in the camera frame, shape (n_rows, 3), [m]."""
        return self._points(x, q, corners, False)[0]

    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Image points times :data:`PX`, shape (n_rows, 2); ``points``: each row's corner index."""
        return self.image_points(x, q, _corners(points, len(q))) * PX

    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray,
                              points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Image points times :data:`PX` (n_rows, 2) and their derivative (n_rows, 2, n_params)."""
        uv, jac = self._project(x, q, _corners(points, len(q)), True)
        return uv * PX, jac * PX

    def session_errors(self, x: np.ndarray | None, data: MeasurementSet,
                       correction: Callable[[np.ndarray, np.ndarray | None], np.ndarray] | None = None,
                       ) -> np.ndarray:
        """Each row's reprojection error [px x PX] predicting a separate session at x (None: nominal).

        Raises:
            CalibPinError: with a learnt correction (it corrects values, not image points).
        """
        if correction is not None:
            raise CalibPinError("a learnt correction (rbf, lm-rbf) cannot be scored on a separate camera session")
        corners = self.point_index(data.point_ids, len(data), data.source)
        return np.linalg.norm(self.predict(x, data.q, corners) - np.asarray(data.values) * PX, axis=1)

    def session_frame_shift(self, x: np.ndarray | None, data: MeasurementSet) -> float | None:
        """How far a separate session's part fixed in the cell is from the calibration's, [m].

        That part (the board eye in hand, the camera eye to hand) placed from the session's
        own images (PnP with the model at x); the RMS distance between where the two put the
        board's corners (eye in hand), or the camera's centre and a point 0.5 m along its
        axis (eye to hand). None when PnP finds the board in none of its poses.
        """
        rig = self.geometry_at(x)
        corners = self.check_rows(data, rig.board, rig.intrinsics)
        try:
            own = refit_fixed(self, np.zeros(self.n_params) if x is None else x, data.q, data.values, corners,
                              data.source or "test_data")
        except DataError:
            return None
        if rig.in_hand:
            points = rig.board.points
            ours, theirs = points @ rig.board_pose.rotation.T + rig.board_pose.translation, \
                points @ own.board_pose.rotation.T + own.board_pose.translation
        else:
            points = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.5]])
            ours, theirs = points @ rig.camera.rotation.T + rig.camera.translation, \
                points @ own.camera.rotation.T + own.camera.translation
        return float(np.sqrt(np.mean(np.sum((theirs - ours) ** 2, axis=1))))

    def _project(self, x: np.ndarray | None, q: np.ndarray, corners: np.ndarray,
                 jacobian: bool) -> tuple[np.ndarray, Any]:
        """Image points [px] and, with ``jacobian``, their derivative [px per unit of x] (n, 2, n_params)."""
        points, d_points, rig = self._points(x, q, corners, jacobian)
        intrinsics = rig.intrinsics.vector()
        uv, d_uv, d_k = project_points(intrinsics, points, jacobian)
        if not jacobian:
            return uv, None
        jac = d_uv @ d_points
        if "intrinsics" in self.estimate:
            jac[:, :, self.n_params - 9 :] = d_k
        return uv, jac

    def _end_frames(self, x: np.ndarray | None, q: np.ndarray,
                    jacobian: bool) -> tuple[np.ndarray, np.ndarray, Any, Any, np.ndarray]:
        """The end frame at each distinct pose of q: rotations (m, 3, 3), origins (m, 3) [m].

        With ``jacobian`` also the derivatives of its origin and of its rotation (a base-frame
        angular velocity), each (m, 3, n_params); and each row's pose index (n_rows,).
        """
        poses, inverse = np.unique(np.asarray(q, dtype=float), axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        if not jacobian:
            rot, origin = self.end_frames(x, poses)
            return rot, origin, None, None, inverse
        m = len(poses)
        x = np.zeros(self.n_params) if x is None else np.asarray(x, dtype=float)
        ends = np.concatenate([np.zeros((m, 3))] + [np.tile(axis, (m, 1)) for axis in np.eye(3)])
        base, end_rot, d = self.points_with_jacobians(x, np.tile(poses, (4, 1)), ends)
        rot, origin = end_rot[:m], base[:m]
        d_origin = d[:m]
        d_axes = d.reshape(4, m, 3, -1)[1:] - d_origin[None]  # d (R e_i), i = x, y, z
        # omega . R e_x = (d R e_y) . R e_z, and so on round (the end frame's components), then in the base frame
        omega_end = np.stack([np.einsum("mi,mik->mk", rot[:, :, 2], d_axes[1]),
                              np.einsum("mi,mik->mk", rot[:, :, 0], d_axes[2]),
                              np.einsum("mi,mik->mk", rot[:, :, 1], d_axes[0])], axis=1)
        return rot, origin, d_origin, rot @ omega_end, inverse

    def _points(self, x: np.ndarray | None, q: np.ndarray, corners: np.ndarray,
                jacobian: bool) -> tuple[np.ndarray, Any, CameraRig]:
        """Each row's corner in the camera frame (n, 3) [m], its derivative (n, 3, n_params) or None, the rig."""
        rig = self.geometry_at(x)
        rot, origin, d_origin, d_omega, inverse = self._end_frames(x, q, jacobian)
        rot, origin = rot[inverse], origin[inverse]
        local = rig.board.points[np.asarray(corners, dtype=int)]  # P_k, board frame
        r_c, t_c = rig.camera.rotation, rig.camera.translation
        r_w, t_w = rig.board_pose.rotation, rig.board_pose.translation
        if rig.in_hand:
            base = local @ r_w.T + t_w  # fixed in the base
            end = np.einsum("nji,nj->ni", rot, base - origin)
            points = (end - t_c) @ r_c
        else:
            end = local @ r_w.T + t_w  # fixed in the end frame
            base = origin + np.einsum("nij,nj->ni", rot, end)
            points = (base - t_c) @ r_c
        if not jacobian:
            return points, None, rig
        n = len(points)
        jac = np.zeros((n, 3, self.n_params))
        d_o, d_w = d_origin[inverse], d_omega[inverse]
        lever = cross_matrices(base - origin)  # omega -> omega x (b - origin)
        if rig.in_hand:  # dy = -R^T (d origin + omega x (b - origin)); dc = R_EC^T dy
            d_end = -np.einsum("nji,njk->nik", rot, d_o + lever @ d_w)
            jac[:, :, : self.sensor_start] = (r_c.T @ d_end)[:, :, : self.sensor_start]
            d_fixed = r_c.T @ np.transpose(rot, (0, 2, 1))  # d c / d b
        else:  # db = d origin + omega x (R y); dc = R_BC^T db
            d_base = d_o + lever @ d_w
            jac[:, :, : self.sensor_start] = (r_c.T @ d_base)[:, :, : self.sensor_start]
            d_fixed = r_c.T @ rot  # d c / d y
        e = self._corrections(x)
        sensor = np.zeros((n, 3, 12))
        sensor[:, :, 0:3] = -r_c.T
        sensor[:, :, 3:6] = -cross_matrices(points) @ pin.Jexp3(e[3:6])  # [c]x Jr
        sensor[:, :, 6:9] = d_fixed
        sensor[:, :, 9:12] = d_fixed @ (r_w @ cross_matrices(local) @ pin.Jexp3(e[9:12]))  # -R_W [P]x Jr
        own = self._parts[self._parts < 12]
        jac[:, :, self.sensor_start : self.sensor_start + len(own)] = sensor[:, :, own]
        return points, jac, rig


def _corners(points: np.ndarray | None, n_rows: int) -> np.ndarray:
    """Each row's corner index (a row of a camera set always names its corner)."""
    if points is None:
        raise ArgumentError("points", f"give each of the {n_rows} rows' corner index")
    return np.asarray(points, dtype=int)


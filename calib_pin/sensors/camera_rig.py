"""A camera set-up as records: where the camera and the board are, the options a caller gives, the file's notes.

:class:`CameraRig` is a camera set's geometry (:mod:`.camera`: the set-ups, the model);
:class:`CameraSetup` the options a caller gives (``--camera-mount``, ``--board``,
``--intrinsics``, ``--noise-px``); a camera set's file states the same as notes
(:func:`setup_notes` writes them, :func:`setup_from_notes` reads them):

    # camera_mount: eye-in-hand
    # board_kind: charuco
    # board_columns: 9
    # board_rows: 7
    # board_dictionary: DICT_5X5_100
    # board_square_mm: 30
    # board_marker_mm: 22
    # camera_fx_px: 1000
    ... camera_fy_px, camera_cx_px, camera_cy_px, camera_width_px, camera_height_px,
    ... camera_k1, camera_k2, camera_p1, camera_p2, camera_k3 (no unit)
    # noise_px: 0.1
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError, DataError
from .lens import INTRINSIC_NAMES, Board, Intrinsics, intrinsics_of
from .lens_file import board_argument, intrinsics_argument
from .setup import SensorSetup, option

if TYPE_CHECKING:
    from ..measurements import MeasurementSet

#: The camera set-ups: the camera on the flange and the board fixed, or the other way round.
MOUNTS = ("eye-in-hand", "eye-to-hand")
#: What a camera model can estimate: the camera's placement, the board's, the intrinsics.
CAMERA_EXTRAS = ("camera", "board", "intrinsics")
#: A pixel as the framework carries a value (module docstring): its reports show x 1000.
PX = 1e-3
#: Pixel noise (1 sigma per coordinate) assumed when neither ``# noise_px`` nor the caller give it, [px].
DEFAULT_NOISE_PX = 0.5
#: A board pose needs at least this many corners (PnP of a plane): a pose with fewer is dropped.
MIN_CORNERS = 4
def gauge_note(mount: str) -> str:
    """What a calibration says of the placements' gauge (its report and printout), for ``mount``."""
    flange, cell = ("camera (T_EC)", "board (T_BW)") if mount == MOUNTS[0] else ("board (T_EW)", "camera (T_BC)")
    return (f"the {flange} placement shares a gauge with the last link's deviations, and the {cell} placement with "
            "the base's: each alone is the true one only on a robot nominal there; the robot and the placements "
            "together are what the data determines")


def _mount(text: str) -> str:
    """``--camera-mount``: one of :data:`MOUNTS`."""
    import argparse

    if text not in MOUNTS:
        raise argparse.ArgumentTypeError(f"expected {' or '.join(MOUNTS)}, got '{text[:40]}'")
    return text


def _positive_px(text: str) -> float:
    """``--noise-px``: a noise in (0, 100] px."""
    import argparse

    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 < value <= 100.0:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 100] px, got '{text[:40]}'")
    return value


@dataclass(frozen=True, eq=False)
class CameraSetup(SensorSetup):
    """A camera set-up's options (each None: the file's).

    Attributes:
        camera_mount: ``eye-in-hand`` or ``eye-to-hand`` (:data:`MOUNTS`).
        board: The printed board (a :class:`~calib_pin.sensors.lens.Board`, or its
            ``--board`` text).
        intrinsics: The camera's intrinsics (an :class:`~calib_pin.sensors.lens.Intrinsics`,
            or its ``--intrinsics`` text: an OpenCV or ROS ``camera_info`` YAML file, or the numbers).
        noise_px: Pixel noise, 1 sigma per coordinate [px].
        estimate: ``intrinsics`` to calibrate them in the same fit (the placements are
            always estimated).

    Raises:
        ArgumentError: naming the field.
    """

    title: ClassVar[str] = "camera"

    camera_mount: Any = option(help="where the camera is: eye-in-hand (on the flange, the board fixed) or "
                               "eye-to-hand (fixed, the board on the flange)", parser=_mount)
    board: Any = option(help="the printed board: 'charuco,COLSxROWS,SQUARE_MM,MARKER_MM[,DICT]' or "
                        "'chessboard,COLSxROWS,SQUARE_MM' (squares, not inner corners), or a board file "
                        "(FILE.yaml: kind, columns, rows, square_mm, marker_mm, dictionary)", parser=board_argument,
                        metavar="SPEC|FILE.yaml")
    intrinsics: Any = option(help="the camera's intrinsics: an OpenCV or ROS camera_info YAML file (FILE.yaml), or "
                             "'fx,fy,cx,cy,width,height[,k1,k2,p1,p2,k3]' in px (OpenCV's pinhole and plumb-bob "
                             "distortion)", parser=intrinsics_argument, metavar="FILE.yaml|K")
    noise_px: Any = option(help="pixel noise of a camera set, 1 sigma per coordinate", unit="px",
                           parser=_positive_px)
    estimate: Any = ()

    def __post_init__(self) -> None:
        from ..util.arguments import as_float, as_names, as_optional

        if self.camera_mount is not None and self.camera_mount not in MOUNTS:
            raise ArgumentError("camera_mount", f"'{self.camera_mount!s:.40}' is not one of {', '.join(MOUNTS)}")
        for name, kind, parse in (("board", Board, board_argument), ("intrinsics", Intrinsics, intrinsics_argument)):
            value = getattr(self, name)
            if isinstance(value, str):
                import argparse

                try:
                    value = parse(value)
                except argparse.ArgumentTypeError as e:
                    raise ArgumentError(name, str(e)) from None
            if value is not None and not isinstance(value, kind):
                raise ArgumentError(name, f"expected a {kind.__name__} or its text, got {type(value).__name__}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "noise_px", as_optional(as_float, self.noise_px, "noise_px", 0.0, 100.0,
                                                         low_open=True, unit="px"))
        object.__setattr__(self, "estimate", as_names(self.estimate, "estimate"))


@dataclass(frozen=True)
class CameraRig:
    """Geometry of a camera set-up.

    Attributes:
        mount: ``eye-in-hand`` or ``eye-to-hand``.
        camera: The camera's placement: T_EC in the end frame (eye in hand), T_BC in the
            base (eye to hand) (pin.SE3, [m]); x_C right, y_C down, z_C the optical axis.
        board_pose: The board's placement: T_BW in the base (eye in hand), T_EW in the end
            frame (eye to hand) (pin.SE3, [m]).
        board: The printed board.
        intrinsics: The camera's intrinsics.
    """

    mount: str
    camera: pin.SE3
    board_pose: pin.SE3
    board: Board
    intrinsics: Intrinsics

    @property
    def in_hand(self) -> bool:
        return self.mount == MOUNTS[0]

    def to_dict(self) -> dict:
        """In mm and degrees (rpy: roll, pitch, yaw about the fixed x, y, z axes), pixels."""
        def frame(t: pin.SE3, meaning: str) -> dict:
            return {"translation_mm": (t.translation * 1e3).tolist(),
                    "rpy_deg": np.rad2deg(pin.rpy.matrixToRpy(t.rotation)).tolist(), "meaning": meaning}

        camera, board = ("end", "base") if self.in_hand else ("base", "end")
        return {"camera_mount": self.mount,
                "camera_frame": frame(self.camera, f"p_{camera} = R p_camera + t"),
                "board_frame": frame(self.board_pose, f"p_{board} = R p_board + t"),
                "board": self.board.to_dict(), "intrinsics": self.intrinsics.to_dict()}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> CameraRig:
        """Inverse of :meth:`to_dict`."""
        def frame(d: Mapping[str, Any]) -> pin.SE3:
            rot = pin.rpy.rpyToMatrix(*np.deg2rad(np.asarray(d["rpy_deg"], dtype=float)))
            return pin.SE3(rot, np.asarray(d["translation_mm"], dtype=float) * 1e-3)

        return cls(str(doc["camera_mount"]), frame(doc["camera_frame"]), frame(doc["board_frame"]),
                   Board.from_dict(doc["board"]), Intrinsics.from_dict(doc["intrinsics"]))


def setup_from_notes(data: MeasurementSet) -> CameraSetup | None:
    """The camera set-up a file states (``# camera_mount``, ``# board_*``, ``# camera_*``, ``# noise_px``).

    None when it states none.

    Raises:
        DataError: a stated set-up that is incomplete or not valid, naming the file and key.
    """
    notes, meta, source = data.notes, data.sensor_meta, data.source or "the measurement set"
    given: dict[str, Any] = {}
    if "camera_mount" in notes:
        given["camera_mount"] = notes["camera_mount"].strip()
    if "noise_px" in notes:
        given["noise_px"] = _number(notes, "noise_px", source)
    board_keys = [k for k in ("board_columns", "board_rows", "board_kind", "board_dictionary") if k in notes]
    if board_keys or "board_square" in meta:
        missing = [k for k in ("board_columns", "board_rows") if k not in notes]
        if missing or "board_square" not in meta:
            raise DataError(source, "a board needs '# board_columns', '# board_rows' and '# board_square_mm' (and "
                            "for a ChArUco board '# board_marker_mm')", None, (missing or ["board_square_mm"])[0])
        kind = notes.get("board_kind", "charuco" if "board_marker" in meta else "chessboard").strip()
        marker = meta.get("board_marker")
        try:
            given["board"] = Board(int(_number(notes, "board_columns", source)), int(_number(notes, "board_rows",
                                   source)), float(meta["board_square"]) * 1e3,
                                   None if marker is None else float(marker) * 1e3,
                                   notes.get("board_dictionary", "DICT_5X5_100").strip(), kind)
        except ArgumentError as e:
            raise DataError(source, e.reason, None, "board_columns") from None
    keys = [f"camera_{n}_px" for n in ("fx", "fy", "cx", "cy", "width", "height")]
    stated = [k for k in keys + [f"camera_{n}" for n in INTRINSIC_NAMES[4:]] if k in notes]
    if stated:
        missing = [k for k in keys if k not in notes]
        if missing:
            raise DataError(source, f"intrinsics need {', '.join('# ' + k for k in keys)}; {missing[0]} is missing",
                            None, missing[0])
        values = [_number(notes, k, source) for k in keys]
        distortion = [_number(notes, f"camera_{n}", source) if f"camera_{n}" in notes else 0.0
                      for n in INTRINSIC_NAMES[4:]]
        try:
            given["intrinsics"] = intrinsics_of(values + distortion)
        except ArgumentError as e:
            raise DataError(source, e.reason, None, "camera_fx_px") from None
    try:
        return CameraSetup(**given) if given else None
    except ArgumentError as e:
        raise DataError(source, e.reason, None, e.argument) from None


def _number(notes: Mapping[str, str], key: str, source: str) -> float:
    try:
        return float(notes[key])
    except ValueError:
        raise DataError(source, f"'{notes[key][:40]}' is not a number", None, key) from None


def board_notes(board: Board) -> tuple[dict[str, str], dict[str, float]]:
    """The notes and set-up metadata [m] a camera set's file states for ``board``."""
    notes = {"board_kind": board.kind, "board_columns": str(board.columns), "board_rows": str(board.rows)}
    if board.kind == "charuco":
        notes["board_dictionary"] = board.dictionary
    meta = {"board_square": board.square_mm * 1e-3}
    if board.marker_mm is not None:
        meta["board_marker"] = board.marker_mm * 1e-3
    return notes, meta


def intrinsics_notes(k: Intrinsics) -> dict[str, str]:
    """The notes a camera set's file states for the lens ``k``."""
    notes = {f"camera_{n}_px": f"{getattr(k, n):.10g}" for n in ("fx", "fy", "cx", "cy", "width", "height")}
    notes.update({f"camera_{n}": f"{getattr(k, n):.10g}" for n in INTRINSIC_NAMES[4:]})
    return notes


def setup_notes(rig: CameraRig, noise_px: float | None) -> tuple[dict[str, str], dict[str, float]]:
    """The notes and set-up metadata [m] a camera set's file states for ``rig`` (:func:`setup_from_notes` reads them)."""
    board, meta = board_notes(rig.board)
    notes = {"camera_mount": rig.mount, **board, **intrinsics_notes(rig.intrinsics)}
    if noise_px:
        notes["noise_px"] = f"{noise_px:g}"
    return notes, meta


def corner_index(point_ids: Any, board: Board, data: MeasurementSet | None = None) -> np.ndarray:
    """Each row's corner index (its ``corner_id``), shape (n_rows,).

    Raises:
        DataError: a corner id that is not a whole number, or not a corner of ``board``,
            naming the file's line.
    """
    ids = np.asarray(point_ids, dtype=object).reshape(-1)
    source = (data.source if data is not None else "") or "corner_id"
    lines = data.lines if data is not None else None
    out = np.empty(len(ids), dtype=int)
    for r, value in enumerate(ids):
        text = str(value).strip()
        k = int(text) if text.lstrip("+-").isdigit() else -1
        if not 0 <= k < board.n_corners:
            line = None if lines is None else int(lines[r])
            raise DataError(source, f"{text[:40]} is not a corner of the board ({board.describe()}: ids 0 to "
                            f"{board.n_corners - 1}; another board's file?)", line, "corner_id")
        out[r] = k
    return out

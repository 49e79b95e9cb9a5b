"""A camera's lens and a printed calibration board: frozen records and the pinhole projection.

:class:`Intrinsics` is OpenCV's pinhole camera with its plumb-bob distortion (k1, k2, p1,
p2, k3): a point (X, Y, Z) of the camera frame (z along the optical axis, x to the right
of the image, y down) goes to

    x' = X / Z,  y' = Y / Z,  r^2 = x'^2 + y'^2,  radial = 1 + k1 r^2 + k2 r^4 + k3 r^6,
    x'' = x' radial + 2 p1 x' y' + p2 (r^2 + 2 x'^2),
    y'' = y' radial + p1 (r^2 + 2 y'^2) + 2 p2 x' y',
    u = fx x'' + cx,  v = fy y'' + cy   [px],

as ``cv2.projectPoints`` does; :meth:`Intrinsics.project` gives (u, v) and their analytic
derivatives with respect to the point and to the nine intrinsics.

:class:`Board` is a chessboard or a ChArUco board of ``columns`` x ``rows`` squares: its
inner corners, numbered as OpenCV's ChArUco board numbers them (id = row * (columns - 1)
+ column, from the corner nearest the board's origin), lie at ((column + 1) s, (row + 1) s,
0) in the board frame W (s the square size), whose z axis points into the board, away
from a camera that sees its printed face.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..exceptions import ArgumentError

#: The extra of calib-pin that installs OpenCV (opencv-python-headless).
OPENCV_EXTRA = "camera"
#: The kinds of board: a plain chessboard, or a ChArUco board (ArUco markers in its white squares).
BOARD_KINDS = ("charuco", "chessboard")
#: OpenCV's predefined ArUco dictionaries a ChArUco board may use.
ARUCO_DICTIONARIES = tuple(f"DICT_{bits}X{bits}_{n}" for bits in (4, 5, 6, 7) for n in (50, 100, 250, 1000)) + (
    "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10", "DICT_APRILTAG_36h11",
    "DICT_ARUCO_MIP_36h12")
#: The intrinsics in the order of :meth:`Intrinsics.vector` (and of a camera model's unknowns).
INTRINSIC_NAMES = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
#: Their units: pixels for the focal lengths and the principal point, none for the distortion.
INTRINSIC_UNITS = ("px",) * 4 + ("1",) * 5
#: Their typical sizes (how far a given value may be off): a few pixels, a percent of distortion.
INTRINSIC_SCALE = (5.0, 5.0, 5.0, 5.0, 0.01, 0.01, 1e-3, 1e-3, 0.01)


@dataclass(frozen=True)
class Board:
    """A printed calibration board.

    Attributes:
        columns, rows: Squares along the board's x and y axes (at least 2 each).
        square_mm: A square's side [mm].
        marker_mm: A ChArUco marker's side [mm] (None for a chessboard).
        dictionary: The ArUco dictionary's OpenCV name (``DICT_5X5_100``; a ChArUco board's).
        kind: ``charuco`` or ``chessboard``.

    Raises:
        ArgumentError: a count below 2, a size not positive, a marker not smaller than its
            square, an unknown kind.
    """

    columns: int
    rows: int
    square_mm: float
    marker_mm: float | None = None
    dictionary: str = "DICT_5X5_100"
    kind: str = "charuco"

    def __post_init__(self) -> None:
        if self.kind not in BOARD_KINDS:
            raise ArgumentError("board", f"kind '{self.kind}' is not one of {', '.join(BOARD_KINDS)}")
        for name in ("columns", "rows"):
            value = getattr(self, name)
            if not isinstance(value, int | np.integer) or not 2 <= int(value) <= 1000:
                raise ArgumentError("board", f"{name} {value!r:.20} is not a whole number of squares in [2, 1000]")
            object.__setattr__(self, name, int(value))
        if not (np.isfinite(self.square_mm) and 0 < self.square_mm < 1e4):
            raise ArgumentError("board", f"square size {self.square_mm!r:.20} mm is not a positive length below 10 m")
        object.__setattr__(self, "square_mm", float(self.square_mm))
        if self.kind == "charuco" and self.dictionary not in ARUCO_DICTIONARIES:
            raise ArgumentError("board", f"dictionary '{self.dictionary!s:.40}' is not one of OpenCV's ArUco "
                                f"dictionaries (DICT_4X4_50 ... DICT_7X7_1000, DICT_ARUCO_ORIGINAL, DICT_APRILTAG_36h11, "
                                "...)")
        if self.kind == "chessboard" and self.marker_mm is not None:
            raise ArgumentError("board", "marker size: a chessboard has no markers (marker_mm is a ChArUco board's)")
        if self.marker_mm is not None:
            if not (np.isfinite(self.marker_mm) and 0 < self.marker_mm < self.square_mm):
                raise ArgumentError("board", f"marker size {self.marker_mm!r:.20} mm is not positive and smaller than "
                                    f"the square ({self.square_mm:g} mm)")
            object.__setattr__(self, "marker_mm", float(self.marker_mm))

    @property
    def n_corners(self) -> int:
        """Inner corners: (columns - 1) x (rows - 1)."""
        return (self.columns - 1) * (self.rows - 1)

    @property
    def points(self) -> np.ndarray:
        """Each corner's point in the board frame, shape (n_corners, 3), [m], row by corner id."""
        ids = np.arange(self.n_corners)
        s = self.square_mm * 1e-3
        return np.column_stack([(ids % (self.columns - 1) + 1) * s, (ids // (self.columns - 1) + 1) * s,
                                np.zeros(len(ids))])

    @property
    def centre(self) -> np.ndarray:
        """The board's middle in its frame, shape (3,), [m]."""
        return np.array([self.columns, self.rows, 0.0]) * self.square_mm * 5e-4

    def describe(self) -> str:
        """``charuco 9x7 squares of 30 mm, markers 22 mm, DICT_5X5_100``."""
        marker = f", markers {self.marker_mm:g} mm, {self.dictionary}" if self.kind == "charuco" else ""
        return f"{self.kind} {self.columns}x{self.rows} squares of {self.square_mm:g} mm{marker}"

    def spec(self) -> str:
        """The ``--board`` text of this board (:func:`board_spec` reads it back)."""
        tail = f",{self.marker_mm:g},{self.dictionary}" if self.kind == "charuco" and self.marker_mm else ""
        return f"{self.kind},{self.columns}x{self.rows},{self.square_mm:g}{tail}"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "columns": self.columns, "rows": self.rows, "square_mm": self.square_mm,
                "marker_mm": self.marker_mm, "dictionary": self.dictionary}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> Board:
        return cls(int(doc["columns"]), int(doc["rows"]), float(doc["square_mm"]),
                   None if doc.get("marker_mm") is None else float(doc["marker_mm"]),
                   str(doc.get("dictionary", "DICT_5X5_100")), str(doc.get("kind", "charuco")))


@dataclass(frozen=True)
class LensSource:
    """Where a camera's intrinsics were read: a YAML file (:mod:`.lens_file`).

    Attributes:
        format: Its layout, ``opencv`` or ``ros`` (``camera_info``).
        path: The file as given.
        camera_name: ROS's ``camera_name`` ("" when it has none).
    """

    format: str
    path: str
    camera_name: str = ""


@dataclass(frozen=True)
class Intrinsics:
    """A camera's pinhole intrinsics and plumb-bob distortion (OpenCV's).

    Attributes:
        fx, fy: Focal lengths [px].
        cx, cy: Principal point [px].
        width, height: Image size [px].
        k1, k2, p1, p2, k3: Distortion coefficients (no unit).
        source: The file they were read from (None: numbers, notes); not part of the
            values (two records of equal numbers are equal).

    Raises:
        ArgumentError: a focal length or image size not positive, a value not finite.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0
    k3: float = 0.0
    source: LensSource | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        for name in INTRINSIC_NAMES:
            value = getattr(self, name)
            if not isinstance(value, int | float | np.integer | np.floating) or not np.isfinite(value):
                raise ArgumentError("intrinsics", f"{name} {value!r:.20} is not a finite number")
            object.__setattr__(self, name, float(value))
        for name in ("width", "height"):
            value = getattr(self, name)
            if not isinstance(value, int | float | np.integer | np.floating) or not float(value).is_integer() \
                    or not 0 < value <= 100_000:
                raise ArgumentError("intrinsics", f"image {name} {value!r:.20} is not a whole number of pixels in "
                                    "[1, 100000]")
            object.__setattr__(self, name, int(value))
        if not (self.fx > 0 and self.fy > 0):
            raise ArgumentError("intrinsics", f"focal lengths must be positive, got fx {self.fx:g}, fy {self.fy:g} px")

    def vector(self) -> np.ndarray:
        """The nine intrinsics in :data:`INTRINSIC_NAMES`' order."""
        return np.array([getattr(self, n) for n in INTRINSIC_NAMES])

    def with_vector(self, v: np.ndarray) -> Intrinsics:
        """The same image size and source with the nine intrinsics ``v`` (:data:`INTRINSIC_NAMES`' order)."""
        values = {n: float(x) for n, x in zip(INTRINSIC_NAMES, v, strict=True)}
        return Intrinsics(width=self.width, height=self.height, source=self.source, **values)

    def matrix(self) -> np.ndarray:
        """OpenCV's camera matrix K, shape (3, 3)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def distortion(self) -> np.ndarray:
        """OpenCV's distortion coefficients (k1, k2, p1, p2, k3), shape (5,)."""
        return np.array([self.k1, self.k2, self.p1, self.p2, self.k3])

    def inside(self, uv: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Which image points (n, 2) [px] lie in the image, ``margin`` px inside its edges."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        return (uv[:, 0] >= -0.5 + margin) & (uv[:, 0] <= self.width - 0.5 - margin) \
            & (uv[:, 1] >= -0.5 + margin) & (uv[:, 1] <= self.height - 0.5 - margin)

    def project(self, points: np.ndarray, jacobian: bool = False) -> tuple[np.ndarray, Any, Any]:
        """Image points of camera-frame points: :func:`project` with these intrinsics."""
        return project(self.vector(), points, jacobian)

    def describe(self) -> str:
        """``1280x1024 px, fx 1000, fy 1000, cx 640, cy 512 px, k1 -0.05 ...``."""
        dist = ", ".join(f"{n} {getattr(self, n):.4g}" for n in INTRINSIC_NAMES[4:] if getattr(self, n))
        return (f"{self.width}x{self.height} px, fx {self.fx:.6g}, fy {self.fy:.6g}, cx {self.cx:.6g}, "
                f"cy {self.cy:.6g} px" + (f", {dist}" if dist else ""))

    def spec(self) -> str:
        """The ``--intrinsics`` text of these intrinsics (:func:`intrinsics_spec` reads it back)."""
        return ",".join(f"{v:.10g}" for v in (self.fx, self.fy, self.cx, self.cy, self.width, self.height,
                                               *self.distortion()))

    def to_dict(self) -> dict[str, Any]:
        return {**{n: getattr(self, n) for n in INTRINSIC_NAMES[:4]}, "width": self.width, "height": self.height,
                **{n: getattr(self, n) for n in INTRINSIC_NAMES[4:]}}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> Intrinsics:
        return cls(**{n: doc[n] for n in (*INTRINSIC_NAMES[:4], "width", "height")},
                   **{n: doc.get(n, 0.0) for n in INTRINSIC_NAMES[4:]})


def project(k: np.ndarray, points: np.ndarray, jacobian: bool = False) -> tuple[np.ndarray, Any, Any]:
    """Image points of camera-frame points (module docstring), with their derivatives.

    Args:
        k: The nine intrinsics in :data:`INTRINSIC_NAMES`' order (fx, fy, cx, cy [px], k1,
            k2, p1, p2, k3).
        points: Camera-frame points, shape (n, 3), [m] (z > 0: in front).
        jacobian: Also the derivatives.

    Returns:
        (u, v) shape (n, 2) [px]; with ``jacobian`` their derivative with respect to the
        point, shape (n, 2, 3) [px/m], and to the intrinsics, shape (n, 2, 9); else None, None.
    """
    fx, fy, cx, cy, k1, k2, p1, p2, k3 = (float(v) for v in k)
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    z = p[:, 2]
    x, y = p[:, 0] / z, p[:, 1] / z
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    uv = np.column_stack([fx * xd + cx, fy * yd + cy])
    if not jacobian:
        return uv, None, None
    d = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # d radial / d r^2
    dxd_dx = radial + 2 * x * x * d + 2 * p1 * y + 6 * p2 * x
    cross = 2 * x * y * d + 2 * p1 * x + 2 * p2 * y  # d xd / d y = d yd / d x
    dyd_dy = radial + 2 * y * y * d + 6 * p1 * y + 2 * p2 * x
    n = len(p)
    d_norm = np.zeros((n, 2, 2))  # d (u, v) / d (x', y')
    d_norm[:, 0, 0], d_norm[:, 0, 1] = fx * dxd_dx, fx * cross
    d_norm[:, 1, 0], d_norm[:, 1, 1] = fy * cross, fy * dyd_dy
    d_proj = np.zeros((n, 2, 3))  # d (x', y') / d (X, Y, Z)
    d_proj[:, 0, 0] = d_proj[:, 1, 1] = 1.0 / z
    d_proj[:, 0, 2], d_proj[:, 1, 2] = -x / z, -y / z
    d_intr = np.zeros((n, 2, 9))
    d_intr[:, 0, 0], d_intr[:, 1, 1] = xd, yd
    d_intr[:, 0, 2] = d_intr[:, 1, 3] = 1.0
    r4 = r2 * r2
    for col, power in ((4, r2), (5, r4), (8, r4 * r2)):  # k1, k2, k3
        d_intr[:, 0, col], d_intr[:, 1, col] = fx * x * power, fy * y * power
    d_intr[:, 0, 6], d_intr[:, 1, 6] = fx * 2 * x * y, fy * (r2 + 2 * y * y)  # p1
    d_intr[:, 0, 7], d_intr[:, 1, 7] = fx * (r2 + 2 * x * x), fy * 2 * x * y  # p2
    return uv, d_norm @ d_proj, d_intr


def intrinsics_of(values: list[float]) -> Intrinsics:
    """Intrinsics of ``fx, fy, cx, cy, width, height`` [px] and, optionally, ``k1, k2, p1, p2, k3``."""
    fx, fy, cx, cy, width, height = values[:6]
    distortion = dict(zip(INTRINSIC_NAMES[4:], values[6:], strict=False))
    size = [int(v) if float(v).is_integer() else v for v in (width, height)]
    return Intrinsics(fx, fy, cx, cy, size[0], size[1], **distortion)  # type: ignore[arg-type]


def board_spec(text: str) -> Board:
    """``--board``: ``charuco,COLSxROWS,SQUARE_MM,MARKER_MM[,DICT]`` or ``chessboard,COLSxROWS,SQUARE_MM``."""
    parts = [p.strip() for p in str(text).split(",")]
    shape = re.fullmatch(r"(\d+)\s*[xX]\s*(\d+)", parts[1]) if len(parts) > 1 else None
    try:
        if shape is None or parts[0] not in BOARD_KINDS:
            raise ValueError
        columns, rows = int(shape.group(1)), int(shape.group(2))
        if parts[0] == "chessboard" and len(parts) == 3:
            return Board(columns, rows, float(parts[2]), None, "", "chessboard")
        if parts[0] == "charuco" and len(parts) in (4, 5):
            return Board(columns, rows, float(parts[2]), float(parts[3]),
                         parts[4] if len(parts) == 5 else "DICT_5X5_100", "charuco")
        raise ValueError
    except (ValueError, ArgumentError) as e:
        why = f": {e.reason}" if isinstance(e, ArgumentError) else ""
        raise argparse.ArgumentTypeError(f"expected 'charuco,COLSxROWS,SQUARE_MM,MARKER_MM[,DICT]' or "
                                         f"'chessboard,COLSxROWS,SQUARE_MM', got '{str(text)[:60]}'{why}") from None


def intrinsics_spec(text: str) -> Intrinsics:
    """``--intrinsics``: ``fx,fy,cx,cy,width,height`` [px], then optionally ``k1,k2,p1,p2,k3``."""
    try:
        values = [float(p) for p in str(text).replace(";", ",").split(",") if p.strip()]
        if len(values) not in (6, 11):
            raise ValueError
        return intrinsics_of(values)
    except (ValueError, ArgumentError) as e:
        why = f": {e.reason}" if isinstance(e, ArgumentError) else ""
        raise argparse.ArgumentTypeError(f"expected 'fx,fy,cx,cy,width,height[,k1,k2,p1,p2,k3]' (px; 6 or 11 "
                                         f"numbers), got '{str(text)[:60]}'{why}") from None

"""A camera's intrinsics in a YAML file: OpenCV's and ROS's ``camera_info``, read and written.

Two layouts (:data:`LENS_FORMATS`):

- ``opencv``: what ``cv2.FileStorage`` writes and OpenCV's calibration sample reads:
  ``image_width``, ``image_height`` [px], ``camera_matrix`` (an ``!!opencv-matrix`` 3x3)
  and ``distortion_coefficients`` (an ``!!opencv-matrix`` of 4 or 5: k1, k2, p1, p2[, k3]);
  the file starts with ``%YAML:1.0`` (or ``%YAML 1.2``);
- ``ros``: ``camera_calibration_parsers``' ``camera_info`` YAML: ``image_width``,
  ``image_height``, ``camera_name``, ``camera_matrix`` ``{rows: 3, cols: 3, data: [9]}``,
  ``distortion_model`` (``plumb_bob``), ``distortion_coefficients`` ``{rows: 1, cols: 5,
  data: [5]}``, ``rectification_matrix`` and ``projection_matrix``.

Both are read with PyYAML (OpenCV's directive and matrix tag taken as what they say), so a
mistake is named by file, line and key without OpenCV. A camera matrix must be a pinhole's
(no skew, last row 0 0 1). Distortion beyond the plumb bob's five (OpenCV's 8, 12 or 14, ROS's
``rational_polynomial``) is taken when the extra terms are zero, else refused, as is another
model (``equidistant``). :func:`intrinsics_text` writes intrinsics back in either layout.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np

from ..exceptions import ArgumentError, DataError
from .lens import OPENCV_EXTRA, Board, Intrinsics, LensSource, board_spec, intrinsics_spec

#: The YAML layouts of a camera's intrinsics (module docstring).
LENS_FORMATS = ("opencv", "ros")
#: File names taken as a lens file by ``--intrinsics`` (any other text is the numbers).
LENS_SUFFIXES = (".yaml", ".yml")
#: ROS's distortion models calib-pin's lens is (the plumb bob; the rational model with its extra terms zero).
ROS_MODELS = ("plumb_bob", "rational_polynomial")
#: The keys each layout needs.
REQUIRED = {"opencv": ("image_width", "image_height", "camera_matrix", "distortion_coefficients"),
            "ros": ("image_width", "image_height", "camera_matrix", "distortion_model", "distortion_coefficients")}
#: OpenCV's distortion vectors: 4, 5, 8, 12 or 14 numbers (k1, k2, p1, p2, k3, k4, k5, k6, s1..s4, tx, ty).
OPENCV_LENGTHS = (4, 5, 8, 12, 14)


def _read_text(path: str | Path, what: str) -> tuple[str, str]:
    """A lens or board file's name and its UTF-8 text.

    Raises:
        DataError: it cannot be read, naming the file and ``what`` it should hold.
    """
    try:
        return str(path), Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        why = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        raise DataError(str(path), f"cannot read {what}: {why}") from None


def read_intrinsics(path: str | Path) -> Intrinsics:
    """The intrinsics of an OpenCV or ROS ``camera_info`` YAML file (module docstring).

    The record remembers the layout and camera name (:class:`~calib_pin.sensors.lens.LensSource`),
    so that a calibration writes them back alike.

    Raises:
        DataError: an unreadable file, not YAML, a missing key, a matrix of the wrong shape,
            a camera matrix with skew, a distortion model the lens has not: naming the file,
            and the line and key where it can.
    """
    source, text = _read_text(path, "the camera's intrinsics")
    fmt = "opencv" if _is_opencv(text) else "ros"
    doc = _load(source, _opencv_as_yaml(text) if fmt == "opencv" else text)
    lines = doc.pop("__lines__")
    missing = [key for key in REQUIRED[fmt] if key not in doc]
    if missing:
        what = "an OpenCV camera file" if fmt == "opencv" else "a ROS camera_info file"
        raise DataError(source, f"missing ({what} has {', '.join(REQUIRED[fmt])})", None, missing[0])

    def where(key: str) -> int | None:
        return lines.get(key)

    k = _matrix(source, doc["camera_matrix"], (3, 3), "camera_matrix", where("camera_matrix"))
    scale = max(abs(k[0, 0]), abs(k[1, 1]), 1.0)
    if abs(k[1, 0]) > 1e-9 * scale or np.max(np.abs(k[2] - [0.0, 0.0, 1.0])) > 1e-9 or abs(k[0, 1]) > 1e-6 * scale:
        raise DataError(source, f"not a pinhole camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (got "
                        f"{_rows(k)}: skew, or a matrix of another kind)", where("camera_matrix"), "camera_matrix")
    distortion = _distortion(source, doc, fmt, where)
    sizes = [_whole(source, doc[key], key, where(key)) for key in ("image_width", "image_height")]
    name = str(doc.get("camera_name") or "") if fmt == "ros" else ""
    try:
        k1, k2, p1, p2, k3 = distortion
        return Intrinsics(float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2]), sizes[0], sizes[1],
                          k1, k2, p1, p2, k3, LensSource(fmt, source, name))
    except ArgumentError as e:
        field = "image_width" if "width" in e.reason else "image_height" if "height" in e.reason else "camera_matrix"
        raise DataError(source, e.reason, where(field), field) from None


def _is_opencv(text: str) -> bool:
    """A file OpenCV wrote: its ``%YAML:1.0`` directive, or a matrix tagged ``!!opencv-matrix``."""
    first = next((line for line in text.splitlines() if line.strip()), "")
    return first.startswith("%YAML:") or "!!opencv-matrix" in text


def _opencv_as_yaml(text: str) -> str:
    """OpenCV's YAML as YAML 1.1 reads it: its ``%YAML:1.0`` directive blanked (the lines kept)."""
    return re.sub(r"\A(\s*)%YAML:[^\n]*", r"\1", text)


def _load(source: str, text: str, what: str = "not a camera file: expected keys (image_width, camera_matrix, ...)"
          ) -> dict[str, Any]:
    """The top-level mapping of a YAML text, with ``__lines__``: each key's 1-based line.

    Raises:
        DataError: not YAML, or not a mapping, naming the line.
    """
    import yaml  # PyYAML: imported when a lens file is read

    class Loader(yaml.SafeLoader):
        pass

    def matrix(loader: yaml.SafeLoader, node: yaml.Node) -> Any:
        return loader.construct_mapping(node, deep=True) if isinstance(node, yaml.MappingNode) else \
            loader.construct_object(node, deep=True)

    for tag in ("opencv-matrix", "opencv-nd-matrix"):
        Loader.add_constructor(f"tag:yaml.org,2002:{tag}", matrix)
    try:
        loader = Loader(text)
        try:
            node = loader.get_single_node()
            doc = loader.construct_document(node) if node is not None else None
        finally:
            loader.dispose()
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = None if mark is None else mark.line + 1
        what = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise DataError(source, f"not valid YAML: {what}", line) from None
    if not isinstance(doc, dict):
        raise DataError(source, f"{what}, got {type(doc).__name__ if doc is not None else 'nothing'}")
    lines = {str(k.value): k.start_mark.line + 1 for k, _ in node.value} if isinstance(node, yaml.MappingNode) else {}
    return {**{str(k): v for k, v in doc.items()}, "__lines__": lines}


def _matrix(source: str, value: Any, shape: tuple[int, int] | None, key: str, line: int | None) -> np.ndarray:
    """A matrix value: ``{rows, cols, data}`` (ROS's, OpenCV's) or a (nested) list, of ``shape``.

    ``shape`` None: a vector of any length, returned flat.

    Raises:
        DataError: not numbers, ``rows * cols`` not the data's length, another shape.
    """
    declared = None
    data = value
    if isinstance(value, Mapping):
        if "data" not in value:
            raise DataError(source, "a matrix needs rows, cols and data", line, key)
        data = value["data"]
        if "rows" in value or "cols" in value:
            try:
                declared = (int(value["rows"]), int(value["cols"]))
            except (KeyError, TypeError, ValueError):
                raise DataError(source, "a matrix needs whole numbers rows and cols beside its data", line, key) from None
    try:
        array = np.asarray(data, dtype=float)
    except (TypeError, ValueError):
        raise DataError(source, f"expected numbers, got {str(data)[:60]!r}", line, key) from None
    if array.ndim == 0 or not np.all(np.isfinite(array)):
        raise DataError(source, f"expected finite numbers, got {str(data)[:60]!r}", line, key)
    if declared is not None:
        if declared[0] * declared[1] != array.size:
            raise DataError(source, f"rows {declared[0]} x cols {declared[1]} is not the {array.size} numbers of its "
                            "data", line, key)
        array = array.reshape(declared)
    if shape is None:
        if array.ndim > 2 or (array.ndim == 2 and min(array.shape) != 1):
            raise DataError(source, f"expected a vector (1 row or 1 column), got {array.shape[0]}x{array.shape[1]}",
                            line, key)
        return array.reshape(-1)
    if array.ndim == 1 and declared is None and array.size == shape[0] * shape[1]:
        array = array.reshape(shape)
    if array.shape != shape:
        got = "x".join(str(n) for n in array.shape) if array.ndim == 2 else f"{array.size} numbers"
        raise DataError(source, f"expected a {shape[0]}x{shape[1]} matrix, got {got}", line, key)
    return array


def _distortion(source: str, doc: Mapping[str, Any], fmt: str, where: Any) -> list[float]:
    """k1, k2, p1, p2, k3 of the file's distortion (module docstring).

    Raises:
        DataError: another model, another count, extra terms not zero.
    """
    key = "distortion_coefficients"
    values = _matrix(source, doc[key], None, key, where(key))
    allowed: tuple[int, ...] = OPENCV_LENGTHS
    if fmt == "ros":
        model = str(doc["distortion_model"]).strip()
        if model not in ROS_MODELS:
            raise DataError(source, f"'{model[:40]}' is not a distortion model calib-pin's lens has (plumb_bob, the "
                            "radial and tangential k1, k2, p1, p2, k3; rational_polynomial with k4 = k5 = k6 = 0)",
                            where("distortion_model"), "distortion_model")
        allowed = (4, 5) if model == "plumb_bob" else (8,)
    if len(values) not in allowed:
        raise DataError(source, f"{len(values)} coefficients (expected {' or '.join(map(str, allowed))}: k1, k2, p1, "
                        "p2[, k3 ...])", where(key), key)
    if np.any(values[5:] != 0):
        raise DataError(source, f"coefficients beyond k1, k2, p1, p2, k3 are not zero ({_rows(values[5:])}): a "
                        "rational or thin-prism lens, which calib-pin's plumb-bob lens is not", where(key), key)
    return [float(v) for v in values[:5]] + [0.0] * (5 - min(len(values), 5))


def _whole(source: str, value: Any, key: str, line: int | None) -> int:
    """A whole number of pixels.

    Raises:
        DataError: not one, naming the key.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = float("nan")
    if not (np.isfinite(number) and number.is_integer() and 0 < number <= 100_000):
        raise DataError(source, f"expected a whole number of pixels in [1, 100000], got {str(value)[:40]!r}", line, key)
    return int(number)


def _rows(a: np.ndarray) -> str:
    return np.array2string(np.asarray(a), precision=6, separator=", ").replace("\n", "")


def _number(v: float) -> str:
    """The shortest text that reads back as ``v``, ``0`` for zero."""
    return "0" if v == 0 else repr(float(v))


def intrinsics_text(k: Intrinsics, fmt: str, camera_name: str = "camera", notes: Sequence[str] = ()) -> str:
    """``k`` as a YAML file of layout ``fmt`` (:data:`LENS_FORMATS`), ``notes`` as comments at its top.

    The ROS layout's ``projection_matrix`` is OpenCV's optimal new camera matrix at alpha 0 (what
    ROS's camera_calibration writes for a monocular camera), its rectification the identity.

    Raises:
        ArgumentError: an unknown layout.
        CalibPinError: OpenCV is not installed (the ROS layout's projection matrix).
    """
    if fmt not in LENS_FORMATS:
        raise ArgumentError("fmt", f"'{fmt}' is not one of {', '.join(LENS_FORMATS)}")
    comments = "".join(f"# {line}\n" for note in notes for line in note.splitlines())
    d = [_number(v) for v in k.distortion()]
    m = [_number(v) for v in k.matrix().reshape(-1)]
    if fmt == "opencv":
        def block(name: str, rows: int, cols: int, data: list[str]) -> str:
            return f"{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {', '.join(data)} ]\n"

        return ("%YAML:1.0\n---\n" + comments + f"image_width: {k.width}\nimage_height: {k.height}\n"
                + block("camera_matrix", 3, 3, m) + block("distortion_coefficients", 1, 5, d))
    p = _projection(k)

    def matrix(name: str, rows: int, cols: int, data: list[str]) -> str:
        return f"{name}:\n  rows: {rows}\n  cols: {cols}\n  data: [{', '.join(data)}]\n"

    return (comments + f"image_width: {k.width}\nimage_height: {k.height}\ncamera_name: {camera_name}\n"
            + matrix("camera_matrix", 3, 3, m) + "distortion_model: plumb_bob\n"
            + matrix("distortion_coefficients", 1, 5, d)
            + matrix("rectification_matrix", 3, 3, [_number(v) for v in np.eye(3).reshape(-1)])
            + matrix("projection_matrix", 3, 4, [_number(v) for v in p.reshape(-1)]))


def _projection(k: Intrinsics) -> np.ndarray:
    """ROS's projection matrix of a monocular camera: [K' | 0], K' OpenCV's optimal new camera matrix at alpha 0."""
    from ..util.optional import require

    cv2 = require("cv2", OPENCV_EXTRA)
    new, _ = cv2.getOptimalNewCameraMatrix(k.matrix(), k.distortion(), (k.width, k.height), 0.0)
    return np.column_stack([np.asarray(new, dtype=float), np.zeros(3)])


def intrinsics_argument(text: str) -> Intrinsics:
    """``--intrinsics``: a lens file (``.yaml``, ``.yml``: :func:`read_intrinsics`) or ``fx,fy,cx,cy,width,height[,...]``.

    Raises:
        argparse.ArgumentTypeError: naming the file and key, or the expected numbers.
    """
    return cast(Intrinsics, _file_or_text(text, read_intrinsics, intrinsics_spec))


def _file_or_text(text: str, read: Any, parse: Any) -> Any:
    """An option's value: ``read`` of a YAML file (``.yaml``, ``.yml``), else ``parse`` of its text.

    Raises:
        argparse.ArgumentTypeError: the file's refusal (naming the file and key), or the text's.
    """
    if Path(str(text).strip()).suffix.lower() in LENS_SUFFIXES:
        try:
            return read(str(text).strip())
        except DataError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    return parse(text)


#: A board file's keys: required, and those a ChArUco board adds (the dictionary optional).
BOARD_KEYS = ("kind", "columns", "rows", "square_mm")
CHARUCO_KEYS = ("marker_mm", "dictionary")


def read_board(path: str | Path) -> Board:
    """A printed board from a small YAML file (``--board board.yaml``).

    ``kind`` (charuco or chessboard), ``columns`` and ``rows`` (squares), ``square_mm``, and
    for a ChArUco board ``marker_mm`` and ``dictionary`` (default ``DICT_5X5_100``)::

        kind: charuco
        columns: 9
        rows: 7
        square_mm: 30
        marker_mm: 22
        dictionary: DICT_5X5_100

    Raises:
        DataError: the file cannot be read, is not YAML, misses a key or has one no board has,
            or a value no board takes, naming the file, the line and the key.
    """
    source, text = _read_text(path, "the board")
    doc = _load(source, text, "not a board file: expected keys (kind, columns, rows, square_mm, ...)")
    lines = doc.pop("__lines__")
    unknown = [k for k in doc if k not in BOARD_KEYS + CHARUCO_KEYS]
    if unknown:
        raise DataError(source, f"not a key of a board (it has {', '.join(BOARD_KEYS + CHARUCO_KEYS)})",
                        lines.get(unknown[0]), unknown[0])
    kind = str(doc.get("kind", "")).strip()
    need = BOARD_KEYS + (("marker_mm",) if kind == "charuco" else ())
    missing = [k for k in need if k not in doc]
    if missing:
        raise DataError(source, f"missing (a {kind or 'board'} file has {', '.join(need)})", None, missing[0])
    try:
        for key in ("columns", "rows"):
            if not float(doc[key]).is_integer():
                raise DataError(source, f"{doc[key]!s:.20} is not a whole number of squares", lines.get(key), key)
        columns, rows = int(float(doc["columns"])), int(float(doc["rows"]))
        square = float(doc["square_mm"])
        marker = float(doc["marker_mm"]) if kind == "charuco" or "marker_mm" in doc else None
    except (TypeError, ValueError):
        bad = next(k for k in ("columns", "rows", "square_mm", "marker_mm") if k in doc and not _is_number(doc[k]))
        raise DataError(source, f"expected a number, got {str(doc[bad])[:40]!r}", lines.get(bad), bad) from None
    try:
        dictionary = str(doc.get("dictionary", "DICT_5X5_100")).strip() if kind == "charuco" else ""
        return Board(columns, rows, square, marker, dictionary, kind)
    except ArgumentError as e:
        key = next((k for k, said in (("marker_mm", "marker size"), ("square_mm", "square size"), ("kind", "kind"),
                                      ("columns", "columns"), ("dictionary", "dictionary")) if e.reason.startswith(said)),
                   "rows")
        raise DataError(source, e.reason, lines.get(key), key) from None


def _is_number(value: Any) -> bool:
    try:
        float(value)
    except (TypeError, ValueError):
        return False
    return True


def board_argument(text: str) -> Board:
    """``--board``: a board file (``.yaml``, ``.yml``: :func:`read_board`) or its spec text (:func:`~.lens.board_spec`).

    Raises:
        argparse.ArgumentTypeError: naming the file and key, or the expected spec.
    """
    return cast(Board, _file_or_text(text, read_board, board_spec))


__all__ = ["BOARD_KEYS", "LENS_FORMATS", "board_argument", "intrinsics_argument", "intrinsics_text", "read_board",
           "read_intrinsics"]

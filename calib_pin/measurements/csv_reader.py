"""Reading measurement sets and pose lists from CSV files.

Format (one row a pose, or a marker at a pose)::

    # robot: irb120
    # anchor_mm: 700, 200, 0
    # tool_mm: 0, 0, 50
    # length_offset_mm: 0
    q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,length_mm
    12.5,-30.0,10.0,45.0,-20.0,90.0,612.345

- Leading ``# key: value`` lines are metadata, each key once. Known keys: ``robot``
  (a name or the URDF path given to the command), ``end_frame``, ``anchor_mm`` /
  ``anchor_m`` (P0 in the base frame), ``tool_mm`` / ``tool_m`` (the tool point in the end
  frame), ``length_offset_mm`` / ``length_offset_m`` (sensor zero offset), ``noise_mm`` /
  ``noise_m`` (the sensor's noise, 1 sigma). Other keys are kept as notes. A ``# key:``
  line after the header is refused (it would be ignored); other ``#`` lines are comments.
- Every column names its unit: ``q<i>_deg`` or ``q<i>_rad`` for each revolute joint of the
  chain (``q<i>_mm`` or ``q<i>_m`` for a prismatic one), ``length_mm`` or ``length_m``; an
  optional integer ``pose`` column labels rows.
- A *position* set (laser tracker, CMM) has ``x_mm, y_mm, z_mm`` (or ``_m``) instead of
  the length: a marker's position in the measuring device's frame, and an optional
  integer ``point_id`` naming the marker. Each (pose, point_id) pair appears once.
- Numbers are plain decimals (``1e-3`` allowed; ``1_0``, ``inf``, ``nan`` are not).
- Any problem raises :class:`~calib_pin.exceptions.DataError` naming the file, the line
  and the field, before anything is fitted.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import DataError
from ..input_files import check_regular
from ..robot.chain import Chain
from .dataset import MeasurementSet

#: Columns a compensated pose list carries beside the joints (calib-pin compensate); read past.
ANNOTATIONS = ("position_error_mm", "orientation_error_urad")
_JOINT = re.compile(r"^q(\d+)_(deg|rad|mm|m)$")
_LENGTH = re.compile(r"^length_(mm|m)$")
_COORD = re.compile(r"^([xyz])_(mm|m)$")
_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")
_INTEGER = re.compile(r"^[-+]?\d+$")
_VECTOR_KEYS = ("anchor", "tool")
_SCALAR_KEYS = ("length_offset", "noise")
#: Longest text quoted back in a message.
_QUOTE = 40
#: Largest field accepted, characters.
_FIELD_LIMIT = 1000


def quote(text: str) -> str:
    """Text for a message: control characters shown escaped, long text cut."""
    shown = repr(text.strip())[1:-1]
    return shown if len(shown) <= _QUOTE else shown[:_QUOTE] + "..."


def number(text: str, path: Path | str, line: int | None, name: str) -> float:
    """A finite decimal number, or a DataError naming the place."""
    t = text.strip()
    if t.lower().lstrip("+-") in ("nan", "inf", "infinity"):
        raise DataError(str(path), f"'{quote(text)}' is not a finite number", line, name)
    if not _NUMBER.match(t):
        raise DataError(str(path), f"'{quote(text)}' is not a number", line, name)
    value = float(t)
    if not math.isfinite(value) or abs(value) > 1e12:
        raise DataError(str(path), f"'{quote(text)}' is out of range", line, name)
    return value


def _integer(text: str, path: Path, line: int, name: str) -> int:
    t = text.strip()
    if not _INTEGER.match(t) or len(t) > 15:
        raise DataError(str(path), f"'{quote(text)}' is not a whole number", line, name)
    return int(t)


def _metadata_value(key: str, text: str, path: Path, line: int) -> tuple[str, Any] | None:
    """Convert one metadata value to SI; (name, value) or None for a note."""
    base, _, unit = key.rpartition("_")
    scale = {"mm": 1e-3, "m": 1.0}.get(unit)
    if base in _VECTOR_KEYS and scale:
        parts = [p for p in re.split(r"[,\s]+", text.strip()) if p]
        if len(parts) != 3:
            raise DataError(str(path), f"needs 3 numbers (x, y, z), got '{quote(text)}'", line, key)
        return base, np.array([number(p, path, line, key) for p in parts]) * scale
    if base in _SCALAR_KEYS and scale:
        value = number(text, path, line, key) * scale
        if base == "noise" and value <= 0:
            raise DataError(str(path), f"{text.strip()} must be positive", line, key)
        return base, value
    if key in ("robot", "end_frame"):
        return key, text.strip()
    return None


@dataclass
class _Columns:
    joints: dict[int, tuple[int, str]] = field(default_factory=dict)
    length: tuple[int, str] | None = None
    coords: dict[str, tuple[int, str]] = field(default_factory=dict)
    pose: int | None = None
    point: int | None = None

    @property
    def position(self) -> bool:
        return bool(self.coords) or self.point is not None


@dataclass
class _Parsed:
    meta: dict[str, Any] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)
    header: list[str] | None = None
    header_line: int = 0
    rows: list[tuple[int, list[str]]] = field(default_factory=list)


def _read_text(path: Path, data: bytes | None = None) -> str:
    try:
        if data is None:
            check_regular(path)  # /dev/zero would be read for ever
        data = path.read_bytes() if data is None else data
    except FileNotFoundError:
        raise DataError(str(path), "no such file") from None
    except IsADirectoryError:
        raise DataError(str(path), "is a folder, not a CSV file") from None
    except OSError as e:
        raise DataError(str(path), f"cannot be read: {e.strerror or e}") from None
    if b"\0" in data:
        raise DataError(str(path), "is not a text file (it holds NUL bytes)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise DataError(str(path), f"is not UTF-8 text (byte {e.start})") from None


def _metadata_line(parsed: _Parsed, stripped: str, path: Path, number_: int) -> None:
    key, _, value = stripped[1:].partition(":")
    key = key.strip()
    if parsed.header is not None:
        raise DataError(str(path), "metadata after the header line is not read: move it above the header",
                        number_, key)
    converted = _metadata_value(key, value, path, number_)
    name = converted[0] if converted else key
    if name in parsed.meta or key in parsed.notes:
        raise DataError(str(path), "metadata given twice", number_, key)
    if converted is None:
        parsed.notes[key] = value.strip()
    else:
        parsed.meta[name] = converted[1]


def _split(text: str, path: Path) -> _Parsed:
    parsed = _Parsed()
    for number_, raw in enumerate(text.splitlines(), start=1):
        stripped = raw.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            if re.match(r"^#\s*[A-Za-z_][\w.]*\s*:", stripped):
                _metadata_line(parsed, stripped, path, number_)
            continue
        if len(raw) > _FIELD_LIMIT * 20:
            raise DataError(str(path), f"line of {len(raw)} characters is too long for a measurement row", number_)
        try:
            fields = next(csv.reader([raw]))
        except csv.Error as e:
            raise DataError(str(path), f"not a CSV row ({e})", number_) from None
        if parsed.header is None:
            parsed.header, parsed.header_line = [f.strip() for f in fields], number_
        else:
            parsed.rows.append((number_, fields))
    return parsed


def _columns(header: list[str], path: Path, line: int) -> _Columns:
    cols = _Columns()
    for col, name in enumerate(header):
        if name in header[:col]:
            raise DataError(str(path), "column appears twice", line, quote(name))
        if m := _JOINT.match(name):
            if int(m.group(1)) in cols.joints:
                raise DataError(str(path), f"joint {m.group(1)} has two columns ({header[cols.joints[int(m.group(1))][0]]} "
                                f"and {name}): keep one", line, name)
            cols.joints[int(m.group(1))] = (col, m.group(2))
        elif m := _LENGTH.match(name):
            if cols.length is not None:
                raise DataError(str(path), "two length columns (length_mm and length_m): keep one", line, name)
            cols.length = (col, m.group(1))
        elif m := _COORD.match(name):
            if m.group(1) in cols.coords:
                raise DataError(str(path), f"two {m.group(1)} columns (mm and m): keep one", line, name)
            cols.coords[m.group(1)] = (col, m.group(2))
        elif name in ANNOTATIONS:
            continue  # what calib-pin compensate adds to the joint targets; not data
        elif name == "pose":
            cols.pose = col
        elif name == "point_id":
            cols.point = col
        else:
            raise DataError(
                str(path), "unknown column (expected q<i>_deg or q<i>_rad, length_mm or length_m, "
                "x_mm/y_mm/z_mm, pose, point_id)", line, quote(name) or f"column {col + 1}")
    return cols


def _check_columns(cols: _Columns, chain: Chain | None, path: Path, line: int, readings: bool) -> int:
    n_joints = chain.n_joints if chain is not None else len(cols.joints)
    expected = set(range(1, n_joints + 1))
    if chain is not None and set(cols.joints) - expected:
        extra = sorted(set(cols.joints) - expected)
        raise DataError(str(path), f"has joint column q{extra[0]} but robot '{chain.name}' has {n_joints} "
                        f"joints to '{chain.end_frame}'", line)
    for i in sorted(expected):
        if i not in cols.joints:
            raise DataError(str(path), f"missing column q{i}_deg (or q{i}_rad; q{i}_mm for a prismatic joint)", line)
    if cols.position and cols.length is not None:
        raise DataError(str(path), "has both length and x/y/z columns: one set holds one sensor's data", line)
    if cols.position:
        for axis in "xyz":
            if axis not in cols.coords:
                raise DataError(str(path), f"missing column {axis}_mm (or {axis}_m) of a position set", line)
    if cols.length is None and readings and not cols.position:
        raise DataError(str(path), "missing column length_mm (or length_m)", line)
    return n_joints


def _angles(fields: list[str], header: list[str], cols: _Columns, chain: Chain | None, n_joints: int,
            path: Path, line: int) -> np.ndarray:
    q = np.empty(n_joints)
    for i in range(1, n_joints + 1):
        col, unit = cols.joints[i]
        value = number(fields[col], path, line, header[col])
        if chain is not None:
            prismatic = chain.joint_kinds[i - 1].startswith("JointModelP")
            if prismatic != (unit in ("m", "mm")):
                want = f"q{i}_mm or q{i}_m" if prismatic else f"q{i}_deg or q{i}_rad"
                kind = "prismatic" if prismatic else "revolute"
                raise DataError(str(path), f"{chain.joint_names[i - 1]} is {kind}: its column is {want}",
                                line, header[col])
        q[i - 1] = {"deg": math.radians(value), "mm": value * 1e-3}.get(unit, value)
        if chain is not None:
            lo, hi = chain.lower[i - 1], chain.upper[i - 1]
            if not lo - 1e-9 <= q[i - 1] <= hi + 1e-9:
                to_unit = {"deg": math.degrees, "mm": lambda v: v * 1e3}.get(unit, float)
                raise DataError(str(path), f"{value:g} is outside the limits of {chain.joint_names[i - 1]} "
                                f"[{to_unit(lo):g}, {to_unit(hi):g}] {unit}", line, header[col])
    return q


def _values(fields: list[str], header: list[str], cols: _Columns, path: Path, line: int) -> np.ndarray:
    if cols.position:
        out = np.empty(3)
        for a, axis in enumerate("xyz"):
            col, unit = cols.coords[axis]
            out[a] = number(fields[col], path, line, header[col]) * (1e-3 if unit == "mm" else 1.0)
        return out
    if cols.length is None:
        return np.array([np.nan])
    col, unit = cols.length
    length = number(fields[col], path, line, header[col])
    if length < 0:
        raise DataError(str(path), f"{length:g} is negative", line, header[col])
    return np.array([length * (1e-3 if unit == "mm" else 1.0)])


def _check_unique(pose_ids: np.ndarray, point_ids: np.ndarray | None, lines: list[int], path: Path) -> None:
    seen: set = set()
    for r, line in enumerate(lines):
        key = (int(pose_ids[r]), int(point_ids[r])) if point_ids is not None else int(pose_ids[r])
        if key in seen:
            what = f"pose {key[0]} point {key[1]}" if isinstance(key, tuple) else f"pose {key}"
            raise DataError(str(path), f"{what} appears twice", line, "pose")
        seen.add(key)


def read_measurements(
    path: str | Path, chain: Chain | None = None, *, readings: bool = True, allow_empty: bool = False,
    robot_label: str | None = None, content: bytes | None = None,
) -> MeasurementSet:
    """Read and check a measurement set (or, with ``readings=False``, a pose list).

    Args:
        path: CSV file.
        chain: Robot chain the set is for. When given, the joint columns must match its
            joints and every angle must lie within its URDF limits.
        readings: Require the sensor's columns. Without them (a pose list) the set's
            kind is ``poses`` and its values NaN.
        allow_empty: Accept a header with no data rows (a session not yet started).
        robot_label: What the user called the robot (a name or a URDF path); the file's
            ``# robot:`` may be either that or the robot's name.
        content: The file's bytes when already read (they are checked as ``path``'s).

    Raises:
        DataError: the file cannot be read, or a row, column or metadata value is wrong.
    """
    path = Path(path)
    parsed = _split(_read_text(path, content), path)
    header, line = parsed.header, parsed.header_line
    if header is None:
        raise DataError(str(path), "no header line (q1_deg, ..., length_mm) and no data")
    cols = _columns(header, path, line)
    n_joints = _check_columns(cols, chain, path, line, readings)
    if not parsed.rows and not allow_empty:
        raise DataError(str(path), "has a header but no data rows")
    n = len(parsed.rows)
    q = np.empty((n, n_joints))
    values = np.empty((n, 3 if cols.position else 1))
    pose_ids = np.empty(n, dtype=int)
    point_ids = np.ones(n, dtype=int)
    for r, (number_, fields) in enumerate(parsed.rows):
        if len(fields) != len(header):
            raise DataError(str(path), f"has {len(fields)} fields, the header has {len(header)}", number_)
        q[r] = _angles(fields, header, cols, chain, n_joints, path, number_)
        values[r] = _values(fields, header, cols, path, number_)
        if cols.pose is not None:
            pose_ids[r] = _integer(fields[cols.pose], path, number_, "pose")
        if cols.point is not None:
            point_ids[r] = _integer(fields[cols.point], path, number_, "point_id")
    lines = [number_ for number_, _ in parsed.rows]
    if cols.pose is not None:
        _check_unique(pose_ids, point_ids if cols.position else None, lines, path)
    meta = parsed.meta
    if chain is not None and meta.get("robot") not in (None, chain.name, robot_label):
        raise DataError(str(path), f"is for robot '{meta['robot']}', not '{chain.name}'", None, "robot")
    kind = "position" if cols.position else ("cable" if cols.length is not None else "poses")
    return MeasurementSet(
        q=q, values=values if cols.position else values[:, 0], kind=kind,
        anchor=meta.get("anchor"), tool=meta.get("tool"), length_offset=meta.get("length_offset", 0.0),
        noise=meta.get("noise"), robot=meta.get("robot"), end_frame=meta.get("end_frame"),
        lines=np.array(lines, dtype=int), source=str(path), notes=parsed.notes,
        pose_ids=pose_ids if cols.pose is not None else None,
        point_ids=point_ids if cols.position else None,
    )

"""Measurement sets: drawstring readings at known joint angles, as CSV files.

Format (one pose a row)::

    # robot: irb120
    # anchor_mm: 700, 200, 0
    # tool_mm: 0, 0, 50
    # length_offset_mm: 0
    q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,length_mm
    12.5,-30.0,10.0,45.0,-20.0,90.0,612.345

- Leading ``# key: value`` lines are metadata. Known keys: ``robot``, ``end_frame``,
  ``anchor_mm`` / ``anchor_m`` (P0 in the base frame), ``tool_mm`` / ``tool_m`` (hook
  point in the end frame), ``length_offset_mm`` / ``length_offset_m`` (sensor zero
  offset), ``noise_mm`` (the sensor's noise, 1 sigma). Other keys are kept as notes.
- Every column names its unit: ``q<i>_deg`` or ``q<i>_rad`` for each joint of the
  chain, ``length_mm`` or ``length_m``; an optional integer ``pose`` column labels rows.
- A *position* set (laser tracker, CMM) has ``x_mm, y_mm, z_mm`` (or ``_m``) instead of
  the length: a marker's position in the measuring device's frame, and an optional
  integer ``point_id`` naming the marker (several markers per pose; one marker if
  absent). Each (pose, point_id) pair appears once.
- Every value is checked; any problem raises :class:`~calib_pin.exceptions.DataError`
  naming the file, the line and the field.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .exceptions import DataError
from .model import Chain

_JOINT = re.compile(r"^q(\d+)_(deg|rad)$")
_LENGTH = re.compile(r"^length_(mm|m)$")
_COORD = re.compile(r"^([xyz])_(mm|m)$")
_VECTOR_KEYS = ("anchor", "tool")


@dataclass
class MeasurementSet:
    """Drawstring readings of one session.

    Attributes:
        q: Joint angles, shape (n_rows, n_joints), [rad].
        lengths: Sensor readings, shape (n_rows,), [m].
        anchor: P0 in the base frame, shape (3,), [m], or None if not given.
        tool: Hook point in the end frame, shape (3,), [m], or None if not given.
        length_offset: Sensor zero offset, [m] (0 if not given).
        noise: Sensor noise (1 sigma), [m], or None if not given.
        robot: Robot named in the file, or None.
        end_frame: End frame named in the file, or None.
        lines: 1-based file line of each row, shape (n_rows,).
        source: File the set was read from ("" if built in memory).
        notes: Other metadata, key to text.
        pose_ids: The ``pose`` column's labels, shape (n_rows,), or None without one.
        positions: For a position set, marker positions, shape (n_rows, 3), [m],
            device frame (``lengths`` is then NaN); None for readings.
        point_ids: For a position set, each row's marker label, shape (n_rows,).
    """

    q: np.ndarray
    lengths: np.ndarray
    anchor: np.ndarray | None = None
    tool: np.ndarray | None = None
    length_offset: float = 0.0
    noise: float | None = None
    robot: str | None = None
    end_frame: str | None = None
    lines: np.ndarray | None = None
    source: str = ""
    notes: dict[str, str] = field(default_factory=dict)
    pose_ids: np.ndarray | None = None
    positions: np.ndarray | None = None
    point_ids: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.q)

    @property
    def kind(self) -> str:
        """``cable`` (drawstring readings) or ``position``."""
        return "cable" if self.positions is None else "position"


def _number(text: str, path: Path, line: int, name: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DataError(path, f"'{text.strip()}' is not a number", line, name) from None
    if not math.isfinite(value):
        raise DataError(path, f"'{text.strip()}' is not a finite number", line, name)
    return value


def _metadata_value(key: str, text: str, path: Path, line: int):
    """Convert one metadata value to SI; (name, value) or None for a note."""
    base, _, unit = key.rpartition("_")
    scale = {"mm": 1e-3, "m": 1.0}.get(unit)
    if base in _VECTOR_KEYS and scale:
        parts = [p for p in re.split(r"[,\s]+", text.strip()) if p]
        if len(parts) != 3:
            raise DataError(path, f"needs 3 numbers (x, y, z), got '{text.strip()}'", line, key)
        return base, np.array([_number(p, path, line, key) for p in parts]) * scale
    if base in ("length_offset", "noise") and scale:
        value = _number(text, path, line, key) * scale
        if base == "noise" and value < 0:
            raise DataError(path, f"{text.strip()} is negative", line, key)
        return base, value
    if key in ("robot", "end_frame"):
        return key, text.strip()
    return None


def read_measurements(
    path: str | Path, chain: Chain | None = None, *, readings: bool = True, allow_empty: bool = False
) -> MeasurementSet:
    """Read and check a measurement set (or, with ``readings=False``, a pose list).

    Args:
        path: CSV file.
        chain: Robot chain the set is for. When given, the joint columns must match its
            joints and every angle must lie within its URDF limits.
        readings: Require the length column. Without it (a pose list) ``lengths`` is NaN.
        allow_empty: Accept a header with no data rows (a session not yet started).

    Raises:
        DataError: the file cannot be read, or a row, column or metadata value is wrong.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise DataError(path, "no such file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(path, f"cannot be read: {e}") from None
    meta: dict = {}
    notes: dict[str, str] = {}
    header: list[str] | None = None
    header_line = 0
    rows: list[tuple[int, list[str]]] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        stripped = raw.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            if header is None and ":" in stripped:
                key, _, value = stripped[1:].partition(":")
                key = key.strip()
                parsed = _metadata_value(key, value, path, number)
                if parsed is None:
                    notes[key] = value.strip()
                else:
                    meta[parsed[0]] = parsed[1]
            continue
        fields = next(csv.reader([raw]))
        if header is None:
            header, header_line = [f.strip() for f in fields], number
        else:
            rows.append((number, fields))
    if header is None:
        raise DataError(path, "no header line (q1_deg, ..., length_mm) and no data")

    joint_cols: dict[int, tuple[int, str]] = {}
    length_col: tuple[int, str] | None = None
    pose_col: int | None = None
    point_col: int | None = None
    coord_cols: dict[str, tuple[int, str]] = {}
    for col, name in enumerate(header):
        if name in header[:col]:
            raise DataError(path, "column appears twice", header_line, name)
        if m := _JOINT.match(name):
            joint_cols[int(m.group(1))] = (col, m.group(2))
        elif m := _LENGTH.match(name):
            length_col = (col, m.group(1))
        elif m := _COORD.match(name):
            coord_cols[m.group(1)] = (col, m.group(2))
        elif name == "pose":
            pose_col = col
        elif name == "point_id":
            point_col = col
        else:
            raise DataError(
                path,
                "unknown column (expected q<i>_deg or q<i>_rad, length_mm or length_m, "
                "x_mm/y_mm/z_mm, pose, point_id)",
                header_line,
                name or f"column {col + 1}",
            )
    n_joints = chain.n_joints if chain is not None else len(joint_cols)
    expected = set(range(1, n_joints + 1))
    if chain is not None and set(joint_cols) - expected:
        extra = sorted(set(joint_cols) - expected)
        raise DataError(
            path,
            f"has joint column q{extra[0]} but robot '{chain.name}' has {n_joints} joints "
            f"to '{chain.end_frame}'",
            header_line,
        )
    for i in sorted(expected):
        if i not in joint_cols:
            raise DataError(path, f"missing column q{i}_deg (or q{i}_rad)", header_line)
    position = bool(coord_cols) or point_col is not None
    if position and length_col is not None:
        raise DataError(path, "has both length and x/y/z columns: one set holds one sensor's data", header_line)
    if position:
        for axis in "xyz":
            if axis not in coord_cols:
                raise DataError(path, f"missing column {axis}_mm (or {axis}_m) of a position set", header_line)
    if length_col is None and readings and not position:
        raise DataError(path, "missing column length_mm (or length_m)", header_line)
    if not rows and not allow_empty:
        raise DataError(path, "has a header but no data rows")

    q = np.empty((len(rows), n_joints))
    lengths = np.full(len(rows), np.nan)
    pose_ids = np.empty(len(rows), dtype=int)
    positions = np.full((len(rows), 3), np.nan) if position else None
    point_ids = np.ones(len(rows), dtype=int) if position else None
    length_scale = 1e-3 if length_col and length_col[1] == "mm" else 1.0
    for r, (number, fields) in enumerate(rows):
        if len(fields) != len(header):
            raise DataError(
                path, f"has {len(fields)} fields, the header has {len(header)}", number
            )
        for i in range(1, n_joints + 1):
            col, unit = joint_cols[i]
            name = header[col]
            value = _number(fields[col], path, number, name)
            q[r, i - 1] = math.radians(value) if unit == "deg" else value
            if chain is not None:
                lo, hi = chain.lower[i - 1], chain.upper[i - 1]
                if not lo - 1e-9 <= q[r, i - 1] <= hi + 1e-9:
                    to_unit = math.degrees if unit == "deg" else float
                    raise DataError(
                        path,
                        f"{value:g} is outside the limits of {chain.joint_names[i - 1]} "
                        f"[{to_unit(lo):g}, {to_unit(hi):g}] {unit}",
                        number,
                        name,
                    )
        if length_col is not None:
            length = _number(fields[length_col[0]], path, number, header[length_col[0]])
            if length < 0:
                raise DataError(path, f"{length:g} is negative", number, header[length_col[0]])
            lengths[r] = length * length_scale
        if position:
            for a, axis in enumerate("xyz"):
                col, unit = coord_cols[axis]
                positions[r, a] = _number(fields[col], path, number, header[col]) * (1e-3 if unit == "mm" else 1.0)
        for col, name, target in ((pose_col, "pose", pose_ids), (point_col, "point_id", point_ids)):
            if col is not None:
                try:
                    target[r] = int(fields[col])
                except ValueError:
                    raise DataError(path, f"'{fields[col]}' is not a whole number", number, name) from None
    if pose_col is not None:
        seen: set = set()
        for r, (number, _) in enumerate(rows):
            key = (int(pose_ids[r]), int(point_ids[r])) if position else int(pose_ids[r])
            if key in seen:
                what = f"pose {key[0]} point {key[1]}" if position else f"pose {key}"
                raise DataError(path, f"{what} appears twice", number, "pose")
            seen.add(key)
    if chain is not None and meta.get("robot") not in (None, chain.name):
        raise DataError(
            path, f"is for robot '{meta['robot']}', not '{chain.name}'", None, "robot"
        )
    return MeasurementSet(
        q=q,
        lengths=lengths,
        anchor=meta.get("anchor"),
        tool=meta.get("tool"),
        length_offset=meta.get("length_offset", 0.0),
        noise=meta.get("noise"),
        robot=meta.get("robot"),
        end_frame=meta.get("end_frame"),
        lines=np.array([number for number, _ in rows]),
        source=str(path),
        notes=notes,
        pose_ids=pose_ids if pose_col is not None else None,
        positions=positions,
        point_ids=point_ids,
    )


def _mm(v: np.ndarray) -> str:
    return ", ".join(f"{x * 1e3:.6f}" for x in v)


def write_measurements(path: str | Path, data: MeasurementSet) -> None:
    """Write a measurement set in degrees and millimetres, metadata first.

    Angles are written with 9 decimals of a degree and lengths (or positions) with 6
    decimals of a millimetre (1 nm), far below any sensor's resolution. A position set
    is written with ``pose`` and ``point_id`` columns.
    """
    lines = []
    for key, value in (("robot", data.robot), ("end_frame", data.end_frame)):
        if value:
            lines.append(f"# {key}: {value}")
    if data.anchor is not None:
        lines.append(f"# anchor_mm: {_mm(data.anchor)}")
    if data.tool is not None:
        lines.append(f"# tool_mm: {_mm(data.tool)}")
    lines.append(f"# length_offset_mm: {data.length_offset * 1e3:.6f}")
    if data.noise is not None:
        lines.append(f"# noise_mm: {data.noise * 1e3:.6f}")
    lines += [f"# {k}: {v}" for k, v in data.notes.items()]
    n = data.q.shape[1]
    joints = [f"q{i}_deg" for i in range(1, n + 1)]
    angles = np.rad2deg(data.q)
    if data.kind == "position":
        poses = data.pose_ids if data.pose_ids is not None else np.arange(1, len(data) + 1)
        lines.append(",".join(["pose", "point_id"] + joints + ["x_mm", "y_mm", "z_mm"]))
        for k in range(len(data)):
            lines.append(",".join([str(int(poses[k])), str(int(data.point_ids[k]))]
                                  + [f"{v:.9f}" for v in angles[k]]
                                  + [f"{v * 1e3:.6f}" for v in data.positions[k]]))
    else:
        lines.append(",".join(joints + ["length_mm"]))
        for q, length in zip(angles, data.lengths, strict=True):
            lines.append(",".join([f"{v:.9f}" for v in q] + [f"{length * 1e3:.6f}"]))
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def write_poses(
    path: str | Path, q: np.ndarray, *, robot: str | None = None, end_frame: str | None = None,
    notes: dict[str, str] | None = None,
) -> None:
    """Write a pose list: ``pose,q1_deg,...`` with poses numbered from 1.

    Args:
        q: Joint angles, shape (n_poses, n_joints), [rad]; written in degrees with 9
            decimals.
    """
    lines = [f"# {k}: {v}" for k, v in (("robot", robot), ("end_frame", end_frame)) if v]
    lines += [f"# {k}: {v}" for k, v in (notes or {}).items()]
    lines.append(",".join(["pose"] + [f"q{i}_deg" for i in range(1, q.shape[1] + 1)]))
    for k, row in enumerate(np.rad2deg(q), start=1):
        lines.append(",".join([str(k)] + [f"{v:.9f}" for v in row]))
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")

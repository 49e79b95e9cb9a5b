"""Reading measurement sets and pose lists from CSV files.

Format (one row a pose, or a marker at a pose)::

    # robot: irb120
    # anchor_mm: 700, 200, 0
    # tool_mm: 0, 0, 50
    # length_offset_mm: 0
    q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,length_mm
    12.5,-30.0,10.0,45.0,-20.0,90.0,612.345

- Leading ``# key: value`` lines are metadata, each key once. Known keys: ``robot``
  (a name or the URDF path given to the command, the URDF's file stem or its ``<robot
  name>``), ``end_frame``, ``anchor_mm`` /
  ``anchor_m`` (P0 in the base frame), ``tool_mm`` / ``tool_m`` (the tool point in the end
  frame), ``length_offset_mm`` / ``length_offset_m`` (sensor zero offset), ``noise_mm`` /
  ``noise_m`` (the sensor's noise, 1 sigma), ``csv`` (the dialect, below). Other keys are
  kept as notes, but one that looks like a key calib-pin reads is refused (the rule:
  :mod:`calib_pin.measurements.metadata`). A ``# key:`` line after the header is refused
  (it would be ignored); other ``#`` lines are comments.
- Every column names its unit: ``q<i>_deg`` or ``q<i>_rad`` for each revolute joint of the
  chain (``q<i>_mm`` or ``q<i>_m`` for a prismatic one), ``length_mm`` or ``length_m``; an
  optional integer ``pose`` column labels rows.
- A *position* set (laser tracker, CMM) has ``x_mm, y_mm, z_mm`` (or ``_m``) instead of
  the length: a marker's position in the measuring device's frame, and an optional
  ``point_id`` naming the marker: whole numbers (``1``, ``2``) or text labels (``SMR1``,
  ``T2``, ``A``: up to 40 characters), one kind in a file. Each (pose, point_id) pair
  appears once.
- Other columns (a temperature, a standard deviation, a time stamp, a comment) are read
  and kept in :attr:`MeasurementSet.extra`, not used; a column that looks like one of
  calib-pin's but is not one is refused (the rule: :mod:`calib_pin.measurements.columns`).
- The separator is ``,``, ``;`` or a tab, and with ``;`` or a tab the decimal mark may be
  ``,`` (detected; the rule and the ``# csv:`` line: :mod:`calib_pin.measurements.dialect`).
  Numbers are plain decimals (``1e-3`` allowed; ``1_0``, ``inf``, ``nan`` are not).
- Any problem raises :class:`~calib_pin.exceptions.DataError` naming the file, the line
  and the field, before anything is fitted.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import DataError
from ..robot.chain import Chain, as_chain
from ..util.arguments import as_bool, as_optional, as_path
from ..util.input_files import check_regular
from .checks import check_robot, limits_of
from .columns import (
    ANNOTATIONS,
    Columns,
    check_columns,
    check_near_misses,
    classify,
    kind_of_columns,
    plain_columns,
    plugin_columns,
)
from .dataset import MeasurementSet, point_label
from .dialect import (
    KEY,
    SEPARATORS,
    Dialect,
    Override,
    as_number,
    decimal_mark,
    number,
    parse_override,
    quote,
    separator,
    shown_separator,
)
from .metadata import pair_key, read_metadata, scalar_samples, sets
from .schema import SCHEMAS

__all__ = ["ANNOTATIONS", "number", "quote", "read_measurements"]

_INTEGER = re.compile(r"^[-+]?\d+$")
#: Largest field accepted, characters.
_FIELD_LIMIT = 1000
#: Longest text label of a marker, characters.
_LABEL_LIMIT = 40


def _integer(text: str, path: Path, line: int, name: str) -> int:
    t = text.strip()
    if not _INTEGER.match(t) or len(t) > 15:
        raise DataError(str(path), f"'{quote(text)}' is not a whole number", line, name)
    return int(t)


@dataclass
class _Parsed:
    meta: dict[str, Any] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)
    raw_meta: list[tuple[int, str, str]] = field(default_factory=list)
    override: Override = field(default_factory=Override)
    header: list[str] | None = None
    header_line: int = 0
    raw_rows: list[tuple[int, str]] = field(default_factory=list)
    rows: list[tuple[int, list[str]]] = field(default_factory=list)
    dialect: Dialect = field(default_factory=Dialect)

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
    if key == KEY:
        if parsed.override.line is not None:
            raise DataError(str(path), "metadata given twice", number_, key)
        parsed.override = parse_override(value, path, number_)
        return
    if pair_key(key) is None and sets(key) in {sets(seen) for _, seen, _ in parsed.raw_meta}:
        # anchor_mm and anchor_m too; a pair key (# distance_mm: A, B, 300) may be given once a pair
        raise DataError(str(path), "metadata given twice", number_, key)
    parsed.raw_meta.append((number_, key, value))


def _split(text: str, path: Path) -> _Parsed:
    """Metadata, the header line and the data lines, as text (the dialect is not known yet)."""
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
        if parsed.header is None:
            parsed.header, parsed.header_line = [raw], number_
        else:
            parsed.raw_rows.append((number_, raw))
    return parsed


def _fields(raw: str, sep: str, path: Path, line: int) -> list[str]:
    try:
        return next(csv.reader([raw], delimiter=sep))
    except csv.Error as e:
        raise DataError(str(path), f"not a CSV row ({e})", line) from None


def _tokenize_header(parsed: _Parsed, path: Path) -> list[str]:
    """Split the header with the file's separator (found on it, or stated by ``# csv:``)."""
    assert parsed.header is not None
    raw_header = parsed.header[0]
    sep = separator(raw_header, parsed.override, path, parsed.header_line)
    parsed.header = [f.strip() for f in _fields(raw_header, sep, path, parsed.header_line)]
    parsed.dialect = Dialect(sep, ".")
    return parsed.header


def _tokenize_rows(parsed: _Parsed, path: Path) -> None:
    """Split the rows with the header's separator.

    Trailing blank fields beyond the header's are a trailing separator, dropped.
    """
    header, sep = parsed.header, parsed.dialect.sep
    assert header is not None
    others = [s for s in SEPARATORS.values() if s != sep]
    for number_, raw in parsed.raw_rows:
        fields = _fields(raw, sep, path, number_)
        if len(fields) > len(header) and not any(f.strip() for f in fields[len(header):]):
            fields = fields[: len(header)]
        if len(fields) != len(header):
            plural = "s" if len(fields) != 1 else ""
            looks = [o for o in others if o in raw and (o != "," or sep == "\t" or len(fields) == 1)]
            if len(fields) == 1 and len(header) > 1 and looks:
                raise DataError(str(path), f"has {len(fields)} field{plural} separated by {shown_separator(sep)} as the "
                                f"header, which has {len(header)}: the row looks {shown_separator(looks[0])}-separated; "
                                "use one separator", number_)
            raise DataError(str(path), f"has {len(fields)} field{plural}, the header has {len(header)}", number_)
        parsed.rows.append((number_, fields))


def _numeric_fields(parsed: _Parsed, cols: Columns):
    """(text, line, name) of every numeric field: what tells the decimal mark.

    The scalar metadata, then the rows' joints, lengths and coordinates.
    """
    assert parsed.header is not None
    yield from scalar_samples(parsed.raw_meta)
    numeric = [c for c, _ in cols.joints.values()] + [c for c, _ in cols.coords.values()]
    numeric += [cols.length[0]] if cols.length is not None else []
    numeric += [c for c, _ in cols.sensor.values()]
    numeric += list(cols.plain.values())
    for number_, fields in parsed.rows:
        for col in numeric:
            yield fields[col], number_, parsed.header[col]


def _angles(fields: list[str], header: list[str], cols: Columns, chain: Chain | None, n_joints: int,
            path: Path, line: int, decimal: str) -> np.ndarray:
    q = np.empty(n_joints)
    for i in range(1, n_joints + 1):
        col, unit = cols.joints[i]
        value = number(fields[col], path, line, header[col], decimal)
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
                                f"[{to_unit(lo):g}, {to_unit(hi):g}] {unit}{limits_of(chain, i - 1)}", line,
                                header[col])
    return q


#: A column of numbers as :func:`~calib_pin.measurements.dialect.number` reads each, one a line.
_NUMBERS = re.compile(r"(?:[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\n)*")


def _column(rows: list[tuple[int, list[str]]], col: int, decimal: str) -> np.ndarray | None:
    """Column ``col`` of every row as :func:`~calib_pin.measurements.dialect.number` reads it, in one pass.

    The same floats; None when any field is not a number it accepts (the row-by-row
    reading then names it).
    """
    texts = [fields[col].strip() for _, fields in rows]
    if decimal == ",":
        if any("." in t for t in texts):
            return None
        texts = [t.replace(",", ".") for t in texts]
    if not _NUMBERS.fullmatch("\n".join(texts) + "\n"):
        return None
    try:
        values = np.array(list(map(float, texts)), dtype=float)
    except ValueError:  # a field with a line break inside (a quoted one)
        return None
    if len(values) != len(rows) or not np.all(np.abs(values) <= 1e12):
        return None
    return values


def _rows_at_once(parsed: _Parsed, cols: Columns, chain: Chain | None, n_joints: int, width: int,
                  decimal: str) -> tuple[np.ndarray, np.ndarray] | None:
    """The joint angles (n, n_joints) and values (n, width) of every row, a column at a time.

    The numbers :func:`_angles` and :func:`_values` give row by row, to the bit.
    None when any row is one they refuse (they then name its line and column) or the
    columns are of a kind read only row by row (labels, a sensor's unit-free columns).
    """
    if cols.label_kind or cols.plain_kind or cols.plain:
        return None
    rows, n = parsed.rows, len(parsed.rows)
    q = np.empty((n, n_joints))
    for i in range(1, n_joints + 1):
        col, unit = cols.joints[i]
        if chain is not None and chain.joint_kinds[i - 1].startswith("JointModelP") != (unit in ("m", "mm")):
            return None
        value = _column(rows, col, decimal)
        if value is None:
            return None
        angle = np.radians(value) if unit == "deg" else value * 1e-3 if unit == "mm" else value  # as math.radians
        if chain is not None:
            lo, hi = chain.lower[i - 1], chain.upper[i - 1]
            if not np.all((lo - 1e-9 <= angle) & (angle <= hi + 1e-9)):
                return None
        q[:, i - 1] = angle
    if cols.sensor_kind:
        columns = list(cols.sensor.values())
    elif cols.position:
        columns = [cols.coords[axis] for axis in "xyz"]
    elif cols.length is None:
        return q, np.full((n, width), np.nan)
    else:
        columns = [cols.length]
    values = np.empty((n, width))
    for k, (col, unit) in enumerate(columns):
        value = _column(rows, col, decimal)
        if value is None or (not cols.sensor_kind and not cols.position and np.any(value < 0)):  # a negative length
            return None
        values[:, k] = value * (1e-3 if unit == "mm" else 1.0)
    return q, values


def _values(fields: list[str], header: list[str], cols: Columns, path: Path, line: int, decimal: str) -> np.ndarray:
    if cols.label_kind:  # a row that names what it touched holds no value
        return np.zeros(0)
    if cols.plain_kind:  # a sensor's unit-free columns after its value columns (a pose: x, y, z, then qw .. qz)
        plain = np.array([number(fields[col], path, line, header[col], decimal) for col in cols.plain.values()])
        if not SCHEMAS[cols.plain_kind].value_columns:  # unit-free values only (a camera's u_px, v_px)
            return plain
        return np.concatenate([_values(fields, header, replace(cols, plain={}, plain_kind=""), path, line, decimal),
                               plain])
    if cols.sensor_kind:  # a registered sensor's columns, in its order
        return np.array([number(fields[col], path, line, header[col], decimal) * (1e-3 if unit == "mm" else 1.0)
                         for col, unit in cols.sensor.values()])
    if cols.position:
        out = np.empty(3)
        for a, axis in enumerate("xyz"):
            col, unit = cols.coords[axis]
            out[a] = number(fields[col], path, line, header[col], decimal) * (1e-3 if unit == "mm" else 1.0)
        return out
    if cols.length is None:
        return np.array([np.nan])
    col, unit = cols.length
    length = number(fields[col], path, line, header[col], decimal)
    if length < 0:
        raise DataError(str(path), f"{length:g} is negative", line, header[col])
    return np.array([length * (1e-3 if unit == "mm" else 1.0)])


def _point_ids(parsed: _Parsed, col: int, path: Path, name: str = "point_id") -> np.ndarray:
    """The ``point_id`` column (or a kind's own, ``name``): ints when every label is a whole number, else text.

    Raises:
        DataError: an empty or over-long label, or whole numbers mixed with text labels.
    """
    texts = [(number_, fields[col].strip()) for number_, fields in parsed.rows]
    whole = [(n, t) for n, t in texts if _INTEGER.match(t) and len(t) <= 15]
    if len(whole) == len(texts):
        return np.array([int(t) for _, t in texts], dtype=int)
    for number_, text in texts:
        if not text:
            raise DataError(str(path), "empty: each row names the point it measured", number_, name)
        if len(text) > _LABEL_LIMIT or any(ord(c) < 32 or ord(c) == 127 for c in text):
            raise DataError(str(path), f"'{quote(text)}' is not a marker label (a whole number, or text of up to "
                            f"{_LABEL_LIMIT} printable characters)", number_, name)
    if whole:
        label = next((n, t) for n, t in texts if not (_INTEGER.match(t) and len(t) <= 15))
        raise DataError(str(path), f"mixes whole numbers ({whole[0][1]} on line {whole[0][0]}) and text labels "
                        f"({quote(label[1])} on line {label[0]}): use one kind (1, 2, ... or P1, P2, ...)",
                        whole[0][0] if whole[0][0] > label[0] else label[0], name)
    return np.array([t for _, t in texts], dtype=str)


def _labels(parsed: _Parsed, cols: Columns, path: Path) -> dict[str, np.ndarray]:
    """A sensor's label columns as text ('' where empty).

    Raises:
        DataError: an over-long label or one with control characters.
    """
    out = {}
    for name, col in cols.labels.items():
        texts = [(number_, fields[col].strip()) for number_, fields in parsed.rows]
        for number_, text in texts:
            if len(text) > _LABEL_LIMIT or any(ord(c) < 32 or ord(c) == 127 for c in text):
                raise DataError(str(path), f"'{quote(text)}' is not a label (text of up to {_LABEL_LIMIT} printable "
                                "characters)", number_, name)
        out[name] = np.array([t for _, t in texts], dtype=str)
    return out


def _extra(parsed: _Parsed, cols: Columns) -> dict[str, np.ndarray]:
    """The extra columns: numbers (empty fields NaN) when every field is one, else text."""
    named = dict(cols.extra)
    for col in cols.unnamed:
        if any(fields[col].strip() for _, fields in parsed.rows):
            named[col] = f"column {col + 1}"
    out: dict[str, np.ndarray] = {}
    for col in sorted(named):
        texts = [fields[col].strip() for _, fields in parsed.rows]
        values = [as_number(t, parsed.dialect.decimal) if t else np.nan for t in texts]
        numeric = all(v is not None for v in values) and any(t for t in texts)
        out[named[col]] = np.array(values, dtype=float) if numeric else np.array(texts, dtype=str)
    return out


def _check_unique(pose_ids: np.ndarray, point_ids: np.ndarray | None, lines: list[int], path: Path,
                  name: str = "point_id") -> None:
    if point_ids is None or point_ids.dtype.kind in "iu":  # whole numbers: every key distinct, at once
        keys = pose_ids[:, None] if point_ids is None else np.stack([pose_ids, point_ids], axis=1)
        if len(np.unique(keys, axis=0)) == len(keys):
            return
    seen: set = set()  # row by row: the first key seen twice, named
    for r, line in enumerate(lines):
        key = (int(pose_ids[r]), point_label(point_ids[r])) if point_ids is not None else int(pose_ids[r])
        if key in seen:
            point = "point" if name == "point_id" else name
            what = f"pose {key[0]} {point} {key[1]}" if isinstance(key, tuple) else f"pose {key}"
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
            ``# robot:`` may be that, the robot's name or its URDF's ``<robot name>``
            (checked first: another robot's file is named as such, not by its joints).
        content: The file's bytes when already read (they are checked as ``path``'s).

    Raises:
        ArgumentError: ``path`` is not a path, ``chain`` not a chain (calib_pin.load_chain).
        DataError: the file cannot be read, or a row, column or metadata value is wrong.
    """
    path = as_path(path, "path")
    chain = as_optional(as_chain, chain, "chain")
    readings, allow_empty = as_bool(readings, "readings"), as_bool(allow_empty, "allow_empty")
    return read_set(path, chain, readings=readings, allow_empty=allow_empty, robot_label=robot_label, content=content)


def read_set(path: Path, chain: Chain | None, *, readings: bool = True, allow_empty: bool = False,
             robot_label: str | None = None, content: bytes | None = None) -> MeasurementSet:
    """:func:`read_measurements` of arguments already checked (a path and the chain a caller made).

    Raises:
        DataError: the file cannot be read, or a row, column or metadata value is wrong.
    """
    parsed = _split(_read_text(path, content), path)
    if chain is not None:  # another robot's file is named as such, not by its joints or limits
        robot = next((value.strip() for _, key, value in parsed.raw_meta if key == "robot"), None)
        check_robot(robot, chain, robot_label, str(path))
    if parsed.header is None:
        raise DataError(str(path), "no header line (q1_deg, ..., length_mm) and no data")
    header, line = _tokenize_header(parsed, path), parsed.header_line
    cols = classify(header, path, line)
    n_joints = chain.n_joints if chain is not None else len(cols.joints)
    check_near_misses(cols, header, max(n_joints, *cols.joints, 0), readings, path, line)
    check_columns(cols, n_joints, chain.name if chain else None, chain.end_frame if chain else None, path, line,
                  readings)
    _tokenize_rows(parsed, path)
    decimal = decimal_mark(parsed.dialect.sep, parsed.override, _numeric_fields(parsed, cols), path)
    parsed.dialect = Dialect(parsed.dialect.sep, decimal)
    parsed.meta, parsed.notes = read_metadata(parsed.raw_meta, path, decimal)
    if not parsed.rows and not allow_empty:
        raise DataError(str(path), "has a header but no data rows")
    n = len(parsed.rows)
    q = np.empty((n, n_joints))
    if cols.sensor_kind:  # its columns in the sensor's order
        order = {q: k for k, q in enumerate(plugin_columns()[next(iter(cols.sensor))][1])}
        cols.sensor = dict(sorted(cols.sensor.items(), key=lambda item: order[item[0]]))
    labels = _labels(parsed, cols, path)
    if cols.plain_kind:  # in the sensor's order
        order = {name: k for k, name in enumerate(plain_columns()[next(iter(cols.plain))][1])}
        cols.plain = dict(sorted(cols.plain.items(), key=lambda item: order[item[0]]))
    bare = bool(cols.plain_kind) and not SCHEMAS[cols.plain_kind].value_columns  # unit-free values only (a camera's)
    width = 0 if cols.label_kind or bare else len(cols.sensor) if cols.sensor_kind else 3 if cols.position else 1
    values = np.empty((n, width + len(cols.plain)))
    pose_ids = np.empty(n, dtype=int)
    at_once = _rows_at_once(parsed, cols, chain, n_joints, width, decimal) if n else None
    if at_once is not None:  # every row's numbers read a column at a time
        q, values = at_once
        if cols.pose is not None:
            for r, (number_, fields) in enumerate(parsed.rows):
                pose_ids[r] = _integer(fields[cols.pose], path, number_, "pose")
    for r, (number_, fields) in enumerate(parsed.rows if at_once is None else ()):
        q[r] = _angles(fields, header, cols, chain, n_joints, path, number_, decimal)
        values[r] = _values(fields, header, cols, path, number_, decimal)
        if cols.pose is not None:
            pose_ids[r] = _integer(fields[cols.pose], path, number_, "pose")
    point_col = cols.point if cols.point is not None else cols.own_point
    own_point = cols.own_point is not None  # a kind's own point column (a camera's corner_id)
    point_name = header[point_col] if point_col is not None else "point_id"
    point_ids = _point_ids(parsed, point_col, path, point_name) if point_col is not None else np.ones(n, dtype=int)
    lines = [number_ for number_, _ in parsed.rows]
    if cols.pose is not None:
        _check_unique(pose_ids, point_ids if (cols.position and not cols.plain_kind) or own_point else None, lines, path,
                      point_name)
    meta = parsed.meta
    kind = cols.label_kind or cols.plain_kind or cols.sensor_kind or (kind_of_columns(("x", "y", "z")) if cols.position else (
        kind_of_columns(("length",)) if cols.length is not None else "poses"))
    schema = SCHEMAS.get(kind)
    own = dict(schema.metadata_keys) if schema is not None else {}
    own.update({k: 0 for k in (schema.pair_metadata if schema is not None else ())})
    return MeasurementSet(
        q=q, values=values if values.shape[1] != 1 else values[:, 0], kind=kind,
        anchor=meta.get("anchor"), tool=meta.get("tool"), length_offset=meta.get("length_offset", 0.0),
        noise=meta.get("noise"), robot=meta.get("robot"), end_frame=meta.get("end_frame"),
        lines=np.array(lines, dtype=int), source=str(path), notes=parsed.notes,
        pose_ids=pose_ids if cols.pose is not None else None,
        point_ids=point_ids if (cols.position and not cols.plain_kind) or own_point else None,
        extra=_extra(parsed, cols),
        sensor_meta={k: tuple(meta[k]) if isinstance(meta[k], list) else meta[k] for k in own if k in meta},
        labels=labels,
    )

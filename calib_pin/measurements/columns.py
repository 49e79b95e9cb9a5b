"""Which columns of a measurement file calib-pin reads, and which it keeps as extra.

The rule:

- calib-pin's columns: ``q<i>_deg`` / ``q<i>_rad`` (``q<i>_mm`` / ``q<i>_m`` for a
  prismatic joint), ``length_mm`` / ``length_m``, ``x_mm`` ``y_mm`` ``z_mm`` (or ``_m``),
  ``pose``, ``point_id``; each quantity once (``q1_deg`` with ``q1_rad``, or ``length_mm``
  with ``length_m``, is refused), and only the robot's joints.
- A column that *looks like* one of them must be one. Refused: a quantity with another
  unit or none (``length_cm``, ``q2_degrees``, ``X``, ``q3``), another case (``Q3_deg``,
  ``Pose``), or a near-miss (one edit for names of up to 4 characters, two otherwise,
  letter swaps counting one) of a column the file needs or may have but does not
  (``lenght_mm`` without a length, ``pointid`` without ``point_id``).
- Every other column (``temp_C``, ``sigma_mm``, ``x_std_mm``, ``time``, ``label``,
  ``comment``; an unnamed one is ``column <k>``) is read and kept as
  :attr:`MeasurementSet.extra <calib_pin.measurements.MeasurementSet.extra>`, reported as
  ignored; an unnamed column with no value in any row (a trailing separator) is dropped.
  ``position_error_mm``, ``orientation_error_urad`` and ``status`` (what ``calib-pin
  compensate`` writes beside the joints) are read past.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from ..exceptions import DataError
from .dialect import quote
from .schema import SCHEMAS

#: Columns a compensated pose list carries beside the joints (calib-pin compensate); read past.
ANNOTATIONS = ("position_error_mm", "orientation_error_urad", "status")
_JOINT = re.compile(r"^q(\d+)_(deg|rad|mm|m)$")
_LENGTH = re.compile(r"^length_(mm|m)$")
_COORD = re.compile(r"^([xyz])_(mm|m)$")
#: A quantity of ours with any (or no) unit, any case.
_LOOKS_OURS = re.compile(r"^(q\d+|length|[xyz])(?:_([a-z]+))?$", re.IGNORECASE)


@dataclass
class Columns:
    """Where each quantity is (column index, unit) in a header."""

    joints: dict[int, tuple[int, str]] = field(default_factory=dict)
    length: tuple[int, str] | None = None
    coords: dict[str, tuple[int, str]] = field(default_factory=dict)
    pose: int | None = None
    point: int | None = None
    #: Column index -> name of the columns kept as extra (unnamed ones: ``column <k>``).
    extra: dict[int, str] = field(default_factory=dict)
    #: Unnamed columns (kept as extra unless blank in every row).
    unnamed: list[int] = field(default_factory=list)
    #: A registered kind's value columns beyond the drawstring's and the positions'
    #: (its schema's ``value_columns``): quantity -> (column index, unit).
    sensor: dict[str, tuple[int, str]] = field(default_factory=dict)
    #: That sensor's kind ("" without such columns).
    sensor_kind: str = ""
    #: A registered kind's unit-free value columns (its schema's ``plain_columns``, after
    #: its ``value_columns``: a 6-D pose's quaternion): name -> column index.
    plain: dict[str, int] = field(default_factory=dict)
    #: That sensor's kind ("" without such columns).
    plain_kind: str = ""
    #: A registered kind's text label columns (its schema's ``label_columns``: a contact
    #: set's ``contact_id``, ``plane_id``): name -> column index.
    labels: dict[str, int] = field(default_factory=dict)
    #: That sensor's kind ("" without such columns).
    label_kind: str = ""
    #: A registered kind's own point column (its schema's ``point_column`` other than
    #: ``point_id``: a camera's ``corner_id``), its index, and that kind.
    own_point: int | None = None
    own_point_kind: str = ""

    @property
    def position(self) -> bool:
        return bool(self.coords) or self.point is not None


#: The value columns this module reads itself (the drawstring's and the positions').
_BUILT_IN = {("length",), ("x", "y", "z")}


def plugin_columns() -> dict[str, tuple[str, tuple[str, ...]]]:
    """Quantity -> (kind, all its value columns) of every registered schema of other values.

    Other values: not the drawstring's length or the positions' x, y, z.
    """
    return {c: (kind, schema.value_columns) for kind, schema in SCHEMAS.items()
            if schema.value_columns and schema.value_columns not in _BUILT_IN for c in schema.value_columns}


def plain_columns() -> dict[str, tuple[str, tuple[str, ...]]]:
    """Name -> (kind, all its unit-free columns) of every registered schema with ``plain_columns``.

    They are read as they are, after its ``value_columns``.
    """
    return {c: (kind, schema.plain_columns) for kind, schema in SCHEMAS.items() for c in schema.plain_columns}


def label_columns() -> dict[str, tuple[str, tuple[str, ...]]]:
    """Name -> (kind, all its label columns) of every registered schema with ``label_columns``.

    Labels are text naming what a row touched; a row may leave some empty.
    """
    return {c: (kind, schema.label_columns) for kind, schema in SCHEMAS.items() for c in schema.label_columns}


def point_columns() -> dict[str, str]:
    """Name -> kind of every registered schema's own point column (not ``point_id``: a camera's ``corner_id``)."""
    return {s.point_column: kind for kind, s in SCHEMAS.items() if s.point_labels and s.point_column != "point_id"}


def kind_of_columns(columns: tuple[str, ...]) -> str:
    """The registered kind whose value columns are ``columns`` (the first, in registry order)."""
    return next(kind for kind, schema in SCHEMAS.items() if schema.value_columns == columns)


def _units(quantity: str) -> str:
    if quantity.startswith("q"):
        return f"{quantity}_deg, {quantity}_rad; {quantity}_mm or {quantity}_m for a prismatic joint"
    return f"{quantity}_mm or {quantity}_m"


def _known(name: str) -> bool:
    return bool(_JOINT.match(name) or _LENGTH.match(name) or _COORD.match(name) or name in ("pose", "point_id"))


def _looks_ours(name: str, path: Path, line: int) -> None:
    """Refuse a name that is one of ours in another case, unit or without a unit."""
    if name.lower() != name and _known(name.lower()):
        raise DataError(str(path), f"unknown column; did you mean {name.lower()}? (names are case-sensitive)",
                        line, quote(name))
    m = _LOOKS_OURS.match(name)
    if m is None:
        return
    quantity, unit = m.group(1).lower(), m.group(2)
    if unit is None:
        raise DataError(str(path), f"give the unit in the name ({_units(quantity)})", line, quote(name))
    raise DataError(str(path), f"unit '{quote(unit)}' is not read ({_units(quantity)})", line, quote(name))


def classify(header: list[str], path: Path, line: int) -> Columns:
    """Sort a header's columns into calib-pin's and extra ones.

    Args:
        header: The header's column names.
        path: The file, for messages.
        line: The header's line in the file (1-based).

    Raises:
        DataError: a name twice, a quantity twice, or a name that looks like one of ours.
    """
    cols = Columns()
    for col, name in enumerate(header):
        if name and name in header[:col]:
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
        elif (m := re.match(r"^(\w+)_(mm|m)$", name)) and m.group(1) in (plugins := plugin_columns()):
            kind = plugins[m.group(1)][0]
            if m.group(1) in cols.sensor or (cols.sensor_kind and cols.sensor_kind != kind):
                raise DataError(str(path), f"two {m.group(1)} columns, or columns of two sensors: keep one", line, name)
            cols.sensor[m.group(1)] = (col, m.group(2))
            cols.sensor_kind = kind
        elif name in (plain := plain_columns()):
            if cols.plain_kind and cols.plain_kind != plain[name][0]:
                raise DataError(str(path), "columns of two sensors: one set holds one sensor's data", line, name)
            cols.plain[name] = col
            cols.plain_kind = plain[name][0]
        elif name in (labelled := label_columns()):
            if cols.label_kind and cols.label_kind != labelled[name][0]:
                raise DataError(str(path), "columns of two sensors: one set holds one sensor's data", line, name)
            cols.labels[name] = col
            cols.label_kind = labelled[name][0]
        elif name in (own := point_columns()):
            cols.own_point, cols.own_point_kind = col, own[name]
        elif name in ANNOTATIONS:
            continue  # what calib-pin compensate adds to the joint targets; not data
        elif name == "pose":
            cols.pose = col
        elif name == "point_id":
            cols.point = col
        elif not name:
            cols.unnamed.append(col)
        else:
            _looks_ours(name, path, line)
            cols.extra[col] = name
    return cols


def _missing(cols: Columns, n_joints: int, readings: bool) -> list[str]:
    """Names of the columns the file needs or may have but does not."""
    names = [f"q{i}_{u}" for i in range(1, n_joints + 1) if i not in cols.joints for u in ("deg", "rad", "mm", "m")]
    if cols.length is None and not cols.coords:
        names += ["length_mm", "length_m"] if readings else []
    if cols.length is None:
        names += [f"{a}_{u}" for a in "xyz" if a not in cols.coords and (readings or cols.coords) for u in ("mm", "m")]
        names += ["point_id"] if cols.point is None else []
    return names + (["pose"] if cols.pose is None else [])


def check_near_misses(cols: Columns, header: list[str], n_joints: int, readings: bool, path: Path, line: int) -> None:
    """Refuse an extra column whose name is a near-miss of a column the file lacks.

    Args:
        cols: The header's columns, sorted (:func:`classify`).
        header: The header's column names.
        n_joints: The chain's joints.
        readings: The file must hold sensor values (not a pose list).
        path: The file, for messages.
        line: The header's line in the file (1-based).

    Raises:
        DataError: ``lenght_mm`` without a length column, and the like.
    """
    missing = _missing(cols, n_joints, readings)
    for name in cols.extra.values():
        for known in missing:
            if distance(name.lower(), known) <= (1 if len(known) <= 4 else 2):
                raise DataError(str(path), f"unknown column; did you mean {known}?", line, quote(name))


def distance(a: str, b: str) -> int:
    """Edits (insert, delete, replace, swap of two neighbours) from ``a`` to ``b``."""
    d = [[i + j if i * j == 0 else 0 for j in range(len(b) + 1)] for i in range(len(a) + 1)]
    for i in range(1, len(a) + 1):
        for j in range(1, len(b) + 1):
            d[i][j] = min(d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] != b[j - 1]))
            if i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                d[i][j] = min(d[i][j], d[i - 2][j - 2] + 1)
    return d[len(a)][len(b)]


def check_columns(cols: Columns, n_joints: int, robot: str | None, end_frame: str | None, path: Path,
                  line: int, readings: bool) -> None:
    """Refuse a header without the columns of its kind of set.

    Args:
        n_joints: The robot's joints (``robot`` named), or the header's own count.
    """
    expected = set(range(1, n_joints + 1))
    if robot is not None and set(cols.joints) - expected:
        extra = sorted(set(cols.joints) - expected)
        raise DataError(str(path), f"has joint column q{extra[0]} but robot '{robot}' has {n_joints} "
                        f"joints to '{end_frame}'", line)
    for i in sorted(expected):
        if i not in cols.joints:
            raise DataError(str(path), f"missing column q{i}_deg (or q{i}_rad; q{i}_mm for a prismatic joint)", line)
    if cols.own_point_kind and cols.own_point_kind not in (cols.plain_kind, cols.sensor_kind):
        column = SCHEMAS[cols.own_point_kind].point_column
        raise DataError(str(path), f"has {column}, a column of {cols.own_point_kind} sets, without their value columns "
                        f"({', '.join(SCHEMAS[cols.own_point_kind].plain_columns or SCHEMAS[cols.own_point_kind].value_columns)})"
                        ": one set holds one sensor's data", line)
    if cols.label_kind:
        other = ("length" if cols.length is not None else "x/y/z" if cols.coords else "point_id" if cols.point is not None
                 else cols.sensor_kind or cols.plain_kind)
        if other:
            raise DataError(str(path), f"has {cols.label_kind} columns ({', '.join(cols.labels)}) and {other}: one set "
                            "holds one sensor's data", line)
        return
    if cols.plain_kind:
        _check_plain(cols, path, line)
        return
    if cols.sensor_kind:
        if cols.position or cols.length is not None:
            raise DataError(str(path), f"has {cols.sensor_kind} columns and others: one set holds one sensor's data",
                            line)
        for quantity in plugin_columns()[next(iter(cols.sensor))][1]:
            if quantity not in cols.sensor:
                raise DataError(str(path), f"missing column {quantity}_mm (or {quantity}_m) of a {cols.sensor_kind} "
                                "set", line)
        return
    if cols.position and cols.length is not None:
        what = "x/y/z columns" if cols.coords else "a point_id column (the marker labels of a position set)"
        raise DataError(str(path), f"has both length and {what}: one set holds one sensor's data", line)
    if cols.position:
        for axis in "xyz":
            if axis not in cols.coords:
                raise DataError(str(path), f"missing column {axis}_mm (or {axis}_m) of a position set", line)
    if cols.length is None and readings and not cols.position:
        raise DataError(str(path), "missing column length_mm (or length_m)", line)


def _check_plain(cols: Columns, path: Path, line: int) -> None:
    """Refuse a header with some of a sensor's unit-free columns, or with another sensor's.

    A sensor's unit-free columns go with all of them and its value columns (a 6-D pose
    set: x, y, z and qw, qx, qy, qz).

    Raises:
        DataError: naming the missing or foreign column.
    """
    schema = SCHEMAS[cols.plain_kind]
    kind = cols.plain_kind
    if schema.point_labels and schema.point_column != "point_id" and cols.own_point is None:
        raise DataError(str(path), f"missing column {schema.point_column} of a {kind} set (which point each row "
                        "measured)", line)
    if cols.length is not None or cols.sensor_kind or cols.point is not None:
        other = "length" if cols.length is not None else "point_id" if cols.point is not None else cols.sensor_kind
        raise DataError(str(path), f"has {kind} columns and {other}: one set holds one sensor's data", line)
    coords = schema.value_columns == ("x", "y", "z")
    for quantity in schema.value_columns:
        if quantity not in (cols.coords if coords else cols.sensor):
            raise DataError(str(path), f"missing column {quantity}_mm (or {quantity}_m) of a {kind} set", line)
    plain = schema.plain_columns
    for name in plain:
        if name not in cols.plain:
            raise DataError(str(path), f"missing column {name} of a {kind} set ({', '.join(plain)})", line)

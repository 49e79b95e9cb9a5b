"""Checks of a measurement set against the robot it is for, for a set from any source.

The checks the CSV reader makes row by row, for any :class:`MeasurementSet` (read,
simulated or made by hand).

:func:`check_measurements` is what the library's entry points (``prepare``,
``calibrate``, a ``test_data`` session) call, and so the
command line through them. What a set of each kind holds is its schema's
(:data:`calib_pin.measurements.schema.SCHEMAS`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import DataError
from ..robot.chain import Chain
from ..util.arguments import LIMIT_TOLERANCE, as_instance, outside_limits, too_far
from .dataset import MeasurementSet
from .schema import SCHEMAS

#: What a pose list's ``kind`` is (a set without values).
POSES = "poses"


def kinds() -> tuple[str, ...]:
    """Data kinds a set may hold: each registered schema's (:data:`~.schema.SCHEMAS`), or a pose list."""
    return (*SCHEMAS, POSES)


#: How far two set-ups may differ and still agree, [m]: a file's rounding, down to the
#: micrometre (``600.000`` beside ``600.0004`` mm) is the same set-up; a drawstring's
#: noise is some 50 um, so the scores cannot tell the two apart.
SETUP_TOLERANCE_M = 1e-6


def _where(data: MeasurementSet) -> str:
    return data.source or "data"


def _row_line(data: MeasurementSet, row: int) -> tuple[int | None, str]:
    """The file line of ``row`` (0-based), or None and ``row k: `` for a set in memory."""
    if data.lines is not None and len(data.lines) == len(data):
        return int(data.lines[row]), ""
    return None, f"row {row} (0-based): "


def robot_matches(label: str, chain: Chain, robot_label: str | None = None) -> bool:
    """A set's ``robot`` names ``chain``: its name (a URDF's file stem), its URDF's
    ``<robot name>``, what the caller called it (``robot_label``), or its URDF's path."""
    if label in (chain.name, chain.full_model.name, robot_label):
        return True
    try:
        return Path(label).resolve() == Path(chain.description.urdf).resolve()
    except (OSError, ValueError):
        return False


def check_robot(label: str | None, chain: Chain, robot_label: str | None, where: str) -> None:
    """Refuse a set whose ``robot`` (None: not stated) is another robot than ``chain``
    (:func:`robot_matches`); checked before anything of its rows, whose joints and limits
    are another robot's.

    Raises:
        DataError: naming ``where`` and the field ``robot``.
    """
    if label is None or robot_matches(str(label), chain, robot_label):
        return
    urdf = chain.full_model.name
    named = f" (nor '{urdf}', its URDF's <robot name>)" if urdf and urdf != chain.name else ""
    raise DataError(where, f"is for robot '{label}', not '{chain.name}'{named}", None, "robot")


def limits_of(chain: Chain, joint: int) -> str:
    """Whose limits a refusal of joint ``joint`` (0-based) beyond them names: the URDF's,
    and how to accept a controller's wider ones, or the URDF's widened by the margin."""
    if chain.joint_kinds[joint].startswith("JointModelP"):
        return " (the URDF's)"
    margin = chain.description.limit_margin
    if margin:
        return f" (the URDF's, widened by {math.degrees(margin):g} deg)"
    return " (the URDF's; a controller that allows more: calibrate --limit-margin-deg)"


def beyond_urdf_limits(chain: Chain, data: MeasurementSet) -> list[str]:
    """The rows of ``data`` that only the chain's limit margin accepts (a revolute joint
    beyond its URDF limits, within :attr:`~calib_pin.robot.RobotDescription.limit_margin`),
    each as ``line 12: joint_1 165.8 deg`` (``row 3`` for a set in memory)."""
    margin = chain.description.limit_margin
    if not margin:
        return []
    revolute = np.array([not kind.startswith("JointModelP") for kind in chain.joint_kinds])
    q = np.asarray(data.q, dtype=float)
    lower, upper = chain.lower + margin * revolute, chain.upper - margin * revolute
    out = []
    for row, j in zip(*np.nonzero((q < lower - LIMIT_TOLERANCE) | (q > upper + LIMIT_TOLERANCE)), strict=True):
        line, _ = _row_line(data, int(row))
        where = f"line {line}" if line is not None else f"row {int(row)}"
        out.append(f"{where}: {chain.joint_names[j]} {math.degrees(q[row, j]):g} deg")
    return out


def _check_shapes(chain: Chain, data: MeasurementSet) -> None:
    where = _where(data)
    if data.kind not in kinds():
        raise DataError(where, f"kind '{data.kind}' is not one of {', '.join(kinds())}", None, "kind")
    schema = SCHEMAS.get(data.kind)
    q = np.asarray(data.q)
    if q.dtype.kind not in "iuf" or q.ndim != 2 or q.shape[1] != chain.n_joints:
        raise DataError(where, f"joint angles of shape {q.shape} ({q.dtype.name}): expected (n_rows, "
                        f"{chain.n_joints}) numbers for the joints of '{chain.name}' to '{chain.end_frame}'", None, "q")
    if not len(q):
        raise DataError(where, "has no rows", None, "q")
    values = np.asarray(data.values)
    per_row = None if schema is None else schema.data_values_per_row  # numbers a data row holds
    expected = None if per_row is None else (len(q),) if per_row == 1 else (len(q), per_row)
    if schema is not None and expected is not None and (values.dtype.kind not in "iuf" or values.shape != expected):
        one = "reading" if per_row == 1 else ", ".join(schema.value_columns)
        raise DataError(where, f"{data.kind} values of shape {values.shape} ({values.dtype.name}): expected "
                        f"{expected} numbers, one {one} per row", None, "values")
    for name in ("lines", "pose_ids", "point_ids"):
        labels = getattr(data, name)
        if labels is not None and np.shape(labels) != (len(q),):
            raise DataError(where, f"{name} of shape {np.shape(labels)}: expected one per row ({len(q)})", None, name)
    if schema is not None and schema.point_labels and data.point_ids is None:
        raise DataError(where, f"a {data.kind} set needs point_ids (which marker each row measured)", None,
                        "point_ids")


def _check_angles(chain: Chain, data: MeasurementSet) -> None:
    q = np.asarray(data.q, dtype=float)
    bad = np.argwhere(~np.isfinite(q))
    if len(bad):
        row, j = (int(i) for i in bad[0])
        line, prefix = _row_line(data, row)
        raise DataError(_where(data), f"{prefix}{q[row, j]} is not a finite joint angle", line, f"q{j + 1}")
    where = outside_limits(q, chain.lower, chain.upper, LIMIT_TOLERANCE)  # the CSV reader's tolerance
    if where is not None:
        row, j = where
        line, prefix = _row_line(data, row)
        prismatic = chain.joint_kinds[j].startswith("JointModelP")
        factor, unit = (1e3, "mm") if prismatic else (math.degrees(1.0), "deg")
        raise DataError(_where(data), f"{prefix}{q[row, j] * factor:g} {unit} is outside the limits of "
                        f"{chain.joint_names[j]} [{chain.lower[j] * factor:g}, {chain.upper[j] * factor:g}] {unit}"
                        f"{limits_of(chain, j)}", line, f"q{j + 1}")


def _check_values(data: MeasurementSet) -> None:
    schema = SCHEMAS.get(data.kind)
    if schema is None:  # a pose list
        return
    values = np.asarray(data.values, dtype=float)
    bad = np.argwhere(~np.isfinite(values))
    columns = schema.value_columns + schema.plain_columns  # a 6-D pose's quaternion after its position
    name = columns[0] if len(columns) == 1 else data.kind
    if len(bad):
        row = int(bad[0][0])
        line, prefix = _row_line(data, row)
        raise DataError(_where(data), f"{prefix}{values[tuple(bad[0])]} is not a finite {name} reading", line,
                        columns[0] if len(columns) == 1 else columns[int(bad[0][1])])
    refused = schema.refuse_values(values)
    if refused is not None:
        row, why = refused
        line, prefix = _row_line(data, row)
        raise DataError(_where(data), f"{prefix}{why}", line, columns[0] if len(columns) == 1 else None)


def _check_metadata(chain: Chain, data: MeasurementSet, robot_label: str | None) -> None:
    where = _where(data)
    if data.end_frame and data.end_frame != chain.end_frame:
        raise DataError(where, f"was measured at end frame '{data.end_frame}', not '{chain.end_frame}'",
                        None, "end_frame")
    for name, frame in (("anchor", "base"), ("tool", "end frame")):
        point = getattr(data, name)
        if point is not None and (np.shape(point) != (3,) or not np.all(np.isfinite(point))):
            raise DataError(where, f"{name} must be 3 finite numbers (x, y, z in m), got {point!r:.60}", None, name)
        why = None if point is None else too_far(np.asarray(point) * 1e3, frame)
        if why is not None:  # a unit or frame mistake: a 5 m tool
            raise DataError(where, why, None, f"{name}_mm")
    if not (isinstance(data.length_offset, (int, float, np.floating)) and math.isfinite(data.length_offset)):
        raise DataError(where, f"length_offset must be a finite number in m, got {data.length_offset!r:.40}",
                        None, "length_offset")
    if data.noise is not None and not (isinstance(data.noise, (int, float, np.floating))
                                       and math.isfinite(data.noise) and data.noise >= 0):
        raise DataError(where, f"noise must be a number >= 0 in m, got {data.noise!r:.40}", None, "noise")


def check_measurements(chain: Chain, data: Any, robot_label: str | None = None) -> MeasurementSet:
    """Check a measurement set against the robot chain it is for.

    The checks: first the robot it names (the chain's name, its URDF's ``<robot name>``,
    ``robot_label`` or its URDF path); its kind; the joint angles' shape (n_rows, n_joints), every angle finite and
    within the URDF limits (the CSV reader's tolerance); the values' shape, finite,
    drawstring readings >= 0; one label per row; its end frame, and finite sensor metadata.

    Args:
        chain: The robot chain the set is for (joints, limits, end frame).
        data: The set.
        robot_label: What the caller called the robot (a name or URDF path), also
            accepted as the set's ``robot``.

    Returns:
        ``data``, unchanged.

    Raises:
        ArgumentError: ``chain`` is not a Chain, or ``data`` not a MeasurementSet.
        DataError: naming the set's source (or ``data``), the file line (or the 0-based
            row) and the field (``q3``, ``length``, ``robot``, ...).
    """
    as_instance(chain, "chain", Chain, "a Chain (calib_pin.load_chain)")
    as_instance(data, "data", MeasurementSet, "a MeasurementSet (calib_pin.read_measurements or simulate)")
    return check_set(chain, data, robot_label)


def check_set(chain: Chain, data: MeasurementSet, robot_label: str | None = None) -> MeasurementSet:
    """:func:`check_measurements` of a chain and a set known to be ones (a calibration's own).

    Raises:
        DataError: as :func:`check_measurements`.
    """
    check_robot(data.robot, chain, robot_label, _where(data))  # another robot's joints and limits: named as such
    _check_shapes(chain, data)
    _check_angles(chain, data)
    _check_values(data)
    _check_metadata(chain, data, robot_label)
    return data


_META_KEY = re.compile(r"^#\s*([A-Za-z_][\w.]*)\s*:")


@dataclass(frozen=True)
class FileHeader:
    """What a measurement file holds above its rows.

    Attributes:
        keys: Each metadata key (``# key:`` line) and its 1-based line.
        columns: The header's column names, as written.
    """

    keys: dict[str, int]
    columns: tuple[str, ...]


def file_header(path: str) -> FileHeader | None:
    """The metadata keys and the column names of the CSV file ``path``, or None.

    None when it is not a readable file (a set made in memory).
    """
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as f:
            keys: dict[str, int] = {}
            for number, raw in enumerate(f, 1):
                line = raw.strip()
                if not line:
                    continue
                if not line.startswith("#"):
                    columns = tuple(c.strip().strip('"') for c in re.split(r"[;,\t]", line))
                    return FileHeader(keys, columns)
                if m := _META_KEY.match(line):
                    keys.setdefault(m.group(1), number)
            return FileHeader(keys, ())
    except (OSError, ValueError):
        return None


def _file_keys(path: str) -> set[str] | None:
    """The metadata keys (``# key:`` lines above the header) of the CSV file ``path``, or None.

    None when it is not a readable file (a set made in memory).
    """
    header = file_header(path)
    return None if header is None else set(header.keys)


def _mm(value: Any) -> str:
    return ", ".join(f"{v:.10g}" for v in np.atleast_1d(np.asarray(value, dtype=float) * 1e3))


def __getattr__(name: str) -> Any:
    """The old name of the validation session's check (now in calib_pin.calibration.validation), with a warning."""
    from ..util.deprecation import moved_names

    return moved_names(__name__, {
        "check_same_setup": "calib_pin.calibration.validation"})(name)

"""Writing measurement sets and pose lists as CSV, in degrees and millimetres.

The one place that knows the row format written by calib-pin (the simulator, the
collector and the pose tools all write through here). Always the standard dialect:
``,`` between fields, ``.`` as the decimal mark, whatever the file read used; a text
field holding ``,`` or ``"`` is quoted.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ..util.arguments import as_instance, as_path
from ..util.atomic import write_text
from .dataset import MeasurementSet, PointLabel, point_label
from .schema import SCHEMAS


def text_field(text: str) -> str:
    """``text`` as one CSV field (quoted when it holds a separator, a quote or a line break)."""
    return '"' + text.replace('"', '""') + '"' if any(c in text for c in ',"\n\r;') else text


def _label(value: PointLabel) -> str:
    return text_field(value) if isinstance(value, str) else str(int(value))


def _extra_fields(data: MeasurementSet, k: int) -> list[str]:
    """Row k's extra columns: numbers as the shortest text that reads back the same, NaN empty."""
    out = []
    for column in data.extra.values():
        v = column[k]
        if isinstance(v, str):
            out.append(text_field(v))
        else:
            out.append("" if np.isnan(v) else repr(float(v)))
    return out


def _mm(v: np.ndarray) -> str:
    return ", ".join(f"{x * 1e3:.6f}" for x in v)


def metadata_lines(data: MeasurementSet) -> list[str]:
    """The ``# key: value`` lines of a set: robot, end frame, sensor geometry, noise, notes."""
    lines = [f"# {key}: {value}" for key, value in (("robot", data.robot), ("end_frame", data.end_frame)) if value]
    schema = SCHEMAS.get(data.kind)
    own = schema.metadata_keys if schema is not None else {}
    keys = dict.fromkeys(k for s in SCHEMAS.values() for k in s.metadata_keys.items())
    for key, size in keys:  # each sensor's set-up metadata (the drawstring's in anchor, tool, length_offset)
        value = data.sensor_meta.get(key, getattr(data, key, None))
        if value is None or (size == 1 and key not in own):
            continue
        text = _mm(np.asarray(value, dtype=float).reshape(-1)) if size > 1 else f"{float(value) * 1e3:.6f}"
        lines.append(f"# {key}_mm: {text}")
    for key in schema.pair_metadata if schema is not None else ():  # one line a pair: label, label, length
        lines += [f"# {key}_mm: {a}, {b}, {length * 1e3:.6f}" for a, b, length, *_ in data.sensor_meta.get(key, ())]
    if data.noise is not None:
        lines.append(f"# noise_mm: {data.noise * 1e3:.6f}")
    return lines + [f"# {k}: {v}" for k, v in data.notes.items()]


def header(n_joints: int, kind: str, with_pose: bool = False) -> str:
    """The column line of a set of ``kind`` (a registered schema's, or ``poses``).

    A kind with point labels gets ``pose`` and ``point_id`` first, then the joints, then
    its value columns in mm.
    """
    schema = SCHEMAS.get(kind)
    joints = [f"q{i}_deg" for i in range(1, n_joints + 1)]
    values: list[str] = []
    if schema is not None:
        values += [f"{c}_mm" for c in schema.value_columns]
        values += schema.plain_columns  # unit-free, after the others (a pose's quaternion)
        values += schema.label_columns  # text naming what a row touched (a contact's fixture)
    if schema is not None and schema.point_labels:
        return ",".join(["pose", schema.point_column, *joints, *values])
    return ",".join((["pose"] if with_pose else []) + joints + values)


def row(q: np.ndarray, values: Iterable[float] = (), labels: Iterable[PointLabel] = (),
        plain: Iterable[float] = ()) -> str:
    """One data row: labels, angles in degrees, values in mm, then unit-free values.

    Labels: whole numbers, or text; angles [rad] written in degrees (9 decimals); values
    [m] written in mm (6 decimals: 1 nm, far below any sensor's resolution); unit-free
    values (``plain``: a quaternion, 12 decimals).
    """
    return ",".join([_label(v) for v in labels] + [f"{v:.9f}" for v in np.rad2deg(q)]
                    + [f"{v * 1e3:.6f}" for v in values] + [f"{v:.12f}" for v in plain])


def write_measurements(path: str | Path, data: MeasurementSet) -> None:
    """Write a measurement set, metadata first.

    A position set gets ``pose`` and ``point_id`` columns (labels as they are: numbers or
    text); the set's extra columns follow calib-pin's, so nothing read is lost.

    Args:
        path: The CSV file to write.
        data: The measurement set.

    Raises:
        ArgumentError: ``path`` is not a path, or ``data`` not a MeasurementSet.
        OSError: the file cannot be written.
    """
    path = as_path(path, "path")
    as_instance(data, "data", MeasurementSet, "a MeasurementSet (calib_pin.read_measurements or simulate)")
    lines = metadata_lines(data)
    if any(";" in name or "\t" in name for name in data.extra):  # the header alone would look ';'-separated
        lines.append("# csv: sep=,")
    lines.append(",".join([header(data.q.shape[1], data.kind), *map(text_field, data.extra)]))
    values = np.asarray(data.values, dtype=float).reshape(len(data), -1)
    schema = SCHEMAS.get(data.kind)
    labelled = schema is not None and schema.point_labels
    n_plain = len(schema.plain_columns) if schema is not None else 0
    label_names = schema.label_columns if schema is not None else ()
    plain, values = values[:, values.shape[1] - n_plain :], values[:, : values.shape[1] - n_plain]
    for k in range(len(data)):
        labels: tuple[PointLabel, ...] = ()
        if labelled:
            pose = data.pose_ids[k] if data.pose_ids is not None else k + 1
            point = data.point_ids[k] if data.point_ids is not None else 1
            labels = (int(pose), point_label(point))
        texts = [text_field(str(data.labels[name][k])) if name in data.labels else "" for name in label_names]
        lines.append(",".join([row(data.q[k], values[k], labels, plain[k]), *texts, *_extra_fields(data, k)]))
    write_text(path, "\n".join(lines) + "\n")


def write_poses(
    path: str | Path, q: np.ndarray, *, robot: str | None = None, end_frame: str | None = None,
    notes: dict[str, str] | None = None, pose_ids: np.ndarray | None = None, extra: dict[str, np.ndarray] | None = None,
) -> None:
    """Write a pose list: ``pose,q1_deg,...`` with poses numbered from 1 (or ``pose_ids``), then ``extra``'s columns.

    Args:
        q: Joint angles, shape (n_poses, n_joints), [rad].
        extra: Other columns, name to shape (n_poses,) (text, such as each pose's ``image``).
    """
    kept = MeasurementSet(q=q, values=np.zeros(len(q)), kind="poses", extra=dict(extra or {}))
    ids = range(1, len(q) + 1) if pose_ids is None else [int(p) for p in pose_ids]
    lines = [f"# {k}: {v}" for k, v in (("robot", robot), ("end_frame", end_frame)) if v]
    lines += [f"# {k}: {v}" for k, v in (notes or {}).items()]
    lines.append(",".join([header(q.shape[1], "poses", with_pose=True), *map(text_field, kept.extra)]))
    lines += [",".join([row(qk, labels=(k,)), *_extra_fields(kept, r)]) for r, (k, qk) in enumerate(zip(ids, q, strict=True))]
    write_text(path, "\n".join(lines) + "\n")


def write_compensated(
    path: str | Path, q: np.ndarray, pose_ids: np.ndarray, position_error_m: np.ndarray,
    orientation_error_rad: np.ndarray, notes: dict[str, str], extra: dict[str, np.ndarray] | None = None,
) -> None:
    """Write compensated joint targets as a pose list, with their other columns and remaining errors.

    ``pose,q1_deg,...`` as a pose list, the targets' other columns as they were (a
    program's speed, zone or name), then each row's remaining end-frame error
    (``position_error_mm``, ``orientation_error_urad``; the reader reads past them).

    Args:
        q: Joint commands, shape (n_poses, n_joints), [rad].
        position_error_m, orientation_error_rad: Remaining errors, shape (n_poses,).
        extra: The targets' other columns, name to shape (n_poses,) (numbers or text).
    """
    kept = MeasurementSet(q=q, values=np.zeros(len(q)), kind="poses", extra=dict(extra or {}))
    lines = [f"# {k}: {v}" for k, v in notes.items()]
    if any(";" in name or "\t" in name for name in kept.extra):  # the header alone would look ';'-separated
        lines.append("# csv: sep=,")
    lines.append(",".join([header(q.shape[1], "poses", with_pose=True), *map(text_field, kept.extra),
                           "position_error_mm", "orientation_error_urad"]))
    lines += [",".join([row(qk, labels=(int(pose),)), *_extra_fields(kept, k)]) + f",{e_p * 1e3:.6f},{e_r * 1e6:.4f}"
              for k, (qk, pose, e_p, e_r) in enumerate(zip(q, pose_ids, position_error_m, orientation_error_rad,
                                                             strict=True))]
    write_text(path, "\n".join(lines) + "\n")

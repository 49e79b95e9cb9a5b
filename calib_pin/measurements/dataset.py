"""A measurement set in memory: joint angles and what the sensor read at each."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import CalibPinError
from .schema import SCHEMAS, default_kind

#: A marker's ``point_id``: a whole number, or a text label (``SMR1``, ``T2``, ``A``).
PointLabel = int | str


def point_label(value: Any) -> PointLabel:
    """A marker label as a plain ``int`` or ``str``.

    Numpy integers and whole floats become ``int``; text is stripped, and text that is a
    whole number, ``"2"``, stays text.

    Args:
        value: A ``point_id`` value.

    Raises:
        CalibPinError: anything else (a fraction, NaN, None, a list).
    """
    if isinstance(value, bool | np.bool_):
        raise CalibPinError(f"point_id {value} is not a marker label (a whole number or a text label)")
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating) and float(value).is_integer():
        return int(value)
    if isinstance(value, str) and value.strip():
        return str(value).strip()
    raise CalibPinError(f"point_id {value} is not a marker label (a whole number or a text label)")


def _as_array(value: list[Any] | tuple[Any, ...]) -> np.ndarray:
    """``value`` as an array; a ragged one as an object array (refused by the checks)."""
    try:
        return np.asarray(value)
    except ValueError:
        array = np.empty(len(value), dtype=object)
        array[:] = list(value)
        return array


@dataclass
class MeasurementSet:
    """The rows of one session.

    Attributes:
        q: Joint angles, shape (n_rows, n_joints), [rad].
        values: What the sensor read, [m]: shape (n_rows,) for drawstring readings,
            (n_rows, 3) for positions in the measuring device's frame.
        kind: The sensor kind the values are of (a key of
            :data:`~calib_pin.measurements.schema.SCHEMAS`; empty: its first, the
            drawstring); ``poses`` for a pose list without values.
        anchor: Drawstring: P0 in the base frame, shape (3,), [m], or None.
        tool: Drawstring: the tool point in the end frame, shape (3,), [m], or None.
        length_offset: Drawstring: zero offset, [m] (0 if not given).
        noise: Sensor noise (1 sigma), [m], or None if not given.
        robot: Robot named in the file, or None.
        end_frame: End frame named in the file, or None.
        lines: 1-based file line of each row, shape (n_rows,).
        source: File the set was read from ("" if built in memory).
        notes: Other metadata, key to text.
        pose_ids: The ``pose`` column's labels, shape (n_rows,), or None without one.
        point_ids: The ``point_id`` column's labels (which marker a row measured),
            shape (n_rows,): int when every label in the file is a whole number, else
            str (``SMR1``, ``T2``); or None.
        extra: The file's other columns, name to shape (n_rows,): float when every field
            is a number (empty ones NaN), else the text as written; values in the file's
            own units, unused by calib-pin (see :meth:`ignored_note`).
        sensor_meta: The file's set-up metadata of the set's sensor (its schema's
            ``metadata_keys``), key to value in SI ([m]); the drawstring's is also in
            ``anchor``, ``tool``, ``length_offset``.
        labels: The sensor's text label columns (its schema's ``label_columns``: a
            contact set's ``contact_id``, ``plane_id``), name to shape (n_rows,) text, ''
            where a row leaves one empty.        dropped: Notes on rows its sensor could not use and left out when the set was
            loaded (a camera's poses of too few corners), one line each.
    """

    q: np.ndarray
    values: np.ndarray
    kind: str = ""
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
    point_ids: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    sensor_meta: dict[str, Any] = field(default_factory=dict)
    labels: dict[str, np.ndarray] = field(default_factory=dict)
    dropped: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        """A list or tuple given for an array field (a set made by hand) becomes an array.

        What it holds is checked by :func:`~calib_pin.measurements.checks.check_measurements`.
        """
        if not self.kind:
            self.kind = default_kind()
        for name in ("q", "values", "anchor", "tool", "lines", "pose_ids", "point_ids"):
            value = getattr(self, name)
            if isinstance(value, (list, tuple)):
                setattr(self, name, _as_array(value))

    def __len__(self) -> int:
        return len(self.q)

    def _values_of(self, columns: tuple[str, ...], what: str) -> np.ndarray:
        schema = SCHEMAS.get(self.kind)
        if schema is None or schema.value_columns != columns:
            raise CalibPinError(f"{self.source or 'the set'} holds {self.kind} data, not {what}")
        return self.values

    @property
    def lengths(self) -> np.ndarray:
        """Drawstring readings, shape (n_rows,), [m].

        Raises:
            CalibPinError: the set holds no drawstring readings.
        """
        return self._values_of(("length",), "drawstring readings")

    @property
    def positions(self) -> np.ndarray:
        """Marker positions, shape (n_rows, 3), [m], device frame.

        Raises:
            CalibPinError: the set holds no positions.
        """
        return self._values_of(("x", "y", "z"), "positions")

    @property
    def groups(self) -> np.ndarray:
        """Each row's pose label: rows of one pose go to the same side of a split.

        The ``pose`` column's labels; without one, rows of the same joint angles are one pose
        (a pose read again), labelled in the order they first appear (0, 1, ... for a file
        that reads each pose once).
        """
        if self.pose_ids is not None:
            return self.pose_ids
        q = np.asarray(self.q, dtype=float).reshape(len(self), -1)
        if not len(q):
            return np.arange(0)
        _, first, inverse = np.unique(q, axis=0, return_index=True, return_inverse=True)
        return np.argsort(np.argsort(first))[inverse.reshape(-1)]

    def describe_rows(self) -> str:
        """``120 poses`` or ``108 rows at 36 poses``."""
        poses = len(np.unique(self.groups))
        return f"{len(self)} rows at {poses} poses" if poses != len(self) else f"{len(self)} poses"

    def ignored_note(self) -> str | None:
        """The note on the extra columns, or None when the set has none.

        For example ``ignored columns: temp_C, sigma_mm (in s.csv; read and kept, not used)``.
        """
        if not self.extra:
            return None
        where = f"in {Path(self.source).name}; " if self.source else ""
        return f"ignored columns: {', '.join(self.extra)} ({where}read and kept, not used)"

    def subset(self, rows: np.ndarray) -> MeasurementSet:
        """The same set restricted to some rows."""
        def pick(a):
            return (None if a is None else a[rows])
        return replace(self, q=self.q[rows], values=self.values[rows], lines=pick(self.lines),
                       pose_ids=pick(self.pose_ids), point_ids=pick(self.point_ids),
                       extra={name: column[rows] for name, column in self.extra.items()},
                       labels={name: column[rows] for name, column in self.labels.items()})

"""What a measurement file of each sensor kind holds: its columns, metadata and value check.

The CSV reader and writer, the column rule and the data checks ask :data:`SCHEMAS` (a
measurement set's ``kind`` -> its :class:`Schema`), never the sensors: this layer sits below
:mod:`calib_pin.sensors`, whose measurement models take their schema from here
(``MeasurementModel.schema``). A plug-in sensor brings its own schema, registered with the
sensor by :func:`calib_pin.sensors.register` (which calls :func:`register_schema`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ..exceptions import ArgumentError

#: A quaternion whose norm is farther than this from 1 is refused (it is not a rotation as written).
QUATERNION_TOLERANCE = 1e-3

#: A value check: (row, why) of the first row whose finite values a sensor cannot have
#: read, or None when every row can be.
ValueCheck = Callable[[np.ndarray], tuple[int, str] | None]


def accept_values(values: np.ndarray) -> tuple[int, str] | None:
    """Every finite value can be read: None."""
    return None


def nonnegative_readings(values: np.ndarray) -> tuple[int, str] | None:
    """The first negative drawstring reading of ``values`` (n_rows,) [m]: (row, why), or None.

    A drawstring reading is >= 0.
    """
    if (values < 0).any():
        row = int(np.argmax(values < 0))
        return row, f"{values[row] * 1e3:g} mm is negative: a drawstring reading is >= 0"
    return None


def unit_quaternions(values: np.ndarray) -> tuple[int, str] | None:
    """The first 6-D pose of ``values`` whose quaternion is not of norm 1: (row, why), or None.

    ``values``: (n_rows, 7: x, y, z [m], qw, qx, qy, qz); the norm is 1 within
    :data:`QUATERNION_TOLERANCE`.
    """
    norms = np.linalg.norm(np.asarray(values, dtype=float).reshape(len(values), -1)[:, 3:7], axis=1)
    bad = np.abs(norms - 1.0) > QUATERNION_TOLERANCE
    if bad.any():
        row = int(np.argmax(bad))
        return row, (f"quaternion (qw, qx, qy, qz) has norm {norms[row]:.6g}, not 1 within "
                     f"{QUATERNION_TOLERANCE:g}: a Hamilton unit quaternion is expected")
    return None


@dataclass(frozen=True)
class Schema:
    """What a measurement file of one sensor kind holds.

    Attributes:
        kind: The measurement-set kind (``MeasurementSet.kind``, a key of :data:`SCHEMAS`).
        data_name: What a set of this kind holds, for people ("drawstring readings").
        value_columns: The quantities of a row's values: column ``<name>_mm`` or
            ``<name>_m`` each (``length``; ``x``, ``y``, ``z``), in the order of ``values``.
        plain_columns: Unit-free value columns after ``value_columns``, read and written
            as they are (a 6-D pose's ``qw``, ``qx``, ``qy``, ``qz``).
        label_columns: Text columns naming each row's fixture, read and written as they
            are (a contact set's ``contact_id``, ``plane_id``).
        metadata_keys: The set-up metadata keys (``# <key>_mm`` or ``# <key>_m``), key ->
            how many numbers (1, or 3 for a vector); read in SI [m] into
            ``MeasurementSet.sensor_meta``.
        pair_metadata: Metadata keys holding ``label, label, length`` (``_mm`` or ``_m``),
            each line once a pair (a contact set's ``distance``).
        numeric_notes: Metadata keys holding one number that the sensor reads itself from
            ``MeasurementSet.notes`` (a 6-D pose set's ``noise_deg``): read in the file's
            dialect, kept as text in the standard one (``.`` as the decimal mark).
        point_labels: Rows carry ``pose`` and ``point_id`` labels (which marker a row measured).
        point_column: The name of that label column (``point_id``; a camera's ``corner_id``).
        data_values_per_row: Numbers a data row holds (1 reading, 3 coordinates, a pose's
            position and quaternion 7; 0 for a row that only names what it touched).
        refuse_values: The value check (a :data:`ValueCheck`) of a set's finite values,
            [m] (plain columns as they are): a negative drawstring reading, a quaternion
            whose norm is not 1.
    """

    kind: str
    data_name: str = "readings"
    value_columns: tuple[str, ...] = ()
    plain_columns: tuple[str, ...] = ()
    label_columns: tuple[str, ...] = ()
    metadata_keys: Mapping[str, int] = field(default_factory=lambda: MappingProxyType({}), hash=False)
    pair_metadata: tuple[str, ...] = ()
    numeric_notes: tuple[str, ...] = ()
    point_labels: bool = False
    point_column: str = "point_id"
    data_values_per_row: int = 1
    refuse_values: ValueCheck = accept_values

    def __post_init__(self) -> None:
        """The name sequences as tuples, the metadata keys read-only.

        Raises:
            ArgumentError: an empty ``kind``.
        """
        if not isinstance(self.kind, str) or not self.kind:
            raise ArgumentError("kind", f"a schema's kind is a non-empty name, got {self.kind!r:.40}")
        for name in ("value_columns", "plain_columns", "label_columns", "pair_metadata", "numeric_notes"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        object.__setattr__(self, "metadata_keys", MappingProxyType(dict(self.metadata_keys)))


#: Measurement-set kind -> what its file holds; the first is :func:`default_kind`.
SCHEMAS: dict[str, Schema] = {
    schema.kind: schema for schema in (
        Schema("cable", "drawstring readings", value_columns=("length",),
               metadata_keys={"anchor": 3, "tool": 3, "length_offset": 1}, refuse_values=nonnegative_readings),
        Schema("position", "positions", value_columns=("x", "y", "z"), point_labels=True, data_values_per_row=3),
        # position [m] and a Hamilton quaternion (w, x, y, z)
        Schema("pose", "6-D poses", value_columns=("x", "y", "z"), plain_columns=("qw", "qx", "qy", "qz"),
               numeric_notes=("noise_deg",), data_values_per_row=7, refuse_values=unit_quaternions),
        # no measured value: a row's labels say which fixture the tool point touches
        Schema("contact", "contact fixtures", label_columns=("contact_id", "plane_id"), metadata_keys={"tool": 3},
               pair_metadata=("distance",), data_values_per_row=0),
        # one detected board corner a row: which corner, and where it is in the image [px]
        Schema("camera", "camera image points", plain_columns=("u_px", "v_px"), point_labels=True,
               point_column="corner_id", data_values_per_row=2, metadata_keys={"board_square": 1, "board_marker": 1},
               numeric_notes=("noise_px", "board_columns", "board_rows", "camera_fx_px", "camera_fy_px",
                              "camera_cx_px", "camera_cy_px", "camera_width_px", "camera_height_px", "camera_k1",
                              "camera_k2", "camera_p1", "camera_p2", "camera_k3")),
    )
}


def register_schema(schema: Schema) -> Schema:
    """Add ``schema`` to :data:`SCHEMAS` under its ``kind`` (replacing one of that kind).

    Args:
        schema: What a measurement file of the kind holds.

    Returns:
        ``schema``.

    Raises:
        ArgumentError: ``schema`` is not a :class:`Schema`.
    """
    if not isinstance(schema, Schema):
        raise ArgumentError("schema", f"expected a measurement Schema, got {type(schema).__name__}")
    SCHEMAS[schema.kind] = schema
    return schema


def default_kind() -> str:
    """The kind of a set made in memory without one: the registry's first."""
    return next(iter(SCHEMAS))

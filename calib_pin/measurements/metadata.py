"""The ``# key: value`` lines above a measurement file's header: which keys calib-pin reads,
and their values in SI.

- ``robot`` and ``end_frame`` are text.
- A registered schema's set-up keys (:attr:`~calib_pin.measurements.schema.Schema.metadata_keys`:
  ``anchor``, ``tool``, ``length_offset``) and every set's ``noise`` are ``<key>_mm`` or
  ``<key>_m``, one number or three (``x, y, z``), read in [m]; each once, in one unit.
- A pair key (:attr:`~calib_pin.measurements.schema.Schema.pair_metadata`: a contact
  set's ``distance``) is ``label, label, length``, in mm or m, one line a pair.
- A schema's numeric notes (:attr:`~calib_pin.measurements.schema.Schema.numeric_notes`:
  a 6-D pose set's ``noise_deg``) are one number each, which the sensor reads itself: kept
  as text, in the standard dialect (``.`` as the decimal mark).
- Every other key is a note, kept as text (:attr:`MeasurementSet.notes`).

Every number is written in the file's dialect (:mod:`calib_pin.measurements.dialect`):
``# noise_mm: 0,05`` and ``# noise_deg: 0,01`` in a file of decimal commas.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import DataError
from .dialect import number, quote, vector_parts
from .schema import SCHEMAS

#: Units of a length key, and their scale to [m].
_LENGTH_UNITS = {"mm": 1e-3, "m": 1.0}

#: A metadata line: (file line, key, value text).
RawLine = tuple[int, str, str]


def keys_of_size(size: int) -> tuple[str, ...]:
    """The set-up metadata keys of the registered schemas that hold ``size`` numbers
    (3: a vector, 1: a scalar; ``noise`` is every set's), in mm or m."""
    keys = dict.fromkeys(k for s in SCHEMAS.values() for k, n in s.metadata_keys.items() if n == size)
    return tuple(keys) + (("noise",) if size == 1 else ())


def meta_name(key: str) -> str:
    """What a metadata key sets: ``anchor`` for ``anchor_mm`` and ``anchor_m``, else the key."""
    base, _, unit = key.rpartition("_")
    return base if base in (*keys_of_size(3), *keys_of_size(1)) and unit in _LENGTH_UNITS else key


def pair_key(key: str) -> tuple[str, float] | None:
    """(name, scale to m) of a registered schema's pair metadata key (``distance_mm``:
    ``label, label, length``, given once a pair), else None."""
    base, _, unit = key.rpartition("_")
    pairs = {k for s in SCHEMAS.values() for k in s.pair_metadata}
    scale = _LENGTH_UNITS.get(unit)
    return (base, scale) if base in pairs and scale else None


def _pair_value(key: str, text: str, path: Path, line: int, decimal: str) -> tuple[str, str, float, int]:
    """``A, B, 300.000`` of a pair key: (label A, label B, length [m], the file line).

    Raises:
        DataError: not two labels and a positive length.
    """
    pair = pair_key(key)
    assert pair is not None
    parts = [p.strip() for p in re.split(r"[;\s]+" if decimal == "," else r"[,;\s]+", text.strip()) if p.strip()]
    if len(parts) != 3:
        raise DataError(str(path), f"needs two labels and a length ('A, B, 300.0'), got '{quote(text)}'", line, key)
    length = number(parts[2], path, line, key, decimal) * pair[1]
    if length <= 0:
        raise DataError(str(path), f"{parts[2]} must be positive", line, key)
    return parts[0], parts[1], length, line


def _value(key: str, text: str, path: Path, line: int, decimal: str) -> tuple[str, Any] | None:
    """One metadata value in SI; (name, value) or None for a note."""
    base, _, unit = key.rpartition("_")
    scale = _LENGTH_UNITS.get(unit)
    if base in keys_of_size(3) and scale:
        parts = vector_parts(text, decimal)
        if len(parts) != 3:
            raise DataError(str(path), f"needs 3 numbers (x, y, z), got '{quote(text)}'", line, key)
        return base, np.array([number(p, path, line, key, mark) for p, mark in parts]) * scale
    if base in keys_of_size(1) and scale:
        value = number(text, path, line, key, decimal) * scale
        if base == "noise" and value <= 0:
            raise DataError(str(path), f"{text.strip()} must be positive", line, key)
        return base, value
    if key in ("robot", "end_frame"):
        return key, text.strip()
    return None


def numeric_notes() -> tuple[str, ...]:
    """The registered schemas' numeric notes (``noise_deg``)."""
    return tuple(dict.fromkeys(k for s in SCHEMAS.values() for k in s.numeric_notes))


def scalar_samples(raw: Iterable[RawLine]) -> Iterator[tuple[str, int, str]]:
    """(text, file line, key) of each scalar number among the metadata lines ``raw`` (what,
    besides the rows, tells a file's decimal mark)."""
    for line, key, value in raw:
        if meta_name(key) in keys_of_size(1) or key in numeric_notes():
            yield value, line, key


def _numeric_note(key: str, text: str, path: Path, line: int, decimal: str) -> str:
    """A numeric note's text in the standard dialect (``0,01`` with decimal commas: ``0.01``).

    Raises:
        DataError: not a number in the file's dialect.
    """
    number(text, path, line, key, decimal)
    return text.strip().replace(",", ".") if decimal == "," else text.strip()


def read_metadata(raw: Iterable[RawLine], path: Path, decimal: str) -> tuple[dict[str, Any], dict[str, str]]:
    """The metadata lines ``raw`` as (values by name, in SI; notes by key, as text); a pair
    key's value is a list of (label, label, length [m], file line).

    Raises:
        DataError: a value that is not what its key holds, a pair key in two units.
    """
    meta: dict[str, Any] = {}
    notes: dict[str, str] = {}
    units: dict[str, tuple[str, int]] = {}
    for line, key, value in raw:
        pair = pair_key(key)
        if pair is not None:  # one line a pair, all in one unit
            seen = units.setdefault(pair[0], (key, line))
            if seen[0] != key:
                raise DataError(str(path), f"{seen[0]} on line {seen[1]} and {key} here mix units: give every "
                                f"{pair[0]} in one unit", line, key)
            meta.setdefault(pair[0], []).append(_pair_value(key, value, path, line, decimal))
            continue
        converted = _value(key, value, path, line, decimal)
        if key in numeric_notes():
            notes[key] = _numeric_note(key, value, path, line, decimal)
        elif converted is None:
            notes[key] = value.strip()
        else:
            meta[converted[0]] = converted[1]
    return meta, notes

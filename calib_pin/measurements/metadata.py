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
- Every other key is a note, kept as text (:attr:`MeasurementSet.notes`); free text stays
  legal. But a note that looks like a key calib-pin reads is refused, as a column that looks
  like one of ours is (:mod:`calib_pin.measurements.columns`): a key of another case
  (``# Anchor_mm``), of another unit or none (``# anchor_cm``, ``# noise``), or a near-miss
  (one edit for keys of up to 4 characters, two otherwise, letter swaps counting one:
  ``# anchor_mn``), of a key the file does not give, whose value is what that key holds
  (three numbers for ``anchor_mm``; ``# tool: Schunk gripper`` stays a note).

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
from .columns import distance
from .dialect import KEY, as_number, number, quote, vector_parts
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


def sets(key: str) -> tuple[bool, str]:
    """What a metadata line sets, for the rule "each key once": (a key calib-pin reads,
    its :func:`meta_name`): ``anchor_mm`` and ``anchor_m`` set one thing, a note ``tool``
    beside ``tool_mm`` another."""
    return key in known_keys(), meta_name(key)


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


#: What a key's value holds (:func:`known_keys`): text, a number, three numbers, or a pair
#: (``label, label, length``).
TEXT, NUMBER, VECTOR, PAIR = "text", "number", "vector", "pair"


def known_keys() -> dict[str, str]:
    """Every metadata key calib-pin reads (the registered schemas' too) -> what its value
    holds (:data:`TEXT`, :data:`NUMBER`, :data:`VECTOR` or :data:`PAIR`)."""
    keys = {"robot": TEXT, "end_frame": TEXT, KEY: TEXT}
    for base, holds in [*((k, VECTOR) for k in keys_of_size(3)), *((k, NUMBER) for k in keys_of_size(1)),
                        *((k, PAIR) for s in SCHEMAS.values() for k in s.pair_metadata)]:
        keys.update({f"{base}_{unit}": holds for unit in _LENGTH_UNITS})
    keys.update({k: NUMBER for k in numeric_notes()})
    return keys


#: Units a length or angle is written in that calib-pin does not read (``# anchor_cm``):
#: a key in one of them is a unit mistake, not a typo.
_OTHER_UNITS = frozenset({"um", "nm", "cm", "dm", "km", "in", "inch", "inches", "ft", "mil", "deg", "rad", "mrad",
                          "urad", "arcsec", "arcmin"})


def _holds(text: str, holds: str, decimal: str) -> bool:
    """``text`` may be a value of what a key ``holds`` (in the file's decimal mark): any
    text for a text key, one number for a number, several for a vector (three, or a
    number short or over), a pair ending in a number; a note in words is not."""
    if holds == TEXT:
        return bool(text.strip())
    if holds == PAIR:
        fields = [p for p in re.split(r"[;\s]+" if decimal == "," else r"[,;\s]+", text.strip()) if p]
        return len(fields) == 3 and as_number(fields[2], decimal) is not None
    parts = vector_parts(text, decimal)
    count = (len(parts) == 1) if holds == NUMBER else (2 <= len(parts) <= 4)
    return count and all(as_number(p, mark) is not None for p, mark in parts)


def _looks_known(key: str, text: str, given: set[str], decimal: str) -> tuple[str, str] | None:
    """(the known key meant, why) when the note ``key`` (value ``text``) looks like a key
    calib-pin reads that the file does not give (``given``: their :func:`meta_name`), and
    ``text`` is what that key holds; else None."""
    known = [k for k, holds in known_keys().items() if meta_name(k) not in given and _holds(text, holds, decimal)]
    lower = key.lower()
    base, _, unit = lower.rpartition("_")
    units = [k for k in known if k.rpartition("_")[0] == (base or unit)]
    if units and (not base or unit in _OTHER_UNITS):  # anchor_cm, noise: a key of ours, its unit not read
        said = f"unit '{unit}' is not read" if base else "no unit"
        return units[0], f"{said}: {', '.join(units[:-1])} or {units[-1]}" if len(units) > 1 else f"{said}: {units[0]}"
    if lower in known and lower != key:
        return lower, "keys are case-sensitive"
    for d, _, k in sorted((distance(lower, k), abs(len(k) - len(key)), k) for k in known):  # nearest, then as long
        if d <= (1 if len(k) <= 4 else 2):
            return k, ""
    return None


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
        DataError: a value that is not what its key holds, a pair key in two units, a
            note whose key looks like one calib-pin reads (a typo, another case or unit).
    """
    meta: dict[str, Any] = {}
    notes: dict[str, str] = {}
    units: dict[str, tuple[str, int]] = {}
    raw = list(raw)
    given = {meta_name(key) for _, key, _ in raw if key in known_keys()}
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
            looks = _looks_known(key, value, given, decimal)
            if looks is not None:
                meant, why = looks
                raise DataError(str(path), f"unknown metadata key; did you mean {meant}? ({why + '; ' if why else ''}"
                                "a note's key must not look like one calib-pin reads)", line, quote(key))
            notes[key] = value.strip()
        else:
            meta[converted[0]] = converted[1]
    return meta, notes

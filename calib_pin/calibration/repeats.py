"""Rows of one measurement given to a calibration twice: the same file again, or rows repeated.

A row fitted twice counts twice: it shrinks the uncertainty, and held out in one set it
trains in the other, so a test figure would include training rows. Two sets (or a set
and a validation session) are refused when

- they are one file: the same path, the same file under another name (a hard link), or
  a file of identical contents (a copy); subsets of one file that share no line are two sets;
- they repeat rows: the same joint angles, the same readings and the same labels (marker,
  fixture), each to the coarser of the two files' precision (:func:`precision`).

Repeated readings at one pose inside ONE file are legal (a repeatability study), and two
sessions of one pose list share joint angles but not readings. So rows of another set at
the joint angles of some of a set's rows are repeats only when they agree in their
readings more often than not (more of those rows repeated than measured anew), and at
least :data:`MIN_REPEATED` rows (or the whole of the smaller set) repeat: a reading that
agrees once to the file's last digit is chance.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..measurements import MeasurementSet

#: Rows that must repeat before two sets are refused (unless the smaller has fewer rows).
MIN_REPEATED = 2

#: The most decimals a column's precision is looked for with (a number written with more,
#: or computed in memory, is compared as it is).
MAX_DECIMALS = 12


def _decimals(column: np.ndarray) -> int:
    """The fewest decimals that write every value of ``column`` exactly (to rounding of
    the unit conversion), at most :data:`MAX_DECIMALS`."""
    column = column[np.isfinite(column)]
    for d in range(MAX_DECIMALS + 1):
        scaled = column * 10.0**d
        if np.all(np.abs(scaled - np.round(scaled)) <= 1e-9 * np.maximum(1.0, np.abs(scaled))):
            return d
    return MAX_DECIMALS + 1


def precision(values: np.ndarray, scales: tuple[float, ...]) -> np.ndarray:
    """Each column's last written digit, in the array's own unit: ``values`` (n, c) are SI
    numbers a file wrote in one of ``scales`` units per SI unit (1000 for mm, 180/pi for
    deg, 1 for m or rad): the unit whose numbers are roundest is taken as the file's."""
    values = np.asarray(values, dtype=float).reshape(len(values), -1)
    out = np.empty(values.shape[1])
    for c in range(values.shape[1]):
        d, s = min(((_decimals(values[:, c] * s), s) for s in scales), key=lambda ds: (ds[0], ds[1]))
        out[c] = 10.0**-d / s
    return out


#: The units a file writes joint angles in (deg, rad) and values in (mm, m; a quaternion: 1).
ANGLE_SCALES = (float(np.rad2deg(1.0)), 1.0)
VALUE_SCALES = (1e3, 1.0)


@dataclass(frozen=True)
class Repeats:
    """Rows of set ``a`` that set ``b`` repeats (0-based, each of ``a``'s rows once).

    Attributes:
        a_rows, b_rows: Each repeated row of ``a`` and a row of ``b`` that repeats it.
        remeasured: Rows of ``a`` at joint angles ``b`` also has, read anew there (no row
            of ``b`` repeats them).
    """

    a_rows: np.ndarray
    b_rows: np.ndarray
    remeasured: int

    def refused(self, n_a: int, n_b: int) -> bool:
        """The repeats are rows given twice, not chance (module docstring)."""
        m = len(self.a_rows)
        return m > self.remeasured and (m >= MIN_REPEATED or m == min(n_a, n_b))


def _labels(data: MeasurementSet) -> np.ndarray:
    """Each row's text labels (marker, fixture) as one string, shape (n_rows,)."""
    parts = [np.asarray(data.point_ids, dtype=str)] if data.point_ids is not None else []
    parts += [np.asarray(column, dtype=str) for _, column in sorted(data.labels.items())]
    if not parts:
        return np.full(len(data), "")
    out = parts[0].astype(object)
    for column in parts[1:]:
        out = out + "\x1f" + column.astype(object)
    return out


def _keys(q: np.ndarray, values: np.ndarray, labels: np.ndarray, q_step: np.ndarray,
          v_step: np.ndarray) -> tuple[list[bytes], list[bytes]]:
    """Each row's key of its joint angles, and of its joint angles, values and labels, on
    the grids ``q_step`` and ``v_step`` (the coarser file's last digits)."""
    qi = np.round(q / q_step).astype(np.int64)
    vi = np.round(values / v_step).astype(np.int64) if values.shape[1] else np.zeros((len(q), 0), np.int64)
    q_keys = [row.tobytes() for row in qi]
    full = [qk + row.tobytes() + str(label).encode() for qk, row, label in zip(q_keys, vi, labels, strict=True)]
    return q_keys, full


def repeats(a: MeasurementSet, b: MeasurementSet) -> Repeats:
    """The rows of ``a`` that ``b`` repeats (its joint angles, values and labels, each to
    the coarser file's precision); sets of different kinds or joint counts repeat none."""
    none = Repeats(np.zeros(0, dtype=int), np.zeros(0, dtype=int), 0)
    if a.kind != b.kind or np.shape(a.q)[1:] != np.shape(b.q)[1:]:
        return none
    qa, qb = np.asarray(a.q, dtype=float), np.asarray(b.q, dtype=float)
    va = np.asarray(a.values, dtype=float).reshape(len(a), -1)
    vb = np.asarray(b.values, dtype=float).reshape(len(b), -1)
    if va.shape[1] != vb.shape[1]:
        return none
    q_step = np.maximum(precision(qa, ANGLE_SCALES), precision(qb, ANGLE_SCALES))
    v_step = np.maximum(precision(va, VALUE_SCALES), precision(vb, VALUE_SCALES))
    qa_keys, a_keys = _keys(qa, va, _labels(a), q_step, v_step)
    qb_keys, b_keys = _keys(qb, vb, _labels(b), q_step, v_step)
    first_of: dict[bytes, int] = {}
    for k, key in enumerate(b_keys):
        first_of.setdefault(key, k)
    poses_of_b = set(qb_keys)
    a_rows, b_rows, remeasured = [], [], 0
    for k, (q_key, key) in enumerate(zip(qa_keys, a_keys, strict=True)):
        if key in first_of:
            a_rows.append(k)
            b_rows.append(first_of[key])
        elif q_key in poses_of_b:
            remeasured += 1
    return Repeats(np.asarray(a_rows, dtype=int), np.asarray(b_rows, dtype=int), remeasured)


def same_file(a: MeasurementSet, b: MeasurementSet) -> str | None:
    """How the two sets' files are one (``the same file`` under another name, ``identical
    contents``), or None (different files, a set made in memory, a file not readable)."""
    if not a.source or not b.source:
        return None
    try:
        if Path(a.source).samefile(b.source):
            return "the same file"
        pa, pb = Path(a.source), Path(b.source)
        if pa.stat().st_size == pb.stat().st_size and _digest(pa) == _digest(pb):
            return "a file of identical contents"
    except OSError:
        return None
    return None


def _digest(path: Path) -> bytes:
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").digest()


def shares_lines(a: MeasurementSet, b: MeasurementSet) -> bool:
    """Two sets read from one file hold a line in common (or either is the whole file)."""
    if a.lines is None or b.lines is None:
        return True
    return bool(set(np.asarray(a.lines, dtype=int).tolist()) & set(np.asarray(b.lines, dtype=int).tolist()))


def where(data: MeasurementSet, rows: np.ndarray, limit: int = 4) -> str:
    """``lines 8-27, 40`` of a file's rows (``rows 1-20``, 1-based, of a set in memory):
    runs of consecutive numbers, the first ``limit`` of them, then how many more."""
    numbers = (np.asarray(data.lines, dtype=int)[rows] if data.lines is not None else np.asarray(rows) + 1).tolist()
    numbers = sorted(set(int(n) for n in numbers))
    runs: list[list[int]] = []
    for n in numbers:
        if runs and n == runs[-1][1] + 1:
            runs[-1][1] = n
        else:
            runs.append([n, n])
    shown = ", ".join(f"{lo}" if lo == hi else f"{lo}-{hi}" for lo, hi in runs[:limit])
    more = f" and {len(runs) - limit} more run(s)" if len(runs) > limit else ""
    word = "line" if data.lines is not None else "row"
    return f"{word}{'s' if len(numbers) > 1 else ''} {shown}{more}"


def name(data: MeasurementSet, label: str) -> str:
    """A set's file name (its label for a set made in memory)."""
    return Path(data.source).name if data.source else f"set {label}"


def repeat_error(a: MeasurementSet, a_label: str, b: MeasurementSet, b_label: str) -> str | None:
    """How set ``b`` holds set ``a``'s measurement again (labels name sets made in memory):
    ``it is a.csv again (the same file)``, or ``its lines 8-27 repeat a.csv's lines 8-27 (...)``,
    naming both files and the rows; None when it does not."""
    one = same_file(a, b)
    if one is not None and shares_lines(a, b):
        return f"it is {name(a, a_label)} again ({one})"
    found = repeats(b, a)
    if not found.refused(len(b), len(a)):
        return None
    return (f"its {where(b, found.a_rows)} repeat {name(a, a_label)}'s {where(a, found.b_rows)} (the same joint angles "
            "and readings, to the files' precision)")

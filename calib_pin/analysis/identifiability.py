"""What a set of poses can tell about the parameters: rank, observability, blind spots.

The analysis works on the identification Jacobian J (readings per parameter) with each
column scaled by the parameter's typical size D (1 mm, 2 mrad for DH), so that a
singular value is "metres of reading per typical deviation". With J D = U S V^T
(m poses, r singular values above ``rcond`` times the largest):

- rank r, and the condition number s_1 / s_r of the identifiable part;
- observability indices: O1 = (s_1 ... s_r)^(1/r) / sqrt(m) (Borm and Menq),
  O3 = s_r (the weakest identifiable direction), O4 = s_r^2 / s_1 (Nahvi and
  Hollerbach's noise amplification index); larger is better for all three;
- parameters that cannot be identified (a zero column: the readings do not depend on
  them at all), and combinations that can only be identified together (the null space
  of the remaining columns, in reduced row-echelon form so each reads like
  ``d_2 +1 mm with d_3 -1 mm``: a change no reading sees);
- a base parameter set: r columns chosen by QR with column pivoting, which can be
  estimated with the others held at zero.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from scipy.linalg import qr

from ..estimators.problem import RowProblem, data_rows, row_offsets
from ..estimators.subspace import RCOND, Subspace
from ..sensors.problem import SetProblem
from ..util.arguments import as_array, as_float, as_instance


@dataclass(frozen=True)
class Identifiability:
    """Identifiability of a parameter model on a set of poses.

    Attributes:
        names: Parameter names, shape (n_params,).
        n_poses: Number of readings m.
        singular_values: Of the scaled Jacobian, descending, shape (n_params,)
            [m of reading per typical deviation].
        rank: Identifiable directions r.
        condition: s_1 / s_r.
        o1, o3, o4: Observability indices (module docstring) [m].
        unidentifiable: Parameters the readings do not depend on: a zero column, or a null
            direction of that parameter alone (at a start that slightly breaks a degeneracy).
        combinations: Combinations identifiable only together, readable text.
        base: Base parameter set (r names, QR with column pivoting).
        directions: Named directions the sensor states (a contact set's scale), each
            (name, seen, what makes it seen): seen when the scaled Jacobian moves the
            readings along it by more than the cut (``rcond`` times s_1) per unit.
    """

    names: tuple[str, ...]
    n_poses: int
    singular_values: np.ndarray
    rank: int
    condition: float
    o1: float
    o3: float
    o4: float
    unidentifiable: tuple[str, ...]
    combinations: tuple[str, ...]
    base: tuple[str, ...]
    #: Unknowns held at their start (``--fix``/``--free``), left out of the analysis.
    fixed: tuple[str, ...] = ()
    directions: tuple[tuple[str, bool, str], ...] = ()

    def as_dict(self) -> dict:
        """JSON-ready summary (no singular values)."""
        return {
            "rank": self.rank, "unknowns": len(self.names), "condition": self.condition,
            "o1": self.o1, "o3": self.o3, "o4": self.o4,
            "unidentifiable": list(self.unidentifiable), "combinations": list(self.combinations),
            "base": list(self.base), **({"fixed": list(self.fixed)} if self.fixed else {}),
            **({"directions": {name: "seen" if seen else "blind" for name, seen, _ in self.directions}}
               if self.directions else {}),
            "note": "the estimators move only the identifiable directions; the blind ones stay at their start (zero)",
        }

    def report(self) -> str:
        """A few lines for people."""
        n = len(self.names)
        lines = [
            f"identification Jacobian: {self.n_poses} values (readings or coordinates) x {n} unknowns "
            "(columns scaled by each unknown's typical size, e.g. 1 mm, 2 mrad)",
            f"rank {self.rank} of {n}; condition number {self.condition:.3g}",
            f"observability: O1 {self.o1:.3g}, O3 {self.o3:.3g}, O4 {self.o4:.3g} "
            "(m of reading per typical deviation; larger is better)",
            "not identifiable (no effect on the readings): "
            + (", ".join(self.unidentifiable) or "none"),
            "identifiable only in combination (moving these together changes no reading):",
        ]
        lines += [f"  {c}" for c in self.combinations] or ["  none"]
        lines.append(f"base parameter set ({len(self.base)}, QR with column pivoting): " + ", ".join(self.base))
        if self.fixed:
            lines.append(f"held at their start (--fix/--free), left out: {', '.join(self.fixed)}")
        for name, seen, hint in self.directions:
            lines.append(f"{name}: seen" if seen else f"{name}: BLIND, no residual changes along it ({hint})")
        return "\n".join(lines)


#: The smallest entry of an orthonormal null-space basis (scaled coordinates) that
#: :func:`_null_lines` takes as a pivot: a smaller one is a start's slight breaking of an exact
#: degeneracy (at zero deviations it is 0), and dividing by it printed coefficients of 1e16.
PIVOT_TOL = 1e-3


def _null_lines(null: np.ndarray, names: list[str], scale: np.ndarray, units: list[str],
                tol: float = 0.05, pivot_tol: float = PIVOT_TOL) -> list[list[tuple[int, str]]]:
    """Null-space basis (k, n) of scaled coordinates, in reduced row-echelon form, as lines of text.

    The basis has orthonormal rows. Each line is a change of the parameters (in mm and
    mrad) that no reading sees, led by its pivot (+1 typical size), its terms in parameter
    order, the lines in pivot order.

    The pivots are chosen in parameter order, each the largest entry of its column among
    the rows left, and only if it is at least ``tol`` of the largest entry of its row (its
    line then keeps the parameters that make it up); the rows left then take any pivot
    above ``pivot_tol``. So no coefficient grows beyond 1 / tol (then 1 / pivot_tol): at a
    start, where an exact degeneracy of zero deviations is slightly broken, the lines are
    those at zero (an RREF pivoting on such a sliver gives coefficients like -6e16 mrad). A term
    below ``tol`` (scaled) is left out. Each line is its terms as (column, text), the
    text a parameter's change in mm or mrad (``d_2 +1 mm``).
    """
    a = null.copy()
    rows, cols = a.shape
    pivots: list[int] = []
    for ratio in (tol, 0.0):
        for c in range(cols):
            if len(pivots) == rows:
                break
            if c in pivots:
                continue
            top = len(pivots)
            p = top + int(np.argmax(np.abs(a[top:, c])))
            free = [k for k in range(cols) if k not in pivots]
            if abs(a[p, c]) < max(pivot_tol, ratio * np.abs(a[p, free]).max()):
                continue
            a[[top, p]] = a[[p, top]]
            a[top] /= a[top, c]
            for r in range(rows):
                if r != top:
                    a[r] -= a[r, c] * a[top]
            pivots.append(c)
    out = []
    for k in np.argsort(pivots, kind="stable"):
        terms = []
        for i, v in enumerate(a[k]):
            if abs(v) > tol:
                size = v * scale[i] * 1e3
                unit = {"m": "mm", "rad/Nm": "mrad/Nm"}.get(units[i], "mrad")
                terms.append((i, f"{names[i]} {size:+.2g} {unit}"))
        out.append(terms)
    return out


#: The largest Jacobian (values) :func:`_jacobian` and :func:`_svd` keep for the next call
#: (8 MB): a calibration's support check and its report analyse the same training rows.
MEMO_VALUES = 1_000_000

#: The last Jacobian and SVD made here, each with what it was made from: ``[key, value]``.
_LAST_JACOBIAN: list[Any] = []
_LAST_SVD: list[Any] = []


def _key(problem: Any, x: np.ndarray) -> tuple[Any, ...] | None:
    """What ``problem``'s Jacobian at ``x`` is made from, or None for a problem of other fields.

    Its class, its measurement model (the object) and every array field's bytes, of each
    part and its weight for a calibration problem of several parts; a problem of other
    fields is not kept.
    """
    parts = getattr(problem, "parts", None)
    if parts is not None:  # a calibration problem: its parts' keys, weights and columns
        keys = [_key(part, problem.model.part_x(x, k)) for part, k in zip(parts, problem.sets, strict=True)]
        if any(k is None for k in keys):
            return None
        return (type(problem), problem.model, x.tobytes(), np.asarray(problem.weights).tobytes(), tuple(problem.sets),
                *keys)
    if not isinstance(problem, SetProblem):
        return None
    key: list[Any] = [type(problem), x.tobytes()]
    for f in fields(problem):
        value = getattr(problem, f.name)
        if isinstance(value, np.ndarray):
            key.append((value.dtype.str, value.shape, value.tobytes()))
        elif value is None or f.name == "model":
            key.append(value)
        else:
            return None
    return tuple(key)


def _same(a: Any, b: Any) -> bool:
    """Keys of :func:`_key` equal: the same classes and model objects, equal bytes."""
    if isinstance(a, tuple) and isinstance(b, tuple) and a and isinstance(a[0], type):
        return len(a) == len(b) and all(_same(u, v) for u, v in zip(a, b, strict=True))
    if isinstance(a, bytes | tuple):
        return bool(a == b)
    return a is b


def _jacobian(problem: Any, x: np.ndarray) -> np.ndarray:
    """``problem.jacobian(x)``, or a copy of the last call's when it was of the same rows, model and x.

    The last array is kept read-only here; the caller's copy is its own: a Jacobian is a
    pure function of them.
    """
    key = _key(problem, x)
    if key is not None and _LAST_JACOBIAN and _same(_LAST_JACOBIAN[0], key):
        return np.array(_LAST_JACOBIAN[1])
    jacobian = problem.jacobian(x)
    _LAST_JACOBIAN[:] = []
    if key is not None and jacobian.size <= MEMO_VALUES:
        kept = np.array(jacobian)  # a copy: the caller's array stays its own
        kept.setflags(write=False)
        _LAST_JACOBIAN[:] = [key, kept]
    return jacobian


def _svd(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The singular values and right singular vectors of ``np.linalg.svd(matrix, full_matrices=False)``.

    For a matrix of the same bytes as the last call's, copies of that call's (kept
    read-only here; the caller's copies are its own).
    """
    key = (matrix.shape, matrix.tobytes())
    if _LAST_SVD and _LAST_SVD[0] == key:
        s, vt = _LAST_SVD[1]
        return np.array(s), np.array(vt)
    _, s, vt = np.linalg.svd(matrix, full_matrices=False)
    _LAST_SVD[:] = []
    if matrix.size <= MEMO_VALUES:
        kept = (np.array(s), np.array(vt))  # copies: the caller's arrays stay its own
        for array in kept:
            array.setflags(write=False)
        _LAST_SVD[:] = [key, kept]
    return s, vt


def analyze(problem: Any, x: np.ndarray | None = None, rcond: float = RCOND,
            fixed: tuple[str, ...] = ()) -> Identifiability:
    """Identifiability of ``problem``'s unknowns at x (default zero).

    Args:
        fixed: Unknowns held at their start (``calibrate --fix``): their columns are left
            out, so the directions shown are those of the unknowns estimated.
        rcond: Singular values below ``rcond`` times the largest count as zero (the
            same cut the estimators' search space uses, :data:`calib_pin.estimators.subspace.RCOND`).

    Raises:
        ArgumentError: not a problem, x not of shape (n_params,) or not finite, rcond
            not in (0, 1).
    """
    as_instance(problem, "problem", RowProblem, "a calibration problem (calib_pin.prepare(...).problem)")
    model = problem.model
    names = list(model.names)
    x = np.zeros(len(names)) if x is None else as_array(x, "x", (len(names),))
    rcond = as_float(rcond, "rcond", 0.0, 1.0, low_open=True, high_open=True)
    keep = np.array([n not in fixed for n in names], dtype=bool)
    jacobian = _jacobian(problem, x)[:, keep]
    scale, units = np.asarray(model.scale)[keep], [u for u, k in zip(model.units, keep, strict=True) if k]
    names = [n for n, k in zip(names, keep, strict=True) if k]
    scaled = jacobian * scale
    space = Subspace.of_svd(*_svd(scaled), scale, x[keep], rcond)  # Subspace.of(jacobian, scale, ...)
    m, n = scaled.shape
    s, rank, kept = space.singular_values, space.rank, space.kept
    column = np.linalg.norm(scaled, axis=0)
    dead = column <= rcond * s[0] / np.sqrt(n)
    live = np.flatnonzero(~dead)
    # The null space of the live columns: every right singular vector, so the square
    # factor is (live x live), never (m x m).
    if len(live) == n and m >= n:  # every column: the SVD above
        s_live, vt_live = _svd(scaled)
    else:
        _, s_live, vt_live = np.linalg.svd(scaled[:, live], full_matrices=m < len(live))
    live_rank = int(np.sum(s_live > rcond * s[0]))
    null = vt_live[live_rank:]
    lines = _null_lines(null, [names[i] for i in live], scale[live], [units[i] for i in live]) if len(null) else []
    # A null direction of one parameter alone: its column is not zero (a start's slight
    # breaking of an exact degeneracy: theta_6 beside a tiny a_6) but no reading sees it.
    alone = [int(live[line[0][0]]) for line in lines if len(line) == 1]
    _, _, pivots = qr(scaled, pivoting=True, mode="economic")
    directions = []
    named = getattr(problem, "named_directions", None)  # the sensor's own, if it names any
    for name, (v, hint) in (named(x) if named is not None else {}).items():
        u = (np.asarray(v, dtype=float) / model.scale)[keep]  # the held unknowns' columns are left out
        seen = bool(np.linalg.norm(scaled @ u) > rcond * s[0] * np.linalg.norm(u))
        directions.append((name, seen, hint))
    return Identifiability(
        names=tuple(names),
        n_poses=m,
        singular_values=s,
        rank=rank,
        condition=float(kept[0] / kept[-1]),
        o1=float(np.exp(np.mean(np.log(kept))) / np.sqrt(m)),
        o3=float(kept[-1]),
        o4=float(kept[-1] ** 2 / kept[0]),
        unidentifiable=tuple(names[i] for i in sorted(set(np.flatnonzero(dead)) | set(alone))),
        combinations=tuple(" with ".join(text for _, text in line) for line in lines if len(line) > 1),
        base=tuple(names[i] for i in sorted(pivots[:rank])),
        fixed=tuple(n for n in model.names if n in fixed),
        directions=tuple(directions),
    )


def distinct_values(problem: Any) -> int:
    """How many values the distinct rows of ``problem`` hold.

    A row repeated (the same pose and point) counts once, each row its own size
    (``row_offsets``); a stacked problem's sets in turn (a cable's length and a tracker's
    position at one pose are both counted).
    """
    parts = getattr(problem, "parts", None)
    if parts is not None:
        return sum(distinct_values(p) for p in parts)
    rows = problem.q if problem.points is None else np.column_stack([problem.q, problem.points])
    _, first = np.unique(rows, axis=0, return_index=True)
    sizes = np.diff(row_offsets(problem))
    data = data_rows(problem)  # row k of q is row data[k]; the rest (known distances) count once each
    return int(sizes[data[first]].sum() + sizes[np.setdiff1d(np.arange(problem.n_rows), data)].sum())


def support_error(problem: Any, rcond: float = RCOND) -> str | None:
    """Why the rows of ``problem`` (the training rows) cannot calibrate anything, or None.

    Rank deficiency alone is normal (the blind directions stay at zero); refused are only
    sets from which nothing of the robot can be learnt:

    - every row at one distinct pose (identical poses): one configuration cannot tell the
      robot's geometry from the sensor's reading;
    - distinct poses whose values are no more than the sensor's own unknowns (the device
      frame, markers, anchor, offset), or whose identifiable directions all belong to them
      (the rank of the robot's columns, deviations and compliances, beyond the sensor's is 0).

    The message starts "the training poses identify only R of N directions".
    """
    model = problem.model
    n = problem.n_params
    sensor = n - model.sensor_start
    scaled = _jacobian(problem, np.zeros(n)) * model.scale
    space = Subspace.of_svd(*_svd(scaled), np.ones(n), rcond=rcond)  # Subspace.of(scaled, np.ones(n), ...)
    poses = len(np.unique(problem.q, axis=0))
    values = distinct_values(problem)
    reason = None
    if poses < 2:
        reason = (f"all {problem.n_rows} rows are at 1 distinct pose (identical poses?): one pose cannot tell the "
                  "robot's geometry from the sensor's reading")
    elif values <= sensor:
        reason = (f"{poses} distinct poses give {values} distinct values, no more than the sensor's own unknowns "
                  f"({sensor})")
    elif sensor:
        s = space.singular_values
        sensor_rank = int(np.sum(np.linalg.svd(scaled[:, model.sensor_start:], compute_uv=False) > rcond * s[0]))
        if space.rank <= sensor_rank:
            reason = (f"every direction {poses} distinct poses identify belongs to the sensor's own unknowns "
                      f"({sensor}): none is the robot's")
    if reason is None:
        return None
    return (f"the training poses identify only {space.rank} of {n} directions: {reason}; nothing can be "
            "calibrated from them: measure more varied poses")

"""How well the data pins each robot deviation down: intervals only for what it determines.

The robot's free deviations split into what the training rows determine and what they do
not (:mod:`calib_pin.analysis.determined`, in units of the prior). A deviation gets a
standard error and a 95 % interval only when the data determines it alone (it carries
less than :data:`IDENTIFIED` of its prior variance into the directions not determined).
Deviations the data determines only together (``d_2`` and ``d_3`` of parallel joints) are
shown once per **combination**, each combination with its value and interval: the split
between them is the start's (the robot stays there along what the data does not see), not
the data's. A deviation the data does not see at all is ``not determined`` (it keeps its
start); one ``--fix`` holds is ``held``. Neither has an interval.

The noise covariance of the robot's determined part is sigma^2 W V_d S_d^-2 V_d^T W; a
sensor unknown's interval comes from the information left to the sensor's unknowns with the
robot free along what the data determines and held along the rest
(:func:`sensor_variance`): a sensor direction the data sees only weakly keeps its large
variance, since the fit moves along it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..util.units import human_unit
from .determined import UNSEEN, Determined, pinv_gram

#: z of the two-sided 95 % normal interval.
Z95 = 1.959964
#: A deviation carrying less than this share of its prior variance into the directions not
#: determined is determined alone (an interval of its own).
IDENTIFIED = 0.01
#: A term of a combination below this (in prior units, the leading term 1) is left out.
TERM_TOL = 0.02

#: A direction not determined belongs to a group of deviations when its part there has at least this norm.
IN_GROUP = 0.1

STATUS = ("identified", "combination", "not determined", "held")


@dataclass(frozen=True)
class Combination:
    """A combination of deviations the data determines, though not each alone.

    Attributes:
        terms: (parameter index, coefficient in the unit of the leading term per the
            parameter's unit, SI) of each term; the leading term's coefficient is 1.
        text: For people: ``d_2 + 1.00 d_3`` (coefficients in mm/mm, mm/mrad, ...).
        value: The combination's value at the estimate, in the leading term's SI unit.
        std: Its standard error, same unit.
        unit: The leading term's SI unit.
    """

    terms: tuple[tuple[int, float], ...]
    text: str
    value: float
    std: float
    unit: str

    def as_dict(self) -> dict[str, Any]:
        factor, suffix = human_unit(self.unit)
        v, s = self.value * factor, self.std * factor
        return {"combination": self.text, "unit": suffix, "value": v, "std": s, "ci95": [v - Z95 * s, v + Z95 * s]}


@dataclass(frozen=True)
class Uncertainty:
    """Uncertainty of an estimate.

    Attributes:
        names, units: Every unknown's name and SI unit.
        x: The estimate, SI units.
        std: Standard error of each unknown, SI units; NaN for a robot deviation without an
            interval of its own (see ``status``).
        status: Each unknown's :data:`STATUS` (sensor unknowns: ``identified``).
        combinations: What the data determines of the deviations in ``combination``.
        noise: The residual's noise the intervals assume (1 sigma), [m].
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    x: np.ndarray
    std: np.ndarray
    status: tuple[str, ...]
    combinations: tuple[Combination, ...]
    noise: float

    def as_dict(self) -> dict:
        """JSON-ready: each unknown's value and status, intervals where identified, the combinations.

        Per unknown its value, status and (identified ones) standard error and 95 % interval,
        in mm/deg; the combinations with theirs.
        """
        out = {}
        for name, unit, value, std, status in zip(self.names, self.units, self.x, self.std, self.status, strict=True):
            f, suffix = human_unit(unit)
            entry: dict[str, Any] = {"value": value * f, "status": status}
            if status == "identified":
                s = std * f
                entry.update(std=s, ci95=[value * f - Z95 * s, value * f + Z95 * s])
            else:  # no interval of its own: null, so that a reader of the keys finds them
                entry.update(std=None, ci95=None)
            out[f"{name}_{suffix}" if suffix else name] = entry  # a unit-free unknown (a lens's k1): its name
        return {"parameters": out, "combinations": [c.as_dict() for c in self.combinations],
                "noise_mm": self.noise * 1e3}


def _groups(vectors: np.ndarray, tol: float) -> list[list[int]]:
    """Indices (rows of ``vectors`` (n, k)) linked by a shared column entry above ``tol``."""
    n = len(vectors)
    parent = list(range(n))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for col in vectors.T:
        members = np.flatnonzero(np.abs(col) > tol * max(np.abs(col).max(), 1e-300))
        for m in members[1:]:
            parent[find(int(m))] = find(int(members[0]))
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(find(i), []).append(i)
    return list(groups.values())


def _rref(a: np.ndarray, tol: float = 1e-9) -> tuple[np.ndarray, list[int]]:
    """Rows brought to reduced row-echelon form with complete pivoting, and their pivot columns.

    The rows of ``a`` (independent) brought to reduced row-echelon form with complete
    pivoting (each pivot the largest entry left): the same span, each row led by its pivot
    (1), no other row's entry in a pivot column, and no entry above 1 in size. Rows that
    span a space in an arbitrary basis (a null space's) come out sparse, one small
    combination each. Returns the rows and their pivot columns.
    """
    a = a.copy()
    pivots: list[int] = []
    for row in range(len(a)):
        rest = np.abs(a[row:])
        rest[:, pivots] = 0.0
        flat = int(np.argmax(rest))
        p, c = flat // rest.shape[1], flat % rest.shape[1]
        if rest[p, c] < tol:
            return a[:row], pivots
        a[[row, row + p]] = a[[row + p, row]]
        a[row] /= a[row, c]
        for r in range(len(a)):
            if r != row:
                a[r] -= a[r, c] * a[row]
        pivots.append(int(c))
    return a, pivots


def _combinations(split: Determined, members: list[int], names: tuple[str, ...], units: tuple[str, ...],
                  x: np.ndarray, noise_cov: np.ndarray) -> list[Combination]:
    """The combinations of the free robot unknowns ``members`` the data determines.

    The combinations of the free robot unknowns ``members`` (positions in ``split.robot``)
    the data determines: the complement of the directions not determined, within them.
    """
    undetermined = split.vt[split.rank:].T[members]  # (k, d), prior units
    u, s, _ = np.linalg.svd(undetermined, full_matrices=True)
    rank = int(np.sum(s > IN_GROUP))  # the directions are orthonormal: one of the group's has a norm near 1 here
    complement = u[:, rank:].T  # (k - rank, k): functionals orthogonal to every direction not determined
    if not len(complement):
        return []
    rows, _ = _rref(complement)
    out = []
    index = split.robot[members]
    sigma = split.sigma[members]
    for row in rows:
        lead = int(np.argmax(np.abs(row) > TERM_TOL))
        coef = row / row[lead]
        coef[np.abs(coef) < TERM_TOL] = 0.0
        physical = coef * sigma[lead] / sigma  # lead unit per unit of each term
        terms = tuple((int(index[j]), float(physical[j])) for j in np.flatnonzero(coef))
        value = float(sum(k * x[i] for i, k in terms))
        idx = np.array([i for i, _ in terms])
        k = np.array([c for _, c in terms])
        std = float(np.sqrt(max(k @ noise_cov[np.ix_(idx, idx)] @ k, 0.0)))
        lead_unit = units[terms[0][0]]
        text = names[terms[0][0]]
        for i, c in terms[1:]:
            factor = human_unit(lead_unit)[0] / human_unit(units[i])[0]
            ratio = _ratio_unit(lead_unit, units[i])
            size = f"{abs(c * factor):.3g}{ratio} " if ratio or abs(abs(c * factor) - 1) > 5e-4 else ""
            text += f" {'+' if c >= 0 else '-'} {size}{names[i]}"
        out.append(Combination(terms, text, value, std, lead_unit))
    return out


def _ratio_unit(lead: str, other: str) -> str:
    """`` mm/deg`` between unlike units of a combination's coefficient; empty for like units."""
    if lead == other:
        return ""
    return f" {human_unit(lead)[1]}/{human_unit(other)[1]}"


#: The sensor unknowns' covariance leaves out only directions whose singular value is below this times the
#: largest: an exact gauge among them, not a direction the data sees weakly (which the fit does move along).
GAUGE_RCOND = 1e-6


def sensor_variance(split: Determined, scale: np.ndarray) -> np.ndarray:
    """The noise variance of each free sensor unknown, SI^2, in the order of ``split.free``'s sensor unknowns.

    The robot moves only along the directions the data determines (it is held at its start
    along the others), the sensor's unknowns freely: the Gram matrix of those moves is
    inverted, leaving out only an exact gauge among them (:data:`GAUGE_RCOND`). A sensor
    direction the data sees weakly (a lens's k1, k2, k3 together) keeps its large variance:
    the fit moves along it with the noise.
    """
    scale = np.asarray(scale, dtype=float)[split.free]
    on_robot = np.isin(split.free, split.robot)
    n_robot = int(on_robot.sum())
    basis = (split.sigma / scale[on_robot])[:, None] * split.vt[: split.rank].T  # robot moves, scaled units
    moves = np.zeros((len(split.free), split.rank + len(split.free) - n_robot))
    moves[np.ix_(on_robot, np.arange(split.rank))] = basis
    moves[~on_robot, split.rank:] = np.eye(len(split.free) - n_robot)
    inverse = pinv_gram(moves.T @ split.gram @ moves, GAUGE_RCOND)
    return split.noise**2 * np.diag(inverse)[split.rank:] * scale[~on_robot] ** 2


def estimate_uncertainty(problem: Any, x: np.ndarray, split: Determined, *,
                         held: tuple[int, ...] = ()) -> Uncertainty:
    """Uncertainty of the estimate x fitted to ``problem`` (the training rows).

    Args:
        problem: The training rows' problem (residual in units of ``split.noise``).
        x: The estimate, shape (n_params,), SI.
        split: What the rows determine of the robot at x.
        held: Indices of the unknowns held at their start (``--fix``).
    """
    model = problem.model
    names, units = tuple(model.names), tuple(model.units)
    n = len(names)
    noise_cov, _ = split.covariance()
    std = np.full(n, np.nan)
    status = ["identified"] * n
    for i in held:
        status[i] = "held"
    share = split.blind_share()
    for j, i in enumerate(split.robot):
        if share[j] > UNSEEN:
            status[i] = "not determined"
        elif share[j] > IDENTIFIED:
            status[i] = "combination"
        else:
            std[i] = np.sqrt(max(noise_cov[i, i], 0.0))
    sensor = [i for i in range(model.sensor_start, n) if i not in held]
    if sensor:
        for i, variance in zip(split.free[split.free >= model.sensor_start], sensor_variance(split, model.scale),
                               strict=True):
            std[i] = np.sqrt(max(variance, 0.0))
    position = {int(i): j for j, i in enumerate(split.robot)}
    mixed = [position[i] for i in split.robot if status[i] == "combination"]
    combinations: list[Combination] = []
    if mixed:
        sparse, _ = _rref(split.vt[split.rank:])  # the directions not determined, each a small combination
        undetermined = sparse.T
        for group in _groups(undetermined[mixed], TERM_TOL):
            members = [mixed[g] for g in group]
            combinations += _combinations(split, members, names, units, x, noise_cov)
    combinations.sort(key=lambda c: [i for i, _ in c.terms])  # in parameter order
    return Uncertainty(names=names, units=units, x=np.asarray(x, dtype=float), std=std, status=tuple(status),
                       combinations=tuple(combinations), noise=split.noise)

"""The noise of each measurement set (and of each part of a row), stated or estimated from the data.

A set's noise sigma_k weighs its rows against the other sets' (w_k = sigma_0 / sigma_k),
and sigma_0 is the noise the Kalman filters assume (R = sigma_0^2). A part of a row with a
noise of its own (a 6-D pose's orientation beside its position,
:meth:`~calib_pin.sensors.base.MeasurementModel.noise_parts`) is a component too. Each
component's sigma is the caller's or its file's; the others are estimated where they
matter (several components, or a method that weighs rows by the noise) by
variance-component estimation on a pilot Levenberg-Marquardt fit of the training rows:
fit, then for each unknown component

    sigma_k^2 = r_k . r_k / dof_k,    dof_k = n_k - h_k,

(r_k: its unweighted training residual, n_k its values, h_k their leverages summed: the
diagonal of the weighted fit's hat matrix over the identifiable directions of the
training Jacobian at the fit, which add up to its rank; a set's own sensor unknowns, or a
weight that makes the fit follow it, are taken up by its own values), refit with the new
weights, until no sigma moves by more than :data:`TOLERANCE` (at most :data:`MAX_FITS` fits).

A component of fewer than :data:`MIN_DOF` degrees of freedom (a set of one row, or of no
more values than its own unknowns) cannot estimate its noise: its sigma would go to zero
and its weight swamp every other set. It takes the pooled sigma of the estimated
components in its unit (sum r.r / sum dof), else its default, and a warning says so.
Estimates that have not settled after :data:`MAX_FITS` fits keep the geometric mean of the
last fit's sigmas and its residual's (the centre of an oscillation), the method is fitted
with those, and a warning says so. Of one component (one set, rows of one part) this is
sqrt(RSS / (m - r)) of one fit: a blind direction fits nothing, so it takes no degree of
freedom. Every method of a calibration is given the same noise.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..estimators import Method, get_method, run_method
from ..estimators.subspace import Subspace
from ..exceptions import DataError
from .problem import Problem

#: At most this many fits of the variance-component estimation.
MAX_FITS = 5

#: The estimation stops when no sigma moves by more than this (relative).
TOLERANCE = 0.01

#: The largest noise [m] a Kalman filter takes: an estimate beyond it is a misfit of the
#: data, refused naming the data.
MAX_FILTER_NOISE_M = 1.0

#: The smallest noise [m] an estimate may give (a noise-free simulation fits to rounding;
#: a Kalman filter needs R > 0): 1 nm.
FLOOR_M = 1e-9

#: The pilot fit's method.
PILOT = "lm"


@dataclass(frozen=True)
class Noise:
    """Each set's noise: per set, each part's sigma (SI) and where it came from.

    Attributes:
        sigmas: Per set, per part of its rows (one part for most sensors), 1 sigma per
            value, SI [m or rad]; a set's first part is its noise sigma_k.
        origins: Per set and part: ``caller``, ``file``, ``estimate`` (from the data) or
            ``default`` (not stated and not needed: the assumed default).
        fits: Pilot fits it took (0: nothing estimated).
        words: Where sigma_0 came from, for people (``stated``, ``default``, ``estimated: ...``).
        pilot: The last pilot fit's estimate (for a method that is the pilot, its estimate), or None
            (none made, or the sigmas did not settle: the method is fitted with the final ones).
        notes: Lines for the printout: a set whose noise its values cannot estimate (it got a
            pooled or default one), an estimation that did not settle.
    """

    sigmas: tuple[tuple[float, ...], ...]
    origins: tuple[tuple[str, ...], ...]
    fits: int = 0
    words: str = "stated"
    pilot: Any = None
    notes: tuple[str, ...] = ()

    @property
    def set_sigmas(self) -> list[float]:
        """Each set's sigma_k [m]."""
        return [s[0] for s in self.sigmas]

    @property
    def sigma(self) -> float:
        """sigma_0 [m]: the first set's, the noise the Kalman filters assume."""
        return self.sigmas[0][0]


def apply(problem: Problem, noise: Noise) -> Problem:
    """``problem`` with each set weighted by its noise.

    Each set whose rows have parts is also reweighted within
    (:meth:`~calib_pin.sensors.base.MeasurementModel.with_part_noise`).
    """
    from dataclasses import replace

    weighted = problem.with_weights(noise.set_sigmas)
    parts = []
    changed = False
    for k, part in zip(weighted.sets, weighted.parts, strict=True):
        own = part.model.noise_parts()
        sigmas = noise.sigmas[k]
        if own and tuple(p.sigma for p in own) != sigmas:
            part = replace(part, model=part.model.with_part_noise(sigmas, "estimate"))
            changed = True
        parts.append(part)
    return weighted.with_parts(parts) if changed else weighted


def _components(problem: Problem, sigmas: list[float | None], origins: list[str],
                default: float) -> tuple[list[list[float]], list[list[str]]]:
    """Each set's parts' sigma and origin.

    A set whose rows have parts (a 6-D pose) as its model says (``default`` origin: unknown),
    else its one sigma (None: unknown, ``default``).
    """
    out_s, out_o = [], []
    for k, model in enumerate(problem.model.parts):
        own = model.noise_parts()
        if own:
            out_s.append([p.sigma for p in own])
            out_o.append([p.origin for p in own])
        else:
            known = sigmas[k] is not None
            out_s.append([float(sigmas[k]) if known else default])  # type: ignore[arg-type]
            out_o.append([origins[k] if known else "default"])
    return out_s, out_o


def estimate_noise(problem: Problem, train: np.ndarray, sigmas: list[float | None], origins: list[str],
                   method: Method, x0: np.ndarray, *, seed: int, loss: str, fixed: tuple[int, ...],
                   default: float, history: bool = True, source: str = "") -> Noise:
    """Each set's noise for ``method`` on the ``train`` rows of ``problem`` (module docstring).

    Args:
        sigmas, origins: Each set's stated sigma [m] (None: unknown) and its origin.
        x0, seed, loss, fixed: Where the pilot fits start, and as the method's.
        default: The sigma [m] of an unknown component that is not estimated.
        source: The data's name for a refusal.

    Raises:
        DataError: an estimate above :data:`MAX_FILTER_NOISE_M` (the readings do not fit the
            robot and sensor set-up), naming the worst set.
    """
    now, where = _components(problem, sigmas, origins, default)
    flat = [(k, j) for k in range(len(now)) for j in range(len(now[k]))]
    unknown = [(k, j) for k, j in flat if where[k][j] == "default"]
    if not unknown or (len(flat) == 1 and not method.weighs_noise):
        return Noise(tuple(map(tuple, now)), tuple(map(tuple, where)), 0, "default" if unknown else "stated")
    pilot = get_method(PILOT)
    defaults = [list(s) for s in now]
    fits, moved = 0, 0.0
    thin: dict[tuple[int, int], str] = {}
    while True:
        noise = Noise(tuple(map(tuple, now)), tuple(map(tuple, where)))
        training = apply(problem, noise).subset(train)
        estimate = run_method(pilot, training, x0, seed=seed, noise=noise.sigma, loss=loss, fixed=fixed,
                              history=history)
        fits += 1
        residuals = _residuals(training, estimate.x)
        new = [list(s) for s in now]
        if len(flat) == 1:
            (k, j), = unknown
            r = residuals[k][j]
            rank = Subspace.of(training.jacobian(estimate.x), training.scale, estimate.x).rank
            if r @ r > 0:
                new[k][j] = max(float(np.sqrt(r @ r / max(r.size - rank, 1))), FLOOR_M)
        else:
            thin = _components_of(problem, training, estimate.x, fixed, residuals, unknown, new, defaults)
        moved = max((abs(new[k][j] / now[k][j] - 1.0) for k, j in unknown if (k, j) not in thin), default=0.0)
        now = new
        _refuse_misfit(problem, now, unknown, method.name, source)
        if len(flat) == 1 or moved < TOLERANCE or fits >= MAX_FITS:
            break
    settled = len(flat) == 1 or moved < TOLERANCE
    if not settled:  # the centre of an oscillation: the geometric mean of the last fit's sigmas and its residual's
        now = [[float(np.sqrt(a * b)) for a, b in zip(used, got, strict=True)] for used, got in zip(noise.sigmas, now,
                                                                                                   strict=True)]
    for k, j in unknown:
        where[k][j] = thin.get((k, j), "estimate")
    notes = _notes(problem, now, where, fits, moved, settled, set(training.sets))
    stated = where[0][0] in ("caller", "file")
    plural = "s" if fits > 1 else ""
    if stated:
        words = "stated"
    elif len(flat) == 1:
        words = (f"estimated: RSS / (m - r) of a first LM fit on the training rows, m = {training.n_values} values, "
                 f"r = {rank} identifiable directions (the set states no noise)")  # one fit: rank was computed
    elif len(now) == 1:
        words = f"estimated per part from the residual ({fits} fit{plural}; noise_by_part)"
    else:
        words = f"estimated from the residual ({fits} fit{plural})"
    # the last pilot fit was weighted by the sigmas before its own estimate: it is the
    # method's fit only when they settled (of one component, the weights do not matter)
    return Noise(tuple(map(tuple, now)), tuple(map(tuple, where)), fits, words,
                 estimate if settled else None, tuple(notes))


#: A component's residual of fewer degrees of freedom than this does not estimate its noise
#: (with several components): its sigma^2 would be a chi-square of so few degrees of freedom
#: divided by them, which is below a tenth of the truth's square once in a hundred draws at 2,
#: and its weight would swamp the other sets'. Such a set takes the pooled noise of the
#: others in its unit (or the default), and the printout says so.
MIN_DOF = 2.0


def _components_of(problem: Problem, training: Problem, x: np.ndarray, fixed: tuple[int, ...],
                   residuals: dict[int, list[np.ndarray]], unknown: list[tuple[int, int]], new: list[list[float]],
                   defaults: list[list[float]]) -> dict[tuple[int, int], str]:
    """Each unknown component's sigma from its residual, into ``new``: r.r / dof, dof its
    values less their leverage in the weighted fit at x (:func:`_leverages`: the
    identifiable directions its values take up; of one component, the rank). A component
    of fewer than :data:`MIN_DOF` takes the pooled sigma of the estimated ones in its unit
    (sum r.r / sum dof), else its default. Returns those thin components, each with where
    its sigma came from (``pooled``, ``default``)."""
    leverage = _leverages(training, x, fixed)
    dof: dict[tuple[int, int], float] = {}
    for k, j in unknown:
        if k in residuals:
            dof[(k, j)] = residuals[k][j].size - leverage[k][j]
    thin = {(k, j): "default" for k, j in unknown if dof.get((k, j), 0.0) < MIN_DOF}
    pooled: dict[str, list[float]] = {}
    for (k, j), d in dof.items():
        if (k, j) in thin:
            continue
        r = residuals[k][j]
        if r @ r > 0:
            new[k][j] = max(float(np.sqrt(r @ r / d)), FLOOR_M)
        rss, total = pooled.get(_unit(problem, k, j), [0.0, 0.0])
        pooled[_unit(problem, k, j)] = [rss + float(r @ r), total + d]
    for k, j in thin:
        rss, total = pooled.get(_unit(problem, k, j), [0.0, 0.0])
        if rss > 0 and total > 0:
            new[k][j], thin[(k, j)] = max(float(np.sqrt(rss / total)), FLOOR_M), "pooled"
        else:
            new[k][j] = defaults[k][j]
    return thin


def _leverages(training: Problem, x: np.ndarray, fixed: tuple[int, ...]) -> dict[int, list[float]]:
    """Each set's (and part's) share of the weighted fit's identifiable directions at x:
    the sum of its entries' leverages, the diagonal of the hat matrix J (J^T J)^+ J^T over
    the kept directions of the unknowns not ``fixed``
    (:class:`~calib_pin.estimators.subspace.Subspace`: U_r = J D V_r S_r^-1, row norms
    squared). They add up to the rank: a set whose rows alone fit directions (its own
    sensor unknowns, or a weight that makes the fit follow it) takes them up, and is left
    that many fewer degrees of freedom."""
    free = np.array([i not in fixed for i in range(training.n_params)], dtype=bool)
    jacobian = training.jacobian(x)[:, free]
    space = Subspace.of(jacobian, np.asarray(training.scale)[free], np.asarray(x)[free])
    h = np.sum((jacobian @ space.basis) ** 2, axis=1)
    out: dict[int, list[float]] = {}
    start = 0
    for part, k in zip(training.parts, training.sets, strict=True):
        mine = h[start : start + part.n_values]
        start += part.n_values
        entries = part.model.part_entries(part.n_rows)
        out[k] = [float(mine[e].sum()) for e in entries] if entries else [float(mine.sum())]
    return out


def _unit(problem: Problem, k: int, j: int) -> str:
    """The unit of set k's component j (``mm`` of a set of one part; its part's own)."""
    own = problem.model.parts[k].noise_parts()
    return own[j].unit if own else "mm"


def _notes(problem: Problem, sigmas: list[list[float]], origins: list[list[str]], fits: int, moved: float,
           settled: bool, trained: set[int]) -> list[str]:
    """The printout's lines on the estimate.

    Each thin component of a set that trains (the noise it got, and how to state it; a set
    of no training row, a test set, is weighted by nothing), and a variance-component
    estimation that did not settle.
    """
    labels = problem.model.labels
    notes = []
    for k, j in ((a, b) for a, by_part in enumerate(origins) for b, origin in enumerate(by_part)
                 if origin in ("pooled", "default") and a in trained):
        own = problem.model.parts[k].noise_parts()
        unit, per_si = (own[j].unit, own[j].per_si) if own else ("mm", 1e3)
        part = f" ({own[j].name})" if own else ""
        whose = f"the pooled noise of the other sets in {unit}" if origins[k][j] == "pooled" else "the default"
        key = f"noise_{unit}"
        notes.append(f"noise of set {labels[k]}{part}: its training values leave fewer than {MIN_DOF:g} degrees of "
                     "freedom beyond the unknowns they fit, too few to estimate it: "
                     f"{whose}, {sigmas[k][j] * per_si:.4g} {unit}, is used (state it: '# {key}: ...' in its file, "
                     f"or FILE:{key}=...)")
    if not settled:
        notes.append(f"the sets' noise did not settle in {fits} fits (the last moved a sigma by {moved:.0%}): each "
                     "set's is the geometric mean of the last fit's and its residual's, and the method was fitted "
                     "with those (state the noises, '# noise_mm: ...' in each file, to fix them)")
    return notes


def _residuals(training: Problem, x: np.ndarray) -> dict[int, list[np.ndarray]]:
    """Each set's unweighted training residual at x, per part of its rows, SI."""
    out = {}
    for part, k in zip(training.parts, training.sets, strict=True):
        xk = training.model.part_x(x, k)
        if part.model.noise_parts():
            out[k] = list(part.model.part_residuals(xk, part.q, part.readings, part.points))
        else:
            out[k] = [part.residual(xk)]
    return out


def _refuse_misfit(problem: Problem, sigmas: list[list[float]], unknown: list[tuple[int, int]], method: str,
                   source: str) -> None:
    """Refuse an estimated set noise above :data:`MAX_FILTER_NOISE_M`: a misfit, not a noise."""
    misfit = sorted({k for k, j in unknown if j == 0 and sigmas[k][0] > MAX_FILTER_NOISE_M},
                    key=lambda k: -sigmas[k][0])
    if not misfit:
        return
    labels = problem.model.labels
    k = misfit[0]
    if len(problem.model.parts) == 1:
        raise DataError(source or "the measurement set", f"a first LM fit leaves {sigmas[k][0]:.4g} m per value (the "
                        f"noise {method} would assume; at most {MAX_FILTER_NOISE_M:g} m): the readings do not "
                        "fit this robot and sensor set-up (a unit or frame mistake?)")
    others = [labels[j] for j in misfit[1:]]
    raise DataError(source or labels[k], f"the fit leaves {sigmas[k][0]:.4g} m per value (this set's estimated noise; "
                    f"at most {MAX_FILTER_NOISE_M:g} m" + (f"; also {', '.join(others)}" if others else "")
                    + "): its readings do not fit this robot and sensor set-up, or not the other sets' "
                    "(a unit or frame mistake?)")

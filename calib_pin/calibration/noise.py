"""The noise of each measurement set (and of each part of a row), stated or estimated from the data.

A set's noise sigma_k weighs its rows against the other sets' (w_k = sigma_0 / sigma_k),
and sigma_0 is the noise the Kalman filters assume (R = sigma_0^2). A part of a row with a
noise of its own (a 6-D pose's orientation beside its position,
:meth:`~calib_pin.sensors.base.MeasurementModel.noise_parts`) is a component too. Each
component's sigma is the caller's or its file's; the others are estimated where they
matter (several components, or a method that weighs rows by the noise) by
variance-component estimation on a pilot Levenberg-Marquardt fit of the training rows:
fit, then for each unknown component

    sigma_k^2 = r_k . r_k / (n_k - p_k),    p_k = rank * n_k / N,

(r_k: its unweighted training residual, n_k its values, N every component's, rank: the
identifiable directions of the training Jacobian at the fit, shared out by each
component's share of the values), refit with the new weights, until no sigma moves by more
than :data:`TOLERANCE` (at most :data:`MAX_FITS` fits). Of one component (one set, rows of
one part) this is sqrt(RSS / (m - r)) of one fit: a blind direction fits nothing, so it
takes no degree of freedom. Every method of a calibration is given the same noise.
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
        pilot: The last pilot fit's estimate (for a method that is the pilot, its estimate), or None.
    """

    sigmas: tuple[tuple[float, ...], ...]
    origins: tuple[tuple[str, ...], ...]
    fits: int = 0
    words: str = "stated"
    pilot: Any = None

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
    fits = 0
    while True:
        noise = Noise(tuple(map(tuple, now)), tuple(map(tuple, where)))
        training = apply(problem, noise).subset(train)
        estimate = run_method(pilot, training, x0, seed=seed, noise=noise.sigma, loss=loss, fixed=fixed,
                              history=history)
        fits += 1
        if len(flat) > 1 and fits >= MAX_FITS:  # the sigmas this fit was weighted by
            break
        rank = Subspace.of(training.jacobian(estimate.x), training.scale, estimate.x).rank
        residuals = _residuals(training, estimate.x)
        n_total = sum(r.size for by_part in residuals.values() for r in by_part)
        new = [list(s) for s in now]
        for k, j in unknown:
            if k not in residuals:
                continue
            r = residuals[k][j]
            dof = max(r.size - rank, 1) if len(flat) == 1 else r.size - rank * r.size / n_total
            if dof > 0 and r @ r > 0:
                new[k][j] = max(float(np.sqrt(r @ r / dof)), FLOOR_M)
        moved = max(abs(new[k][j] / now[k][j] - 1.0) for k, j in unknown)
        now = new
        _refuse_misfit(problem, now, unknown, method.name, source)
        if len(flat) == 1 or moved < TOLERANCE:
            break
    for k, j in unknown:
        where[k][j] = "estimate"
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
    return Noise(tuple(map(tuple, now)), tuple(map(tuple, where)), fits, words, estimate)


def _residuals(training: Problem, x: np.ndarray) -> dict[int, list[np.ndarray]]:
    """Each set's unweighted training residual at x, per part of its rows, SI."""
    out = {}
    for part, k in zip(training.parts, training.sets, strict=True):
        xk = training.model.part_x(x, k)
        if part.model.noise_parts():
            out[k] = list(part.model.part_residuals(xk, part.q, part.readings))
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

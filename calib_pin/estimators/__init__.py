"""Estimators by name: a registry of frozen method records that state what each can do.

Every estimator has one signature and one result type (see :mod:`.base`). The record
:class:`Method` tells callers what they would otherwise ask of the estimator's type:
whether it takes a robust loss (natively, or through the shared refit scheme of
:mod:`.robust`), whether it estimates kinematic parameters, and which data kinds it
takes. Estimator modules are imported when a method is first asked for.
"""

from __future__ import annotations

import dataclasses
import importlib
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..exceptions import ArgumentError, EstimatorError
from ..util.arguments import as_array, as_bool, as_float, as_instance, as_int
from ..util.progress import progress_bar
from .active_set import Fixed, estimate_nonnegative, expanded
from .base import EstimateResult, History
from .problem import LeastSquares

#: Robust losses (scipy.optimize.least_squares names); "linear" is plain least squares.
LOSSES = ("linear", "huber", "soft_l1", "cauchy")


@dataclass(frozen=True)
class Method:
    """One estimator of the registry and what it can do.

    Attributes:
        name: Name on the command line (``ekf-qibas``).
        label: The paper's label (``M9``).
        title: What it is, for people.
        target: ``module:Class`` of the estimator, imported on first use.
        robust: ``native`` (its own robust stage: set its ``loss``), ``refit`` (the
            shared refit scheme of :mod:`.robust`), or ``""`` (no robust loss).
        kinematic: Estimates kinematic parameters (False: learns a correction of the
            values, so there is no URDF to write).
        kinds: Data kinds it takes (empty: every kind).
        paper: One of the paper's nine methods (a default of ``compare`` and ``benchmark``).
        weighs_noise: Its estimate depends on the sensor noise it is given (R of the
            Kalman filters); a set that states none gets it estimated
            (:mod:`calib_pin.calibration.noise`).
    """

    name: str
    label: str
    title: str
    target: str
    robust: str = ""
    kinematic: bool = True
    kinds: tuple[str, ...] = ()
    paper: bool = True
    weighs_noise: bool = False

    def estimator(self, loss: str = "linear") -> Any:
        """The estimator with default settings and ``loss`` (one :meth:`check` accepts)."""
        module, _, cls = self.target.partition(":")
        estimator = getattr(importlib.import_module(f"{__name__}.{module}"), cls)()
        if loss == "linear":
            return estimator
        if self.robust == "native":
            return dataclasses.replace(estimator, loss=loss)
        from .robust import Robust

        return Robust(estimator, loss)

    def check(self, loss: str = "linear") -> None:
        """Refuse a loss this method does not take, in one line.

        Args:
            loss: ``linear``, or a robust loss (``huber``, ``soft_l1``, ``cauchy``).

        Raises:
            EstimatorError: unknown loss, or a loss it has no robust variant for.
        """
        if loss not in LOSSES:
            raise EstimatorError(f"unknown loss '{loss}' (valid: {', '.join(LOSSES)})")
        if loss != "linear" and not self.robust:
            robust = [m.name for m in METHODS.values() if m.robust]
            raise EstimatorError(f"method '{self.name}' has no robust loss; --loss {loss} works with: "
                                 f"{', '.join(robust)}")

    def takes(self, kind: str, unsupported: tuple[str, ...] = ()) -> str | None:
        """Why this method cannot fit data of ``kind``, or None.

        The sensor of ``kind`` names the methods it cannot serve in ``unsupported``; some
        methods cannot fit rows of several sizes.
        """
        if self.kinds and kind not in self.kinds:
            return f"method '{self.name}' takes {' or '.join(self.kinds)} data, not {kind} data; use a parameter method"
        if self.name in unsupported:
            usable = [m for m in METHODS if m not in unsupported]
            return f"method '{self.name}' needs rows of one size, and {kind} rows differ in size: use {', '.join(usable)}"
        return None


#: The registry: the paper's M1..M9 in its order, then combinations of them.
METHODS: dict[str, Method] = {m.name: m for m in (
    Method("ekf", "M1", "extended Kalman filter (filterpy)", "ekf:EKF", weighs_noise=True),
    Method("bas", "M2", "beetle antennae search", "bas:BAS", robust="refit"),
    Method("ukf", "M3", "unscented Kalman filter (filterpy)", "ukf:UKF", weighs_noise=True),
    Method("pso", "M4", "particle swarm", "pso:PSO", robust="refit"),
    Method("rbf", "M5", "RBF network on the values' error (scipy)", "rbf:RBF", kinematic=False),
    Method("lm", "M6", "Levenberg-Marquardt (scipy)", "lm:LevenbergMarquardt", robust="native"),
    Method("de", "M7", "differential evolution (scipy)", "de:DE", robust="refit"),
    Method("qibas", "M8", "quadratic interpolated BAS", "qibas:QIBAS", robust="refit"),
    Method("ekf-qibas", "M9", "EKF, then QIBAS (the paper's method)", "ekf_qibas:EKFQIBAS", robust="native",
           weighs_noise=True),
    Method("lm+rbf", "M6+M5", "LM, then an RBF network on what it leaves", "lm_rbf:LMRBF", kinematic=False,
           paper=False),
)}

#: Every method name: the paper's M1..M9 in its order, then the combinations.
ESTIMATORS = tuple(METHODS)

#: The paper's nine methods, in its order (the default of ``compare`` and ``benchmark``).
PAPER_METHODS = tuple(m.name for m in METHODS.values() if m.paper)

#: The paper's label of each method (Table I).
PAPER_LABELS = {m.name: m.label for m in METHODS.values()}

DEFAULT_METHOD = "ekf-qibas"


def unknown_method(name: str) -> str:
    """Why ``name`` is no method, in words: the names nearest it, then the valid ones."""
    import difflib

    near = difflib.get_close_matches(name.replace("_", "-").lower(), list(METHODS), n=1, cutoff=0.7)
    hint = f": did you mean {near[0]}?" if near else ""
    return f"unknown method '{name}'{hint} (valid: {', '.join(METHODS)})"


def get_method(name: str) -> Method:
    """The method record registered as ``name``.

    Args:
        name: A method's name (``lm``, ``ekf-qibas``, ...).

    Raises:
        EstimatorError: unknown name, with the list of valid ones.
    """
    try:
        return METHODS[name]
    except KeyError:
        raise EstimatorError(unknown_method(name)) from None


def get_estimator(name: str, loss: str = "linear") -> Any:
    """The estimator registered as ``name``, with ``loss`` (see :meth:`Method.estimator`)."""
    method = get_method(name)
    method.check(loss)
    return method.estimator(loss)


def run_estimator(
    name: str, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
    loss: str = "linear", history: bool = True, fixed: tuple[int, ...] = (),
) -> EstimateResult:
    """Run the estimator ``name`` (with ``loss``) on any least-squares problem.

    It records its convergence history (unless ``history`` is False) and its wall time
    ``time_s``.

    Args:
        name: A method of :data:`METHODS` (``lm``, ``ekf-qibas``, ...).
        problem: A :class:`~calib_pin.estimators.problem.LeastSquares` problem.
        x0: The start, shape (n_params,), SI units.
        seed: Seeds any randomness.
        noise: The measurement noise (1 sigma) [m] of the methods that weigh values by it.
        loss: ``linear`` or a robust loss the method takes.
        history: Record the training RMSE after every iteration.
        fixed: Unknowns (indices into x) held at their x0 value.

    Raises:
        CalibPinError: an unknown method or loss; an ArgumentError naming a bad argument
            (x0 not of shape (n_params,) or not finite, noise not > 0 [m], ...).
    """
    method = get_method(as_instance(name, "name", str, "a method name (calib_pin.ESTIMATORS)"))
    method.check(as_instance(loss, "loss", str, f"a loss name ({', '.join(LOSSES)})"))
    for attribute in ("n_params", "residual"):
        if not hasattr(problem, attribute):
            raise ArgumentError("problem", f"expected a least-squares problem (calib_pin.Problem), got "
                                f"{type(problem).__name__}")
    x0 = as_array(x0, "x0", (problem.n_params,))
    held = tuple(sorted({as_int(i, "fixed", 0, problem.n_params - 1) for i in fixed}))
    return run_method(method, problem, x0, seed=as_int(seed, "seed", 0),
                      noise=as_float(noise, "noise", 0.0, 1.0, low_open=True, unit="m"), loss=loss,
                      history=as_bool(history, "history"), fixed=held)


def run_method(method: Method, problem: LeastSquares, x0: np.ndarray, *, seed: int, noise: float, loss: str,
               history: bool = True, fixed: tuple[int, ...] = ()) -> EstimateResult:
    """:func:`run_estimator` of a method record and arguments already checked.

    The calibration's own path, which checks each once where it enters.

    Unknowns the problem names in ``nonnegative`` (the joint compliances) come out >= 0
    for every method: one fitted negative is fixed at zero and the method runs again
    without it (:mod:`.active_set`; ``result.bounded`` lists them, ``time_s`` covers
    every run, ``history`` is the last run's). Unknowns ``fixed`` are held at their x0
    value: the estimator sees the others only (the active set's :class:`~.active_set.Fixed`
    problem); ``result.extras["fixed"]`` lists them and the covariance has zero rows and
    columns for them. PSO and DE show a bar over their generations on a terminal.
    """
    estimator = method.estimator(loss)
    name = method.name
    recorders: list[History] = []
    generations = getattr(estimator, "max_iter", 0) if getattr(estimator, "reports_generations", False) else 0

    def once(part: LeastSquares, start: np.ndarray) -> EstimateResult:
        recorder = History() if history else None
        recorders[:] = [recorder] if recorder is not None else []
        with progress_bar(generations + 1, f"{name} generations", quiet=not generations) as bar:
            def callback(rmse_m: float, evaluations: float) -> None:
                bar.update()  # type: ignore[union-attr]
                if recorder is not None:
                    recorder(rmse_m, evaluations)

            return estimator(part, start, seed=seed, noise=noise, callback=recorder if bar is None else callback)

    nonnegative = tuple(getattr(problem, "nonnegative", ()))
    held = list(fixed)
    start = time.perf_counter()
    if held:
        reduced = Fixed(problem, np.setdiff1d(np.arange(problem.n_params), held), x0)
        inner = tuple(int(np.searchsorted(reduced.free, i)) for i in nonnegative if i not in held)
        part = estimate_nonnegative(once, reduced, x0[reduced.free], inner) if inner else once(reduced, x0[reduced.free])
        bounded = tuple(int(reduced.free[i]) for i in part.bounded)
        result = expanded(part, reduced, bounded, part.nfev, 1)
        result = dataclasses.replace(result, extras={**result.extras, "fixed": tuple(held)})
    else:
        result = estimate_nonnegative(once, problem, x0, nonnegative) if nonnegative else once(problem, x0)
    elapsed = time.perf_counter() - start
    if not recorders:
        return dataclasses.replace(result, time_s=elapsed)
    return dataclasses.replace(result, time_s=elapsed, history=tuple(recorders[0].history),
                               evaluations=tuple(recorders[0].evaluations))


__all__ = ["DEFAULT_METHOD", "ESTIMATORS", "LOSSES", "METHODS", "PAPER_LABELS", "PAPER_METHODS", "EstimateResult",
           "Method", "get_estimator", "get_method", "run_estimator", "run_method"]

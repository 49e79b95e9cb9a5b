"""Estimators by name, all with one signature and one result type (see :mod:`.base`)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from ..errors import CalibrationProblem
from ..exceptions import EstimatorError
from .bas import BAS
from .base import EstimateResult, Tracker
from .de import DE
from .ekf import EKF
from .ekf_qibas import EKFQIBAS
from .lm import LevenbergMarquardt
from .robust import LOSSES, Robust
from .pso import PSO
from .qibas import QIBAS
from .rbf import RBF
from .search_space import SearchSpace
from .ukf import UKF

#: Registry: method name (as on the command line) to estimator with default settings,
#: in the paper's order M1..M9.
ESTIMATORS = {
    "ekf": EKF(),
    "bas": BAS(),
    "ukf": UKF(),
    "pso": PSO(),
    "rbf": RBF(),
    "lm": LevenbergMarquardt(),
    "de": DE(),
    "qibas": QIBAS(),
    "ekf-qibas": EKFQIBAS(),
}

#: The paper's label of each method (Table I).
PAPER_LABELS = {name: f"M{i}" for i, name in enumerate(ESTIMATORS, start=1)}

DEFAULT_METHOD = "ekf-qibas"


def get_estimator(name: str):
    """The estimator registered as ``name``.

    Raises:
        EstimatorError: unknown name, with the list of valid ones.
    """
    try:
        return ESTIMATORS[name]
    except KeyError:
        raise EstimatorError(
            f"unknown method '{name}' (valid: {', '.join(ESTIMATORS)})"
        ) from None


def get_robust(name: str, loss: str):
    """The estimator ``name`` with a robust ``loss`` (see :mod:`.robust`).

    Raises:
        EstimatorError: unknown name or loss, or a method that has no robust variant.
    """
    estimator = get_estimator(name)
    if loss not in LOSSES:
        raise EstimatorError(f"unknown loss '{loss}' (valid: {', '.join(LOSSES)})")
    if loss == "linear":
        return estimator
    if hasattr(estimator, "loss"):  # its own robust stage: LM (scipy's losses), EKF-QIBAS
        return dataclasses.replace(estimator, loss=loss)
    if getattr(estimator, "minimises_cost", False):  # searches: one shared refit scheme
        return Robust(estimator, loss)
    robust = [n for n, e in ESTIMATORS.items() if hasattr(e, "loss") or getattr(e, "minimises_cost", False)]
    raise EstimatorError(f"method '{name}' has no robust loss; --loss {loss} works with: {', '.join(robust)}")


def run_estimator(
    name: str, problem: CalibrationProblem, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
    loss: str = "linear",
) -> EstimateResult:
    """Run the estimator ``name`` (with ``loss``, see :func:`get_robust`) and record its
    wall time in ``time_s``."""
    estimator = get_robust(name, loss)
    start = time.perf_counter()
    result = estimator(problem, x0, seed=seed, noise=noise)
    result.time_s = time.perf_counter() - start
    return result


__all__ = [
    "BAS",
    "DE",
    "DEFAULT_METHOD",
    "EKF",
    "EKFQIBAS",
    "ESTIMATORS",
    "EstimateResult",
    "LOSSES",
    "LevenbergMarquardt",
    "PAPER_LABELS",
    "PSO",
    "QIBAS",
    "RBF",
    "Robust",
    "SearchSpace",
    "Tracker",
    "UKF",
    "get_estimator",
    "get_robust",
    "run_estimator",
]

"""Estimators by name, all with one signature and one result type (see :mod:`.base`)."""

from __future__ import annotations

import time

import numpy as np

from ..errors import CalibrationProblem
from ..exceptions import EstimatorError
from .base import EstimateResult
from .ekf import EKF
from .ekf_qibas import EKFQIBAS
from .lm import LevenbergMarquardt
from .qibas import QIBAS
from .search_space import SearchSpace

#: Registry: method name (as on the command line) to estimator with default settings.
ESTIMATORS = {
    "ekf": EKF(),
    "qibas": QIBAS(),
    "ekf-qibas": EKFQIBAS(),
    "lm": LevenbergMarquardt(),
}

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


def run_estimator(
    name: str, problem: CalibrationProblem, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5
) -> EstimateResult:
    """Run the estimator ``name`` and record its wall time in ``time_s``."""
    estimator = get_estimator(name)
    start = time.perf_counter()
    result = estimator(problem, x0, seed=seed, noise=noise)
    result.time_s = time.perf_counter() - start
    return result


__all__ = [
    "DEFAULT_METHOD",
    "EKF",
    "EKFQIBAS",
    "ESTIMATORS",
    "EstimateResult",
    "LevenbergMarquardt",
    "QIBAS",
    "SearchSpace",
    "get_estimator",
    "run_estimator",
]

"""K-fold cross-validation of a calibration's model on its own training poses.

:func:`cross_validate` splits the training rows by pose into K seeded folds; each fold is
held out once while the same method fits the model (geometry, compliance, sensor
geometry fitted on the other folds' rows only; the calibration's start and held unknowns,
``--nominal`` and ``--fix``/``--free``) on the rest, and the held-out rows are
scored. The figure is the held-out error of *this model on this data*, before a user
trusts it (``calibrate --cv K``); the calibration's own test split is not touched.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..analysis.metrics import Metrics
from ..estimators import run_estimator
from ..estimators.problem import data_row_errors
from ..exceptions import CalibPinError


@dataclass(frozen=True)
class CrossValidation:
    """Held-out metrics of each fold, [mm].

    Attributes:
        folds: K.
        seed: Seed of the folds.
        test: Per fold, the held-out rows' metrics [mm].
    """

    folds: int
    seed: int
    test: tuple[Metrics, ...]

    def stat(self, key: str) -> tuple[float, float]:
        """(mean, sd) over the folds of ``rmse_mm``, ``mean_mm`` or ``max_mm``."""
        values = np.array([getattr(m, key) for m in self.test])
        return float(np.mean(values)), float(np.std(values))

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: K, seed, and per metric mean, sd and each fold's value [mm]."""
        return {"folds": self.folds, "seed": self.seed, "split": "by pose, within the training rows",
                **{key: {"mean": self.stat(key)[0], "sd": self.stat(key)[1],
                         "per_fold": [getattr(m, key) for m in self.test]}
                   for key in ("rmse_mm", "mean_mm", "max_mm")}}


def cross_validate(setup: Any, method: str, rows: np.ndarray, folds: int, *, seed: int = 0,
                   loss: str = "linear") -> CrossValidation:
    """K-fold cross-validation by pose of ``setup``'s model on ``rows``.

    Args:
        setup: A :class:`~calib_pin.calibration.pipeline.CalibrationSetup`.
        method, loss: The estimator and loss of the calibration.
        rows: The data rows to cross-validate on (the calibration's training rows).
        folds: K, at least 2 and at most the number of poses in ``rows``.
        seed: Seed of the fold assignment.

    Raises:
        CalibPinError: K out of range for the poses.
    """
    rows = np.asarray(rows, dtype=int)
    groups = np.asarray(setup.data.groups)[rows]
    poses = np.unique(groups)
    if not 2 <= folds <= len(poses):
        raise CalibPinError(f"--cv {folds}: needs 2 to {len(poses)} folds (the training poses)")
    order = np.random.default_rng(seed).permutation(len(poses))
    fold_of_pose = np.empty(len(poses), dtype=int)
    fold_of_pose[order] = np.arange(len(poses)) % folds
    fold = fold_of_pose[np.searchsorted(poses, groups)]
    out = []
    for k in range(folds):
        train, test = rows[fold != k], rows[fold == k]
        problem = setup.problem_on(train)  # the sensor's start fitted on this fold's training rows only
        training, held_out = problem.subset(train), problem.subset(test)
        x0, held = setup.start_on(problem, training)  # --nominal's start, --fix/--free's held unknowns
        noise = setup.noise_for(method, training)[0]
        est = run_estimator(method, training, x0, seed=seed, noise=noise, loss=loss, fixed=held)
        out.append(Metrics.of(data_row_errors(held_out, est.residual(held_out))))
    return CrossValidation(folds, seed, tuple(out))

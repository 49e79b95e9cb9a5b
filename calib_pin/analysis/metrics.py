"""Accuracy metrics of the paper (eq. 22) and the seeded train/test split."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..util.arguments import as_float


@dataclass(frozen=True)
class Metrics:
    """Residual statistics in [mm].

    Attributes:
        rmse_mm: Root mean square residual.
        mean_mm: Mean absolute residual (the paper's "Std", eq. 22).
        max_mm: Largest absolute residual.
    """

    rmse_mm: float
    mean_mm: float
    max_mm: float

    @classmethod
    def of(cls, residual: np.ndarray) -> Metrics:
        """Metrics of residuals given in [m], shape (n,)."""
        r = np.abs(np.asarray(residual, dtype=float)) * 1e3
        return cls(float(np.sqrt(np.mean(r**2))), float(np.mean(r)), float(np.max(r)))

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def split_rows(n: int, test_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Seeded random split of rows 0..n-1 into sorted train and test indices.

    Args:
        n: Number of rows.
        test_fraction: Share of rows held out, in [0, 1); the paper uses 0.2.
        seed: Seed of the permutation.
    """
    if not 0.0 <= test_fraction < 1.0:
        raise ValueError(f"test fraction must be in [0, 1), got {test_fraction}")
    order = np.random.default_rng(seed).permutation(n)
    n_test = int(round(test_fraction * n))
    return np.sort(order[n_test:]), np.sort(order[:n_test])


def check_fraction(test_fraction: float) -> float:
    """The share of rows held out, in [0, 1).

    Args:
        test_fraction: The share to check.

    Raises:
        ArgumentError: not a number in [0, 1).
    """
    return as_float(test_fraction, "test_fraction", 0.0, 1.0, high_open=True)


def pooled_unit(sets: Sequence[Any]) -> str | None:
    """The one unit of every set's row errors (each set's ``unit``), or None when they differ (no pool)."""
    units = {s.unit for s in sets}
    return units.pop() if len(units) == 1 else None


def units_words(sets: Sequence[Any]) -> str:
    """What the all-sets metrics pool, for people and report.json, or why there are none.

    For example ``every set's row errors together, in mm``, or ``the sets' row errors are
    in different units (a, b: mm; c: deg)``.
    """
    unit = pooled_unit(sets)
    if unit is not None:
        return f"every set's row errors together, in {unit}"
    by: dict[str, list[str]] = {}
    for s in sets:
        by.setdefault(s.unit, []).append(s.label)
    return "the sets' row errors are in different units (" + "; ".join(
        f"{', '.join(labels)}: {unit}" for unit, labels in by.items()) + ")"

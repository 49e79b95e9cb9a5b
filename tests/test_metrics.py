"""Metrics of eq. 22 and the seeded split."""

import numpy as np
import pytest

from calib_pin.analysis.metrics import Metrics, split_rows


def test_metrics_of_known_residuals():
    """RMSE, mean absolute (the paper's Std) and max, in mm from residuals in m."""
    m = Metrics.of(np.array([3e-3, -4e-3]))
    assert m.rmse_mm == pytest.approx(np.sqrt(12.5))
    assert m.mean_mm == pytest.approx(3.5)
    assert m.max_mm == pytest.approx(4.0)


def test_split_is_seeded_disjoint_and_80_20():
    """120 rows split 96/24, same seed same split, other seed other split."""
    train, test = split_rows(120, 0.2, seed=3)
    assert len(train) == 96 and len(test) == 24
    assert set(train).isdisjoint(test) and set(train) | set(test) == set(range(120))
    again = split_rows(120, 0.2, seed=3)
    assert np.array_equal(again[1], test)
    assert not np.array_equal(split_rows(120, 0.2, seed=4)[1], test)


def test_split_rejects_bad_fraction():
    with pytest.raises(ValueError):
        split_rows(10, 1.0, 0)

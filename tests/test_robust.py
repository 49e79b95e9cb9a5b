"""Robust losses: the noise a robust fit's covariance is taken at."""

from __future__ import annotations

import numpy as np
import pytest

from calib_pin.estimators.robust import robust_noise


@pytest.mark.parametrize("loss", ["huber", "soft_l1", "cauchy"])
def test_a_robust_fits_noise_is_sigma_on_gaussian_residuals(loss):
    """On Gaussian residuals the sandwich noise is about sigma (the loss's efficiency: within 5 to 30 %)."""
    r = np.random.default_rng(0).normal(size=20_000) * 0.1
    assert 0.1 <= robust_noise(r, loss) < 0.13
    assert robust_noise(r, "linear") == pytest.approx(0.1, rel=0.02)


def test_heavy_tails_raise_a_robust_fits_noise_less_than_their_rms():
    """5 % of the residuals 20 sigma off: Huber's covariance noise grows above sigma, far below the RMS that a
    least-squares fit would see, and above the Gaussian core's (the reported intervals widen)."""
    rng = np.random.default_rng(1)
    r = rng.normal(size=20_000) * 0.1
    r[:1000] += rng.choice([-2.0, 2.0], size=1000)
    huber = robust_noise(r, "huber")
    assert 0.105 < huber < 0.2 < robust_noise(r, "linear")

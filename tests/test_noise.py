"""The sensor noise from the data: sigma^2 = RSS / (m - r) of a first LM fit, r counted on
the identifiable subspace, given to the Kalman filters when a set states no noise."""

from __future__ import annotations

import dataclasses
import re

import numpy as np

import calib_pin as cp
from calib_pin import prepare
from calib_pin.parameters import parameter_model
from calib_pin.robot import load_chain
from calib_pin.simulation import simulate


def _set(noise_mm: float, poses: int = 150, seed: int = 4):
    chain = load_chain("irb120")
    data, _ = simulate(chain, parameter_model(chain), poses, seed, noise_mm=noise_mm)
    return data


def test_estimate_recovers_the_simulated_noise():
    """Simulated at 0.3 mm (a real cable set's size) the estimate is within 15 %; the
    degrees of freedom are counted on the identifiable subspace (r < unknowns)."""
    result = cp.solve(prepare("irb120", _set(0.3)), "ekf", holdout=0)
    assert abs(result.noise * 1e3 - 0.3) < 0.045
    rank = int(re.search(r"r = (\d+) identifiable", result.noise_from).group(1))
    assert rank < result.problem.n_params and f"m = {len(result.data)} values" in result.noise_from


def test_kalman_filter_gets_the_estimate_only_when_no_noise_is_stated():
    """No noise stated: the EKF is given the estimate (result.noise_from says so); a stated
    noise (the caller's, or the file's) is used as given; LM ignores the noise."""
    data = _set(0.3)
    assert data.noise is None
    estimated = cp.solve(prepare("irb120", data), "ekf", seed=0)
    assert estimated.noise_from.startswith("estimated") and abs(estimated.noise * 1e3 - 0.3) < 0.045
    stated = cp.solve(prepare("irb120", dataclasses.replace(data, noise=0.3e-3)), "ekf", seed=0)
    assert stated.noise_from == "stated" and stated.noise == 0.3e-3
    told = cp.solve(prepare("irb120", data, noise_mm=0.05), "ekf", seed=0)
    assert told.noise == 0.05e-3 and not np.allclose(told.x, estimated.x)
    lm = cp.solve(prepare("irb120", data), "lm", seed=0)
    assert lm.noise_from == "default"

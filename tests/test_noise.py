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


def _sessions(n_poses, kinds=("cable", "cable"), seed=7):
    """Sessions of one true robot stating no noise."""
    chain = load_chain("irb120")
    sets, _ = cp.simulate_sessions(chain, parameter_model(chain), list(n_poses), seed=seed, kinds=list(kinds))
    return [dataclasses.replace(s, noise=None, notes={k: v for k, v in s.notes.items() if k != "noise_deg"})
            for s in sets]


def test_a_set_too_small_to_estimate_its_noise_takes_the_pooled_one():
    """A one-row set beside a good one: its value leaves no degree of freedom beyond what
    the fit takes from it, so its noise is not estimated (it was driven towards zero and its
    weight swamped the rest): it takes the good set's, pooled, and a warning says so; the
    good set fits as it does alone."""
    sets = _sessions([60, 1])
    result = cp.calibrate("irb120", sets, method="lm")
    alone = cp.calibrate("irb120", sets[0], method="lm")
    good, thin = result.sets
    assert (good.sigma_origin, thin.sigma_origin) == ("estimate", "pooled") and thin.sigma == good.sigma
    assert any(w.startswith(f"noise of set {thin.label}: its training values leave fewer than 2 degrees of freedom")
               and "the pooled noise of the other sets in mm" in w for w in result.warnings)
    assert good.metrics["test"]["after"].rmse_mm < 1.05 * alone.metrics["test"]["after"].rmse_mm


def test_a_thin_6d_set_does_not_swamp_a_cable_set():
    """Two 6-D poses (12 values for the 12 unknowns of their device frame and body) beside
    a cable session: their noise went to 0 mm, the fit followed them alone (the cable set's
    error stayed the nominal robot's, 'identifiable: 12 of 36'); now both parts take a
    pooled or default noise and the cable set is calibrated."""
    sets = _sessions([60, 2], kinds=("cable", "pose"))
    result = cp.calibrate("irb120", sets, method="ekf-qibas")
    cable, pose = result.sets
    assert [pose.sigma_origin] == ["pooled"] and pose.sigma > 0.02e-3
    assert cable.metrics["train"]["after"].rmse_mm < 0.1 < cable.metrics["train"]["before"].rmse_mm


def test_variance_components_that_do_not_settle_say_so_and_refit(monkeypatch):
    """Stopped before they settle (here after 2 fits), the sigmas are not the last fit's
    weights: each is the geometric mean of those and its residual's, the method is fitted
    with them (no pilot reused), and one warning says so."""
    from calib_pin.calibration import noise as noise_module

    monkeypatch.setattr(noise_module, "MAX_FITS", 2)
    sets = _sessions([60, 40], seed=9)
    sets[1] = dataclasses.replace(sets[1], values=sets[1].values + np.random.default_rng(1).normal(0, 0.5e-3, len(sets[1])))
    calibration = prepare("irb120", sets)
    train = calibration.split(0.2, 0)[0]
    method = cp.estimators.get_method("lm")
    problem = calibration.problem_on(train)
    found = noise_module.estimate_noise(problem, train, [None, None], ["estimate", "estimate"], method,
                                        np.zeros(problem.n_params), seed=0, loss="linear", fixed=(), default=5e-5)
    assert found.fits == 2 and found.pilot is None
    assert any(n.startswith("the sets' noise did not settle in 2 fits") for n in found.notes)
    result = cp.solve(calibration, "lm")
    assert any("did not settle in 2 fits" in w for w in result.warnings)


def test_a_test_set_gets_no_thin_set_note(chain, params):
    """A set of role test trains nothing: its noise weighs no row, and no note names it."""
    sets, _ = cp.simulate_sessions(chain, params, (40, 20), 5, kinds=("cable", "cable"))
    result = cp.calibrate("irb120", [cp.FitSet(sets[0], label="a"), cp.FitSet(sets[1], label="b", role="test")],
                          method="lm")
    assert not [w for w in result.warnings if "noise of set b" in w]

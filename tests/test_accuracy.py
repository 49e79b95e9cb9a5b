"""The predicted accuracy at named points, against the simulator's truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.robot.kinematics import Kinematics
from calib_pin.robot.poses import random_poses

ROBOTS = Path(__file__).resolve().parents[1] / "robots"


def _true_rms_mm(calibration, x, truth_x, point, q):
    n = len(calibration.params.names)
    kin = Kinematics(calibration.chain)
    kin.set_perturbation(calibration.params.delta_matrices(x[:n]))
    est = kin.points(q, np.asarray(point))[0]
    kin.set_perturbation(calibration.params.delta_matrices(truth_x[:n]))
    true = kin.points(q, np.asarray(point))[0]
    return float(np.sqrt(np.mean(np.sum((est - true) ** 2, axis=1)))) * 1e3


def test_the_prediction_matches_the_true_error_at_three_points(chain, params):
    """A cable hooked 50 mm out, truths drawn from the prior (eight seeds): at the hook
    (determined), the flange origin and a 150 mm tool (not determined: mostly the prior), the
    predicted RMS error is within a factor 1.5 of the true one at 500 fresh poses (RMS over the
    seeds: one truth is one draw of what the prior bounds)."""
    q = random_poses(chain, 500, np.random.default_rng(9))
    seeds = 8
    predicted, true = np.zeros((seeds, 3)), np.zeros((seeds, 3))
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        truth_x = rng.normal(size=len(params.names)) * cp.Prior().sigma(params.units, params.scale)
        data, _ = cp.simulate(chain, params, 120, seed=seed, _true_x=truth_x)
        calibration = cp.prepare("irb120", data, tcp_mm=[(0, 0, 50), (0, 0, 0), (0, 0, 150)])
        result = cp.solve(calibration, "lm", seed=0)
        hook, origin, tool = result.accuracy.points
        assert hook.determined and not origin.determined and not tool.determined
        for k, p in enumerate((hook, origin, tool)):
            predicted[seed, k] = p.rms * 1e3
            true[seed, k] = _true_rms_mm(calibration, result.x, truth_x, p.point, q)
            assert p.rms**2 == pytest.approx(p.noise**2 + p.model**2 + p.blind**2, rel=1e-6)
    ratio = np.sqrt(np.mean(predicted**2, axis=0) / np.mean(true**2, axis=0))
    assert np.all((1 / 1.5 < ratio) & (ratio < 1.5)), ratio


def test_the_default_points_and_the_repeatability_of_markers():
    """The real tracker set: the three markers and the end frame's origin are named; the
    tracker's repeatability is read from the markers' distances, the residual above it is
    unexplained and said so."""
    result = cp.calibrate("irb120", str(ROBOTS / "irb120_wu2015.csv"), method="lm")
    accuracy = result.accuracy
    assert [p.name for p in accuracy.points] == ["marker 1", "marker 2", "marker 3", "tool0 origin"]
    (unexplained,) = accuracy.sets
    assert unexplained.repeatability.from_data and 0.05e-3 < unexplained.repeatability.sigma < 0.1e-3
    assert unexplained.model > 0.1e-3 and unexplained.far_above
    assert any("repeatability" in w for w in accuracy.warnings())


def test_a_set_that_only_tests_still_has_its_accuracy(tmp_path, chain, params):
    """A set of role test (no training row) beside a training set: the accuracy is computed,
    its repeatability from its own rows."""
    sets, _ = cp.simulate_sessions(chain, params, (40, 20), 5, kinds=("cable", "cable"))
    result = cp.calibrate("irb120", [cp.FitSet(sets[0]), cp.FitSet(sets[1], role="test")], method="lm")
    assert result.accuracy is not None and len(result.accuracy.sets) == 2

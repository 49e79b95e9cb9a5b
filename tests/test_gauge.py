"""The gauge: what the data does not determine stays at the robot's start, whatever the method."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.calibration.gauge import resolve_gauge
from calib_pin.robot.kinematics import Kinematics
from calib_pin.robot.poses import random_poses

ROBOTS = Path(__file__).resolve().parents[1] / "robots"


@pytest.fixture(scope="module")
def ur5_cable():
    """A simulated UR5 drawstring session (placement model, 80 poses, 0.05 mm)."""
    chain = cp.load_chain("ur5")
    params = cp.parameter_model(chain)
    data, truth = cp.simulate(chain, params, 80, seed=2)
    return cp.prepare("ur5", data), truth


def _tool(calibration, x, q, point=(0.0, 0.0, 0.15)):
    kin = Kinematics(calibration.chain)
    kin.set_perturbation(calibration.params.delta_matrices(x[: len(calibration.params.names)]))
    return kin.points(q, np.asarray(point))[0]


def test_every_method_gives_the_same_robot_within_the_noise(ur5_cable):
    """LM, EKF-QIBAS and DE on one split: along what the data does not determine the robot is
    exactly at its start, and at a 150 mm tool they agree within the predicted noise there
    (without the gauge a turn about the anchor, or a direction seen less than the noise,
    put 0.1 to 0.7 mm between them)."""
    calibration, _ = ur5_cable
    q = random_poses(calibration.chain, 200, np.random.default_rng(1))
    results = {m: cp.solve(calibration, m, seed=0) for m in ("lm", "ekf-qibas", "de")}
    lm = results["lm"]
    noise = dict(zip([p.name for p in lm.accuracy.points], lm.accuracy.points, strict=True))
    for method, r in results.items():
        split = r.determined
        off = split.vt[split.rank:] @ ((r.x[split.robot] - r.x0[split.robot]) / split.sigma)
        assert np.abs(off).max() < 1e-6, method
        gap = np.sqrt(np.mean(np.sum((_tool(calibration, r.x, q) - _tool(calibration, lm.x, q)) ** 2, axis=1)))
        assert gap < 2 * max(p.noise for p in noise.values()), (method, gap)
        assert abs(r.estimate.extras["gauge"].chi2_change) <= 1.0 + 1e-9


def test_the_fit_is_unchanged_by_the_gauge(ur5_cable):
    """The gauge moves only what the data does not see: the training residual changes by less
    than one noise variance, the held-out error by less than 1 %."""
    calibration, _ = ur5_cable
    result = cp.solve(calibration, "lm", seed=0)
    gauge = result.estimate.extras["gauge"]
    assert gauge.undetermined > 0 and gauge.robot_moved > 0
    assert abs(gauge.chi2_change) < 1.0


def test_the_anchor_takes_what_the_robot_does_not_explain():
    """Anchor estimated: d_1 with anchor_z (and theta_1 with the anchor turned about z) are
    one freedom; the robot stays at its nominal d_1 and theta_1, the anchor moves."""
    result = cp.calibrate("irb120", str(ROBOTS / "irb120_default.csv"), method="lm",
                          setup=cp.CableSetup(estimate=("anchor",)))
    names = result.problem.model.names
    for name in ("d_1", "theta_1"):
        assert abs(result.x[names.index(name)]) < 1e-9, name
    assert result.uncertainty.status[names.index("d_1")] == "not determined"


def test_the_truth_moved_to_the_gauge_is_what_the_fit_recovers(ur5_cable):
    """The truth moved the same way: the estimate matches it along what the data determines
    (in noise standard deviations, about 1) and both equal the start elsewhere."""
    calibration, truth = ur5_cable
    result = cp.solve(calibration, "lm", seed=0)
    training = result.problem.subset(result.train)
    true_x = np.zeros(result.problem.n_params)
    true_x[: len(truth.x)] = truth.x
    free = np.arange(result.problem.n_params)
    moved, _ = resolve_gauge(training, true_x, result.x0, free, cp.Prior(), result.noise)
    split = result.determined
    d = (result.x[split.robot] - moved[split.robot]) / split.sigma
    z = split.vt[: split.rank] @ d * split.singular_values[: split.rank] / split.noise
    assert np.sqrt(np.mean(z**2)) < 2.0

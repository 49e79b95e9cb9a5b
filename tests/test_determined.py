"""What the data determines, checked on the cost itself: along what it calls not determined
the training residual's sum of squares curves by less than one noise variance over a whole
prior standard deviation, and along what it calls determined by more; for every sensor kind
and a mix."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.analysis.determined import determined
from calib_pin.estimators.active_set import Fixed

ROBOTS = Path(__file__).resolve().parents[1] / "robots"


def _chi2_along(problem, x, split, row, noise):
    """How much the training residual's sum of squares curves along ``split.vt[row]``: half
    the second difference of it over moves of one prior standard deviation each way (the
    sensor refitted), in noise variances. The data determines the direction better than the
    prior when that is above 1."""
    return (_moved(problem, x, split, row, noise, 1.0) + _moved(problem, x, split, row, noise, -1.0)) / 2


def _moved(problem, x, split, row, noise, side):
    """The sum of squares after a move of ``side`` prior standard deviations along the row,
    minus before, in noise variances."""
    r0 = problem.residual(x)
    moved = np.array(x, dtype=float)
    moved[split.robot] += side * split.sigma * split.vt[row]
    sensor = np.arange(problem.model.sensor_start, problem.n_params)
    if len(sensor):  # the sensor's best fit with the robot held: scipy's least squares
        from scipy.optimize import least_squares

        part = Fixed(problem, sensor, moved)
        moved = part.expand(least_squares(part.residual, moved[sensor], jac=part.jacobian, method="lm",
                                          x_scale=part.scale).x)
    r1 = problem.residual(moved)
    return (r1 @ r1 - r0 @ r0) / noise**2


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    """A drawstring session and a tracker session of one simulated IRB120 (files)."""
    chain = cp.load_chain("irb120")
    sets, _ = cp.simulate_sessions(chain, cp.parameter_model(chain), (60, 30), 4, kinds=("cable", "position"))
    folder = tmp_path_factory.mktemp("mixed")
    paths = []
    for k, s in enumerate(sets):
        paths.append(folder / f"m_{k + 1}.csv")
        cp.write_measurements(paths[-1], s)
    return [str(p) for p in paths]


@pytest.mark.parametrize("data", ["irb120_default.csv", "irb120_wu2015.csv", "irb120_pose_example.csv",
                                  "irb120_contact_example.csv", "mixed"])
def test_the_cost_agrees_with_what_is_called_determined(data, mixed):
    files = mixed if data == "mixed" else str(ROBOTS / data)
    result = cp.calibrate("irb120", files, method="lm")
    problem = result.problem.subset(result.train)
    split = result.determined
    assert 0 < split.rank < len(split.robot)
    for row in range(split.rank, len(split.robot)):  # not determined: under one noise variance
        assert _chi2_along(problem, result.x, split, row, split.noise) < 1.0, row
    weakest = split.rank - 1  # the least determined of the determined: more than the noise
    assert _chi2_along(problem, result.x, split, weakest, split.noise) > 1.0


def test_a_blind_parameter_and_a_combination_are_found():
    """theta_6 (the hook on the joint-6 axis) is not determined and d_2 - d_3 (parallel joints)
    only as a combination: in prior units, the first a direction of its own, the second the
    sum determined."""
    calibration = cp.prepare("irb120", str(ROBOTS / "irb120_default.csv"))
    problem = calibration.problem
    x = np.zeros(problem.n_params)
    split = determined(problem, x, np.arange(problem.n_params), cp.Prior(), 0.05e-3)
    names = [problem.model.names[i] for i in split.robot]
    share = dict(zip(names, split.blind_share(), strict=True))
    assert share["theta_6"] > 0.99 and share["a_1"] < 0.01
    assert abs(share["d_2"] - 0.5) < 0.01 and abs(share["d_3"] - 0.5) < 0.01


def test_a_tighter_prior_leaves_more_to_the_prior():
    """What counts as determined is the data against the prior: with a prior ten times
    tighter, fewer directions beat it."""
    calibration = cp.prepare("irb120", str(ROBOTS / "irb120_default.csv"))
    problem = calibration.problem
    x, free = np.zeros(problem.n_params), np.arange(problem.n_params)
    wide = determined(problem, x, free, cp.Prior(1.0, 0.1), 0.05e-3)
    tight = determined(problem, x, free, cp.Prior(0.01, 0.001), 0.05e-3)
    assert tight.rank < wide.rank

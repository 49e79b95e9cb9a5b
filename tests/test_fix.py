"""Unknowns held at their nominal value (calibrate --fix / --free,
calib_pin.calibration.held): the held ones stay exactly at the start, the others are
estimated against the simulator's truth, --analyze leaves them out, bad names refused."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.analysis.identifiability import analyze
from calib_pin.cli import command
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import CableModel

ROOT = Path(__file__).resolve().parents[1]
WU = str(ROOT / "robots" / "irb120_wu2015.csv")


def _fresh_rmse_mm(result, chain, params, truth) -> float:
    q = random_poses(chain, 300, np.random.default_rng(5))
    true = CableModel(chain, params, truth.sensor).predict(truth.x, q)
    return float(np.sqrt(np.mean((result.predict(q) - true) ** 2)) * 1e3)


def test_fixing_theta_1_on_the_wu_set_changes_nothing_the_device_frame_cannot_absorb():
    """Issue 25: on the real Wu set the device frame absorbs joint 1's zero: fixing
    theta_1 leaves the held-out error unchanged within 0.001 mm; theta_1 is reported fixed.
    Free, the data does not determine it either: the robot stays at nominal there and the
    device frame takes the turn (calibration/gauge.py)."""
    free = cp.calibrate("irb120", WU, method="lm")
    fixed = cp.calibrate("irb120", WU, method="lm", fix="theta_1")
    i = fixed.problem.model.names.index("theta_1")
    assert fixed.x[i] == 0.0 and abs(free.x[i]) < 1e-6
    assert free.uncertainty.status[i] == "not determined" and fixed.uncertainty.status[i] == "held"
    assert fixed.fixed == ("theta_1",) and free.fixed == ()
    for stat in ("rmse_mm", "mean_mm", "max_mm"):
        a, b = getattr(free.metrics["test"]["after"], stat), getattr(fixed.metrics["test"]["after"], stat)
        assert abs(a - b) < 1e-3, (stat, a, b)
    ident = fixed.identifiability
    assert "theta_1" not in ident.names and ident.fixed == ("theta_1",)
    assert len(ident.names) == len(free.identifiability.names) - 1


def test_held_parameters_against_the_truth(chain, params):
    """A true arm whose d_1 and a_2 are exactly nominal: fixed at nominal they stay 0 and
    the fit is as good as the free one; fixing a_2 when it is truly 1 mm off costs
    accuracy (the fix really holds it); --free estimates only the named ones."""
    _, draw = cp.simulate(chain, params, 1, seed=3)
    x = draw.x.copy()
    for name in ("d_1", "a_2"):
        x[params.names.index(name)] = 0.0
    data, truth = cp.simulate(chain, params, 120, seed=3, noise_mm=0.02, _true_x=x)
    free = cp.calibrate("irb120", data, method="lm", test_fraction=0)
    held = cp.calibrate("irb120", data, method="lm", test_fraction=0, fix="d_1,a_2")
    for name in ("d_1", "a_2"):
        assert held.x[held.problem.model.names.index(name)] == 0.0
    e_free, e_held = (_fresh_rmse_mm(r, chain, params, truth) for r in (free, held))
    assert e_held < 0.05 and e_held < 1.1 * e_free
    x[params.names.index("a_2")] = 1e-3
    data, truth = cp.simulate(chain, params, 120, seed=3, noise_mm=0.02, _true_x=x)
    wrong = cp.calibrate("irb120", data, method="lm", test_fraction=0, fix="a_2")
    assert _fresh_rmse_mm(wrong, chain, params, truth) > 5 * e_held
    # --free: a true arm off in its joint zeros only, estimated from those alone
    x = np.zeros(len(params.names))
    thetas = [f"theta_{j}" for j in (2, 3, 4, 5)]
    x[[params.names.index(t) for t in thetas]] = [2e-3, -1.5e-3, 1e-3, 2.5e-3]
    data, truth = cp.simulate(chain, params, 60, seed=4, noise_mm=0.01, _true_x=x)
    result = cp.calibrate("irb120", data, method="lm", test_fraction=0, free=",".join(thetas))
    robot = result.problem.model.robot(result.x)
    assert set(result.fixed) == set(params.names) - set(thetas)
    assert np.all(robot[[params.names.index(n) for n in result.fixed]] == 0.0)
    assert np.abs(robot - x).max() < 5e-5  # 50 urad of the truth (1-2.5 mrad)


def test_fixed_compliance_and_analyze(chain, params):
    """A compliance can be held (at zero: a rigid joint); --analyze's directions are those
    of the unknowns left."""
    setup = cp.prepare("irb120", WU, compliance="joint_2,joint_3", fix="compliance_joint_2,theta_1")
    assert setup.fixed == ("theta_1", "compliance_joint_2")
    result = cp.solve(setup, "lm")
    assert result.x[setup.problem.model.names.index("compliance_joint_2")] == 0.0
    assert result.x[setup.problem.model.names.index("compliance_joint_3")] > 0.0
    full, left = analyze(setup.problem), analyze(setup.problem, fixed=setup.fixed)
    assert len(left.names) == len(full.names) - 2 and left.fixed == setup.fixed
    assert "held at their start (--fix/--free), left out: theta_1, compliance_joint_2" in left.report()


def test_bad_names_are_refused(tmp_path, capsys):
    with pytest.raises(cp.CalibPinError, match=r"no unknown 'theta_9' in this calibration \(valid: a_1, d_1, "):
        cp.prepare("irb120", WU, fix="theta_9")
    with pytest.raises(cp.CalibPinError, match="'d_1' is both fixed and free"):
        cp.prepare("irb120", WU, fix="d_1", free="d_1,a_2")
    with pytest.raises(cp.CalibPinError, match="no unknown 'device_x'.*valid: a_1.*theta_6\\)"):
        cp.prepare("irb120", WU, free="device_x")  # the sensor's unknowns are not the robot's
    calibrate = command("calibrate")
    for argv in (["--fix", "theta_9"], ["--free", "a_1,nope"]):
        assert calibrate(["irb120", "--data", WU, "--out", str(tmp_path / "o"), *argv]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "(valid: a_1, d_1" in err
    assert not (tmp_path / "o").exists()
    assert calibrate(["irb120", "--data", WU, "--method", "lm", "--fix", "theta_1", "--no-html",
                      "--out", str(tmp_path / "o")]) == 0
    assert "fixed (held at their nominal value, --fix/--free): theta_1" in capsys.readouterr().out
    assert json.loads((tmp_path / "o" / "report.json").read_text())["fixed"] == ["theta_1"]


def test_fix_and_free_on_a_contact_set_alone_or_beside_another(chain, params):
    """--fix/--free on a contact set (alone, beside a cable set, and --analyze --fix): the
    contact set's named directions (scale, base motions) are tested on the unknowns kept
    (they raised numpy's ValueError: 39 is different from 37)."""
    contact = cp.read_measurements(Path(__file__).resolve().parents[1] / "robots" / "irb120_contact_example.csv")
    fixed = cp.prepare("irb120", contact, fix="theta_1")
    report = analyze(fixed.problem, fixed=fixed.fixed)
    assert report.fixed == ("theta_1",) and any(name.startswith("scale") for name, _, _ in report.directions)
    result = cp.calibrate("irb120", contact, method="lm", fix="theta_1")
    assert result.metrics["train"]["after"].rmse_mm < result.metrics["train"]["before"].rmse_mm
    cable, _ = cp.simulate(chain, params, 40, seed=3)
    both = cp.calibrate("irb120", [contact, cable], method="lm", free="theta_2,d_2")
    assert len(both.sets) == 2


@pytest.mark.parametrize("free", ["", ",,", [], ()])
def test_an_empty_list_of_unknowns_is_refused(free):
    """free='' (or an empty list) is not "every unknown free", and fix='' not "none held":
    both are refused, as the command line's --free '' and --fix ',,' are."""
    with pytest.raises(cp.ArgumentError, match="names nothing"):
        cp.prepare("irb120", WU, free=free)
    with pytest.raises(cp.ArgumentError, match="names nothing"):
        cp.prepare("irb120", WU, fix=free)

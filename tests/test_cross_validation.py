"""calibrate --cv K: K-fold cross-validation by pose on the training rows, checked against
the simulator's noise floor and a model that cannot fit (the nominal one)."""

from __future__ import annotations

import json

import numpy as np

import calib_pin as cp
from calib_pin import prepare
from calib_pin.calibration.solve import cross_validate
from calib_pin.parameters import parameter_model
from calib_pin.robot import load_chain
from calib_pin.simulation import simulate


def test_folds_reach_the_noise_floor():
    """On a simulated drawstring set (noise 0.05 mm) every fold's held-out poses are
    predicted at the noise floor (mean |e| of N(0, s): 0.8 s = 0.04 mm)."""
    chain = load_chain("irb120")
    data, _ = simulate(chain, parameter_model(chain), 80, 3, noise_mm=0.05)
    setup = prepare("irb120", data)
    rows = np.arange(60)
    cv = cross_validate(setup, "lm", rows, 4, seed=1)
    assert len(cv.test) == 4
    mean, sd = cv.stat("mean_mm")
    assert 0.02 < mean < 0.08 and sd < 0.03
    doc = cv.as_dict()
    assert doc["folds"] == 4 and len(doc["mean_mm"]["per_fold"]) == 4


def test_cli_cv_in_report_and_printout(tmp_path, capsys):
    """--cv 4 prints the line and writes report.json's cross_validation."""
    from calib_pin.cli import main

    code = main(["calibrate", "irb120", "--method", "lm", "--cv", "4", "--out", str(tmp_path), "--no-html"])
    printed = capsys.readouterr().out
    assert code == 0 and "4-fold cross-validation on the training poses" in printed
    cv = json.loads((tmp_path / "report.json").read_text())["cross_validation"]
    assert cv["folds"] == 4 and 0.02 < cv["mean_mm"]["mean"] < 0.1


def test_folds_hold_what_the_calibration_holds():
    """With --fix the folds fit the calibration's model: the unknowns it holds stay at their
    start in every fold, so held true deviations (theta_2, d_1, a_1) show
    in the held-out error as it does in the calibration's test error."""
    chain = load_chain("irb120")
    data, _ = simulate(chain, parameter_model(chain), 80, 3, noise_mm=0.05)
    rows = np.arange(60)
    free = cross_validate(prepare("irb120", data), "lm", rows, 4, seed=1)
    held = prepare("irb120", data, fix="theta_2,d_1,a_1")
    cv = cross_validate(held, "lm", rows, 4, seed=1)
    assert cv.stat("rmse_mm")[0] > 1.5 * free.stat("rmse_mm")[0]
    result = cp.solve(held, "lm", seed=1)
    assert abs(cv.stat("rmse_mm")[0] - result.metrics["test"]["after"].rmse_mm) < 0.5 * result.metrics["test"]["after"].rmse_mm


def test_folds_take_the_checked_method(monkeypatch):
    """solve with Folds checks the method's loss once: the folds fit with the record solve
    checked (cross-validation checked it again)."""
    from calib_pin.estimators import Method

    checked = []
    check = Method.check
    monkeypatch.setattr(Method, "check", lambda self, loss="linear": checked.append(self.name) or check(self, loss))
    calibration = prepare("irb120", simulate(load_chain("irb120"), parameter_model(load_chain("irb120")), 60, seed=4)[0])
    result = cp.solve(calibration, "lm", holdout=cp.Folds(3))
    assert result.cross_validation["folds"] == 3 and checked == ["lm"]

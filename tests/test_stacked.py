"""Several measurement sets in one fit: the stacked problem, the multi-set pipeline, the CLI."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import calib_pin as cp
from calib_pin import FitSet
from calib_pin.calibration.gauge import resolve_gauge
from calib_pin.calibration.problem import Problem
from calib_pin.cli.calibrate import calibrate_main
from calib_pin.estimators.subspace import Subspace
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import CableModel, Drawstring, setup_record

#: Three anchors of one drawstring, re-anchored between sessions, base frame [mm].
ANCHORS_MM = ((600.0, 200.0, -100.0), (-300.0, 550.0, -50.0), (100.0, -600.0, 150.0))
NOISE_M = 5e-5


def _session(chain, params, truth, anchor_mm, seed, noise_m=NOISE_M, n=60):
    """A drawstring session of the true robot ``truth.x`` with its own anchor (the file's
    anchor is the true one), noise ``noise_m`` [m], no noise_mm in its metadata."""
    poses, _ = cp.simulate(chain, params, n, seed=seed, anchor_mm=anchor_mm, nominal_rmse_mm=0.0)
    sensor = Drawstring(np.array(anchor_mm) * 1e-3, truth.sensor.tool, 0.0)
    rng = np.random.default_rng(seed + 1000)
    values = CableModel(chain, params, sensor).predict(truth.x, poses.q) + rng.normal(scale=noise_m, size=len(poses))
    return dataclasses.replace(poses, values=values, noise=None, notes={"source": f"session seed {seed}"})


@pytest.fixture(scope="module")
def three(chain, params):
    """One true robot, three sessions of 60 poses with different anchors."""
    _, truth = cp.simulate(chain, params, 60, seed=15, anchor_mm=ANCHORS_MM[0])
    sets = [_session(chain, params, truth, a, seed=150 + k) for k, a in enumerate(ANCHORS_MM)]
    return truth, sets


def _fresh_rmse_mm(chain, params, truth, model, x, anchor_mm) -> float:
    """RMSE [mm] of a model's predicted readings at 1000 fresh poses, for the drawstring at
    ``anchor_mm``, against the noise-free true readings."""
    q = random_poses(chain, 1000, np.random.default_rng(123))
    true = CableModel(chain, params, Drawstring(np.array(anchor_mm) * 1e-3, truth.sensor.tool, 0.0)).predict(truth.x, q)
    return float(np.sqrt(np.mean((model.predict(x, q) - true) ** 2)) * 1e3)


def test_three_anchors_joint_fit_beats_each_session_and_recovers_the_anchors(chain, params, three):
    truth, sets = three
    joint = cp.calibrate("irb120", [FitSet(s, label=f"s{k + 1}") for k, s in enumerate(sets)], method="lm",
                         setup=setup_record(estimate=("anchor",)))
    assert [s.label for s in joint.sets] == ["s1", "s2", "s3"]
    assert "s2:anchor_x" in joint.problem.model.names
    names, std = joint.problem.model.names, joint.uncertainty.std
    # Drawstring data cannot see the arm (theta_1) and every anchor turned together about the
    # base z axis, nor d_1 with every anchor raised: the calibration keeps the robot at its
    # start along them and the anchors take the rest (calibration/gauge.py). So the anchors are
    # compared with the truth moved to the same gauge (its anchors are the file's: corrections 0).
    training = joint.problem.subset(joint.train)
    space = Subspace.of(training.jacobian(joint.x), training.scale, joint.x)
    true_x = np.concatenate([truth.x, np.zeros(joint.problem.n_params - len(truth.x))])
    seen, _ = resolve_gauge(training, true_x, np.zeros_like(true_x), np.arange(len(true_x)), cp.Prior(),
                            joint.noise)
    # Blind: d_1 (up) and theta_1 (a turn about z) with every anchor; theta_6 and 3 pairs as with one set.
    assert space.rank == joint.problem.n_params - 6
    errors = []
    for k, (s, anchor_mm) in enumerate(zip(joint.sets, ANCHORS_MM, strict=True)):
        single = cp.calibrate("irb120", sets[k], method="lm", setup=setup_record(estimate=("anchor",)), noise_mm=0.05)
        alone = _fresh_rmse_mm(chain, params, truth, single.problem.model, single.x, anchor_mm)
        together = _fresh_rmse_mm(chain, params, truth, s.model, s.x, anchor_mm)
        errors.append((alone, together))
        print(f"set {k + 1}: fresh RMSE alone {alone:.4f} mm, joint {together:.4f} mm; anchor error "
              f"{np.round((s.model.geometry_at(s.x).anchor - np.array(anchor_mm) * 1e-3) * 1e3, 4)} mm")
        assert together < alone, (k, together, alone)
        assert together < 0.035  # reading noise 0.05 mm; the noise-free truth is the reference
        columns = [names.index(f"s{k + 1}:anchor_{a}") for a in "xyz"]
        error = s.model.geometry_at(s.x).anchor - (np.array(anchor_mm) * 1e-3 + seen[columns])
        print(f"  identifiable-part error / sigma: {np.round(error / std[columns], 2)}, sigma {std[columns] * 1e3} mm")
        assert np.all(np.abs(error) < 3 * std[columns]), (k, error / std[columns])
        assert np.abs(error).max() < 1e-4  # 0.1 mm
        assert s.sigma_origin == "estimate" and abs(s.sigma / NOISE_M - 1) < 0.4  # 48 training rows each
    assert abs(np.mean([s.sigma for s in joint.sets]) / NOISE_M - 1) < 0.15
    alone, together = np.mean(errors, axis=0)
    assert together < 0.75 * alone


def test_wu2015_split_in_two_sets_each_with_its_own_device_frame(tmp_path):
    data = cp.read_measurements("robots/irb120_wu2015.csv")
    ids = np.array([int(p) for p in data.point_ids])
    m12, m3 = data.subset(np.flatnonzero(ids <= 2)), data.subset(np.flatnonzero(ids == 3))
    result = cp.calibrate("irb120", [FitSet(m12, "m12"), FitSet(m3, "m3")], method="lm")
    assert [s.label for s in result.sets] == ["m12", "m3"]
    for s in result.sets:
        assert len(s.train) and len(s.test)
        assert s.metrics["test"]["after"].rmse_mm < 0.5 < s.metrics["test"]["before"].rmse_mm
        assert set(s.geometry["markers_mm"]) == ({"1", "2"} if s.label == "m12" else {"3"})
    frames = [s.geometry["device_frame"]["translation_mm"] for s in result.sets]
    assert np.all(np.isfinite(frames))
    pooled = np.concatenate([s.train for s in result.sets])
    assert len(result.train) == len(pooled)
    from calib_pin.report.build import build_report

    report = build_report(result)
    assert [s["label"] for s in report["sets"]] == ["m12", "m3"]
    assert report["sets"][1]["test"]["after"]["rmse_mm"] == result.sets[1].metrics["test"]["after"].rmse_mm
    json.dumps(report, allow_nan=False)


def test_one_set_in_a_list_is_the_plain_path(session):
    data, _ = session
    plain = cp.calibrate("irb120", data, method="ekf-qibas", seed=2)
    listed = cp.calibrate("irb120", [data], method="ekf-qibas", seed=2)
    assert isinstance(listed.problem, Problem) and len(listed.sets) == 1 and len(plain.sets) == 1
    assert np.array_equal(plain.x, listed.x)
    assert listed.problem.model.names == plain.sets[0].model.names  # no set label on one set's unknowns


def test_stacked_jacobian_is_the_finite_difference(chain, params, three):
    truth, sets = three
    problems = [CableModel.problem_for(chain, params, s, np.arange(len(s)), {"estimate": ("anchor", "offset")})
                for s in sets]
    stacked = Problem.of(problems, ["a", "b", "c"], [5e-5, 1e-4, 2e-5]).subset(np.arange(20, 150, 3))
    assert set(stacked.sets) == {0, 1, 2} and stacked.n_params == 24 + 3 * 4
    x = np.random.default_rng(0).normal(size=stacked.n_params) * stacked.scale
    jac = stacked.jacobian(x)
    step = 1e-7
    numeric = np.column_stack([(stacked.residual(x + step * e) - stacked.residual(x - step * e)) / (2 * step)
                               for e in np.eye(stacked.n_params)])
    assert np.allclose(jac, numeric, rtol=1e-5, atol=1e-7 * np.abs(jac).max())
    for row in (0, 17, stacked.n_rows - 1):
        r, j = stacked.row_residual_with_jacobian(x, row)
        assert np.allclose(r, stacked.residual(x)[row]) and np.allclose(j, jac[row])
    weights = np.repeat(stacked.weights, [p.n_rows for p in stacked.parts])
    assert np.allclose(stacked.row_errors(stacked.residual(x)), np.abs(stacked.residual(x)) / weights)


def test_a_stack_of_one_problem_is_that_problem(chain, params, three):
    _, sets = three
    problem = CableModel.problem_for(chain, params, sets[0], np.arange(60), {"estimate": ("anchor",)})
    stacked = Problem.of([problem], ["a"], [3e-5])
    x = np.random.default_rng(1).normal(size=problem.n_params) * problem.scale
    assert np.array_equal(stacked.residual(x), problem.residual(x))
    assert np.array_equal(stacked.jacobian(x), problem.jacobian(x))


def test_noise_from_caller_file_or_residual(chain, params, three):
    truth, sets = three
    loud = _session(chain, params, truth, ANCHORS_MM[1], seed=40, noise_m=2e-4)
    quiet = dataclasses.replace(sets[0], noise=5e-5)  # as a file's '# noise_mm: 0.05'
    result = cp.calibrate("irb120", [FitSet(quiet, "quiet"), FitSet(loud, "loud")], method="lm")
    (q, noisy) = result.sets
    assert (q.sigma_origin, q.sigma) == ("file", 5e-5)
    assert noisy.sigma_origin == "estimate" and abs(noisy.sigma / 2e-4 - 1) < 0.25
    assert result.noise == 5e-5
    given = cp.calibrate("irb120", [FitSet(quiet, "quiet"), FitSet(loud, "loud", noise_mm=0.2)], method="lm")
    assert [s.sigma_origin for s in given.sets] == ["file", "caller"]
    assert np.isclose(given.problem.weights[1], 0.25)


def test_roles_train_and_test(chain, params, three):
    _, sets = three
    result = cp.calibrate("irb120", [FitSet(sets[0], "a", role="train"), FitSet(sets[1], "b"),
                                     FitSet(sets[2], "c", role="test")], method="lm", noise_mm=0.05)
    a, b, c = result.sets
    assert len(a.test) == 0 and len(a.train) == 60 and "test" not in a.metrics
    assert len(c.train) == 0 and len(c.test) == 60 and "train" not in c.metrics
    assert 0 < len(b.test) < 60
    assert c.metrics["test"]["after"].rmse_mm < 0.1 < c.metrics["test"]["before"].rmse_mm  # scored, never fitted
    assert set(result.test) >= set(c.rows)


@pytest.mark.parametrize("kwargs, message", [
    ({"data": "same label"}, "two sets are labelled 'x'"),
    ({"data": "same file"}, "given twice"),
    ({"setup": cp.CableSetup(anchor_mm=(0, 0, 0))}, "anchor_mm: one value for several sets"),
    ({"test_data": "robots/irb120_default.csv"}, "name the one whose set-up the session shares"),
    ({"method": "rbf"}, "one correction per set, valid for none of the others"),
])
def test_several_sets_refusals(three, kwargs, message):
    _, sets = three
    data = [sets[0], sets[1]]
    if kwargs.get("data") == "same label":
        data = [FitSet(sets[0], "x"), FitSet(sets[1], "x")]
    elif kwargs.get("data") == "same file":
        data = ["robots/irb120_default.csv", "robots/irb120_default.csv"]
    options = {k: v for k, v in kwargs.items() if k != "data"}
    with pytest.raises(cp.CalibPinError, match=message.replace("(", r"\(")):
        cp.calibrate("irb120", data, method=options.pop("method", "lm"), **options)


def test_cli_several_data_files(three, tmp_path, capsys):
    _, sets = three
    paths = []
    for k, s in enumerate(sets[:2]):
        paths += ["--data", str(tmp_path / f"anchor{k + 1}.csv")]
        cp.write_measurements(paths[-1], s)
    out = tmp_path / "o"
    assert calibrate_main(["irb120", *paths, "--method", "lm", "--estimate", "anchor", "--no-html",
                           "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "set anchor1: 60 rows" in text and "set anchor2: 60 rows" in text and "all sets" in text
    assert text.count("train after") == 3
    report = json.loads((out / "report.json").read_text())
    assert [s["label"] for s in report["sets"]] == ["anchor1", "anchor2"]
    assert report["sets"][0]["noise_from"] == "estimate"
    assert calibrate_main(["irb120", *paths, "--anchor-mm", "1,2,3", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--anchor-mm with several --data files: put each set's in its file" in err[0]


def test_three_set_ups_in_one_file_are_named_in_a_warning(three, tmp_path):
    _, sets = three
    rows = np.concatenate([s.values for s in sets])
    one = dataclasses.replace(sets[0], q=np.concatenate([s.q for s in sets]), values=rows,
                              extra={"session": np.repeat(np.array(["A", "B", "C"], dtype=object), 60)})
    path = tmp_path / "three_anchors.csv"
    cp.write_measurements(path, one)  # one anchor in the metadata, three in fact
    result = cp.calibrate("irb120", path, method="lm", noise_mm=0.05)
    assert result.metrics["train"]["after"].rmse_mm > 0.25
    warning = [w for w in result.warnings if "set-ups" in w]
    assert len(warning) == 1 and "'session' column names 3 set-ups (A, B, C) fitted here as one" in warning[0]
    together = cp.calibrate("irb120", sets, method="lm", noise_mm=0.05)  # three files: no such warning
    assert not [w for w in together.warnings if "set-ups" in w]


def test_html_report_has_a_table_per_set(three):
    pytest.importorskip("matplotlib")
    from calib_pin.report.build import build_report
    from calib_pin.report.html import render_html

    _, sets = three
    result = cp.calibrate("irb120", [FitSet(sets[0], "left"), FitSet(sets[1], "right")], method="lm",
                          setup=setup_record(estimate=("anchor",)))
    page = render_html(build_report(result))
    assert "Measurement sets" in page and "Set left" in page and "Set right" in page


@pytest.mark.parametrize("method", ["ekf-qibas", "ekf"])
def test_kalman_filters_update_row_by_row_over_stacked_sets(chain, params, three, method):
    truth, sets = three
    data = [FitSet(s, f"s{k + 1}", noise_mm=0.05) for k, s in enumerate(sets)]
    result = cp.calibrate("irb120", data, method=method, setup=setup_record(estimate=("anchor",)))
    reference = cp.calibrate("irb120", data, method="lm", setup=setup_record(estimate=("anchor",)))
    for s, ref, anchor_mm in zip(result.sets, reference.sets, ANCHORS_MM, strict=True):
        error = _fresh_rmse_mm(chain, params, truth, s.model, s.x, anchor_mm)
        assert error < 1.3 * _fresh_rmse_mm(chain, params, truth, ref.model, ref.x, anchor_mm) + 0.005
    with pytest.raises(cp.CalibPinError, match="predicts per set"):
        result.predict(np.zeros(6))
    assert np.array_equal(result.predict(np.zeros(6), set="s2"), result.sets[1].predict(np.zeros(6)))


@pytest.mark.parametrize("method", ["lm", "ekf"])
def test_a_set_no_robot_fits_is_refused_naming_the_data_not_the_noise_argument(method):
    """Two sets, one of positions in the wrong unit (metres read as mm): the estimated noise
    would be metres, which the filters refuse as their argument ('argument noise'); the
    refusal names a data file, and every set it finds so (a stacked fit cannot tell which
    one is wrong when one spoils the common estimate)."""
    data = cp.read_measurements("robots/irb120_wu2015.csv")
    ids = np.array([int(p) for p in data.point_ids])
    m12, m3 = data.subset(np.flatnonzero(ids <= 2)), data.subset(np.flatnonzero(ids == 3))
    wrong = dataclasses.replace(m3, values=m3.values * 1e3, source="m3_in_um.csv")
    with pytest.raises(cp.DataError, match=r"the fit leaves .* m per value .*do not fit this robot") as refused:
        cp.calibrate("irb120", [FitSet(m12, "m12"), FitSet(wrong, "m3")], method=method)
    assert "argument noise" not in str(refused.value)
    assert "m3_in_um.csv" in str(refused.value) or "also m3" in str(refused.value)


def test_a_problem_of_no_sets_is_refused(three):
    """A calibration problem of no sets (no parts), or of parts, labels and sigmas that do
    not pair up, is one CalibPinError (its residual raised numpy's ValueError)."""
    problem = cp.prepare("irb120", three[1][:2]).problem
    with pytest.raises(cp.CalibPinError, match="at least one measurement set"):
        Problem(problem.model, (), np.zeros(0))
    with pytest.raises(cp.CalibPinError, match="at least one measurement set"):
        Problem.of([], [], [])
    with pytest.raises(cp.CalibPinError, match="2 set problem"):
        Problem.of(list(problem.parts), ["a"], [1e-4, 1e-4])

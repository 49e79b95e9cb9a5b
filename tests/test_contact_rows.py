"""A contact set's known-distance rows beside its touches, everywhere rows are counted.

A contact problem's rows are its touches (data rows, one per row of ``q`` and of the
file), then one row per known distance (``# distance_mm``), which carries no pose, is kept
by every ``subset`` (always trained on) and is never a test row: :func:`calib_pin.estimators.problem.data_rows`.
Also: a contact truth's model (``Truth.model``) and compare's fresh-pose score, measured after
the best rigid motion (the base placement no contact set sees)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.analysis.identifiability import distinct_values
from calib_pin.cli import main
from calib_pin.estimators import get_method
from calib_pin.estimators.problem import data_row_errors, data_rows
from calib_pin.robot.poses import random_poses
from calib_pin.sensors.contact import rigid_aligned
from calib_pin.simulation import Truth
from calib_pin.studies.comparison import _methods_for_data, compare


@pytest.fixture(scope="module")
def sets(tmp_path_factory):
    """A seeded contact set (3 sockets, a plane, A-B known) and a cable set of one true robot, with truths."""
    folder = tmp_path_factory.mktemp("contact_rows")
    assert main(["simulate", "irb120", "--kinds", "contact", "--poses", "48", "--seed", "4",
                 "--out", str(folder / "touch.csv")]) == 0
    assert main(["simulate", "irb120", "--kinds", "contact,cable", "--poses", "40", "--seed", "5",
                 "--out", str(folder / "day.csv")]) == 0
    return folder


def test_a_contact_truths_model_predicts_the_true_tool_points(sets):
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    truth = Truth.from_json(sets / "touch.truth.json", params)
    model = truth.model(chain, params)
    assert model.n_params == model.sensor_start == len(truth.x_model)  # nothing of the set-up unknown
    data = cp.read_measurements(sets / "touch.csv")
    problem = cp.prepare("irb120", data).problem
    # at the truth every touch misses its true fixture by the play only (0.05 mm per axis)
    r, jac = model.residual(truth.x_model, data.q, problem.points, jacobian=True)
    assert np.sqrt(np.mean(r[: -1] ** 2)) < 0.1e-3 and abs(r[-1]) < 1e-9  # the known distance holds exactly
    step = 1e-7
    for k in (0, 7, model.n_params - 1):  # the robot's columns against finite differences
        e = np.zeros(model.n_params)
        e[k] = step
        fd = (model.residual(truth.x_model + e, data.q, problem.points)[0]
              - model.residual(truth.x_model - e, data.q, problem.points)[0]) / (2 * step)
        assert np.allclose(jac[:, k], fd, atol=1e-6 * max(1.0, np.abs(fd).max()))


def test_rigid_aligned_removes_a_rigid_motion_only():
    rng = np.random.default_rng(3)
    p = rng.normal(size=(30, 3))
    import pinocchio as pin

    moved = p @ pin.exp3(np.array([0.3, -0.2, 0.5])).T + np.array([1.0, 2.0, -3.0])
    assert np.allclose(rigid_aligned(moved, p), p, atol=1e-12)
    bent = moved.copy()
    bent[0] += 0.1  # a shape change stays
    assert np.abs(rigid_aligned(bent, p) - p).max() > 0.05


def test_compare_scores_a_contact_set_on_fresh_poses_after_the_best_rigid_motion(sets):
    result = compare("irb120", str(sets / "touch.csv"), methods=["lm"])
    trial = result.trials[0]
    fresh = trial.runs["lm"].fresh_rmse_mm
    assert trial.before_fresh_rmse_mm > 0.5 and fresh < 0.1, (trial.before_fresh_rmse_mm, fresh)
    # the same number from the calibration's own model and the truth, independently of compare
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    truth = Truth.from_json(sets / "touch.truth.json", params)
    calibrated = cp.calibrate("irb120", str(sets / "touch.csv"), method="lm")
    q = random_poses(chain, 1000, np.random.default_rng(10_000))
    true = truth.model(chain, params).predict(truth.x_model, q)
    error = rigid_aligned(calibrated.problem.model.predict(calibrated.x, q), true) - true
    assert fresh == pytest.approx(float(np.sqrt(np.mean(error**2))) * 1e3, rel=1e-6)
    # the default methods leave out those the sensor refuses, saying so
    said: list[str] = []
    records = [get_method(m) for m in ("ekf", "ukf", "rbf", "lm")]
    kept = _methods_for_data(cp.prepare("irb120", str(sets / "touch.csv")), records, True, said.append)
    assert [m.name for m in kept] == ["ekf", "lm"]
    assert said and "ukf, rbf" in said[0]


def test_distance_rows_are_training_rows_never_test_rows(sets):
    data = cp.read_measurements(sets / "touch.csv")
    setup = cp.prepare("irb120", data)
    train, test = setup.split(0.25, 0)
    problem = setup.problem_on(train)
    n_distances = len(problem.parts[0].model.fixtures.distances)
    assert n_distances == 1
    assert len(problem.q) == len(problem.points) == len(data)  # q: touches only
    assert problem.n_rows == len(data) + n_distances and len(problem.row_offsets) == problem.n_rows + 1
    assert np.array_equal(data_rows(problem), np.arange(len(data)))
    for rows in (train, test):
        part = problem.subset(rows)
        assert part.n_rows == len(rows) + n_distances  # the distance row stays with every subset
        assert np.array_equal(part.q, data.q[rows])
        assert len(data_row_errors(part, part.residual(None))) == len(rows)  # ... and is never scored
    result = cp.solve(setup, "lm", holdout=0.25)
    test_problem = result.problem.subset(result.test)
    errors = data_row_errors(test_problem, result.estimate.residual(test_problem))
    assert result.metrics["test"]["after"].rmse_mm == pytest.approx(float(np.sqrt(np.mean(errors**2))) * 1e3)
    ident = result.identifiability  # --analyze of the training rows: every touch's values and the distance's
    training = result.problem.subset(result.train)
    assert ident.n_poses == training.n_values == int(training.parts[0].row_sizes[: len(result.train)].sum()) + n_distances
    assert any(name.startswith("scale") and seen for name, seen, _ in ident.directions)  # the distance sees it
    assert distinct_values(training) == training.n_values  # distinct touches, and the distance's value


def test_a_stack_with_a_contact_set_first_keeps_every_sets_rows(sets, tmp_path):
    """The contact set (with its distance row) before a cable set: the cable's training rows
    are its own (no row shifted by the distance row), through calibrate, the report and --analyze."""
    paths = [str(sets / "day_1.csv"), str(sets / "day_2.csv")]
    assert [cp.read_measurements(p).kind for p in paths] == ["contact", "cable"]
    out = tmp_path / "out"
    assert main(["calibrate", "irb120", "--data", paths[0], "--data", paths[1], "--method", "lm",
                 "--out", str(out)]) == 0
    assert (out / "report.html").is_file()
    report = json.loads((out / "report.json").read_text())
    result = cp.calibrate("irb120", paths, method="lm")
    n = len(result.data)
    assert report["residuals"]["rows"] == [int(r) for r in result.train] + [int(r) for r in result.test]
    assert sorted(report["residuals"]["rows"]) == list(range(n))  # every touch and reading once, no distance row
    training = result.problem.subset(result.train)
    contact, cable = (cp.read_measurements(p) for p in paths)
    cable_train = result.sets[1].train
    assert np.array_equal(training.parts[1].q, cable.q[cable_train])  # the cable's own training rows
    assert training.parts[0].n_rows == len(result.sets[0].train) + 1  # the contact's, and its distance row
    assert np.array_equal(training.q, result.data.q[result.train])
    # each set's test error is of its own data rows only, as the pooled table's
    for k, s in enumerate(result.sets):
        part = result.problem.parts[k].subset(s.test)
        assert s.metrics["test"]["after"].rmse_mm == pytest.approx(
            float(np.sqrt(np.mean(data_row_errors(part, part.residual(s.x)) ** 2))) * 1e3)
    assert result.identifiability.n_poses == training.n_values


def test_a_robust_fit_names_outlying_touches_by_their_data_row(sets):
    """Outliers of a stack whose contact set (with its distance row) comes first are named
    by data row (the cable's shifted by nothing, no distance row named)."""
    paths = [str(sets / "day_1.csv"), str(sets / "day_2.csv")]
    cable = cp.read_measurements(paths[1])
    values = cable.values.copy()
    values[3] += 0.01  # a 10 mm gross error on the cable's row 3
    bad = cp.MeasurementSet(**{**{f: getattr(cable, f) for f in cable.__dataclass_fields__}, "values": values})
    result = cp.calibrate("irb120", [paths[0], bad], method="lm", loss="huber", test_fraction=0.0)
    n_contact = len(cp.read_measurements(paths[0]))
    assert n_contact + 3 in result.outlier_rows
    assert all(0 <= r < len(result.data) for r in result.outlier_rows)

"""Batch runs: identical results serially, in local processes and on a loopback Dask cluster."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.exceptions import CalibPinError
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import CableModel
from calib_pin.studies.batch import SUMMARY_COLUMNS, BatchTask, parallel_map, run_batch


@pytest.fixture(scope="module")
def sets(tmp_path_factory, chain, params):
    """Three small simulated sets (40 poses, seeds 0-2) with their truths, and a bad file."""
    folder = tmp_path_factory.mktemp("sets")
    tasks, truths = [], {}
    for seed in range(3):
        data, truth = cp.simulate(chain, params, 40, seed=seed, noise_mm=0.05)
        path = folder / f"arm{seed}.csv"
        cp.write_measurements(path, data)
        tasks.append(BatchTask("irb120", str(path), "lm", seed=seed))
        truths[f"arm{seed}"] = truth
    bad = folder / "broken.csv"
    bad.write_text("q1_deg,q2_deg\n1,2\n")
    tasks.insert(1, BatchTask("irb120", str(bad), "lm"))
    return tasks, truths


def _without_time(outcomes) -> list:
    """Everything a task produced except its wall times."""
    out = []
    for o in outcomes:
        report = {k: v for k, v in (o.report or {}).items() if k != "time_s"}
        row = {k: v for k, v in o.row.items() if k != "time_s"}
        out.append((o.name, o.status, o.error, row, json.dumps(report, sort_keys=True), o.urdf_text))
    return out


@pytest.fixture(scope="module")
def serial(sets, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    return out, run_batch(sets[0], out=out)


def _fresh_rmse_mm(report: dict, truth, chain, params) -> float:
    """RMSE [mm] of the reported deviations' readings on 500 fresh poses against the truth."""
    dev = report["deviations"]
    x = np.array([dev[f"{n}_mm"] * 1e-3 if u == "m" else np.deg2rad(dev[f"{n}_deg"])
                  for n, u in zip(params.names, params.units, strict=True)])
    q = random_poses(chain, 500, np.random.default_rng(99))
    cable = CableModel(chain, params, truth.sensor)
    return float(np.sqrt(np.mean((cable.predict(x, q) - cable.predict(truth.x, q)) ** 2)) * 1e3)


def test_serial_batch_calibrates_each_set_and_reports_the_bad_one(serial, sets, chain, params):
    out, outcomes = serial
    _, truths = sets
    assert [o.status for o in outcomes] == ["ok", "failed", "ok", "ok"]
    bad = outcomes[1]
    assert "broken.csv" in bad.error and "\n" not in bad.error and bad.report is None
    for o in (outcomes[0], outcomes[2], outcomes[3]):
        assert o.report["seed"] == int(o.name[-1])
        # Against the simulator's truth: nominal 2 mm, calibrated well under 0.3 mm.
        assert _fresh_rmse_mm(o.report, truths[o.name], chain, params) < 0.3
        assert (out / o.name / "irb120_calibrated.urdf").read_text() == o.urdf_text
        assert (out / o.name / "irb120_calibration.json").is_file()  # as calibrate writes (write_outputs)
        assert json.loads((out / o.name / "report.json").read_text())["method"] == "lm"
    with (out / "summary.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == SUMMARY_COLUMNS
    assert [r["set"] for r in rows] == ["arm0", "broken", "arm1", "arm2"]
    assert rows[1]["status"] == "failed" and rows[1]["error"] == bad.error and rows[1]["test_rmse_after_mm"] == ""
    assert float(rows[0]["test_rmse_after_mm"]) == pytest.approx(outcomes[0].report["test"]["after"]["rmse_mm"], abs=1e-6)
    assert not (out / "broken").exists()


def test_joblib_processes_give_the_serial_results(serial, sets, tmp_path):
    outcomes = run_batch(sets[0], out=tmp_path, jobs=2)
    assert _without_time(outcomes) == _without_time(serial[1])


def test_loopback_dask_cluster_gives_the_serial_results(serial, sets, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
        dashboard_address=":0",  # any free port: None still binds the HTTP server to 8787
    ) as cluster:
        outcomes = run_batch(sets[0], out=tmp_path, scheduler=cluster.scheduler_address)
    assert _without_time(outcomes) == _without_time(serial[1])
    assert (tmp_path / "summary.csv").read_text().count("\n") == 5


def test_duplicate_set_names_and_bad_jobs_are_refused(sets, tmp_path):
    task = sets[0][0]
    with pytest.raises(CalibPinError, match="share the name 'arm0'"):
        run_batch([task, BatchTask("irb120", str(tmp_path / "arm0.csv"))], out=tmp_path)
    with pytest.raises(CalibPinError, match="jobs must be at least 1"):
        parallel_map(abs, [1], jobs=0)


@pytest.mark.parametrize("address", ["notanaddress", "http://127.0.0.1:8786", "tcp://host:port"])
def test_malformed_scheduler_address_is_refused_before_connecting(address):
    pytest.importorskip("distributed")
    with pytest.raises(CalibPinError, match="is not a Dask scheduler address .*; give tcp://host:port"):
        parallel_map(abs, [1], scheduler=address)


def test_parallel_map_keeps_the_order():
    assert parallel_map(abs, [-3, 1, -2], jobs=2) == [3, 1, 2]


def test_batch_cli_writes_outputs_and_names_the_failed_set(sets, tmp_path, capsys):
    from calib_pin.cli.batch import batch_main

    paths = [t.data for t in sets[0]]
    assert batch_main([*paths, "--out", str(tmp_path), "--method", "lm"]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and "1 of 4 set(s) failed, first broken" in err[0]
    assert (tmp_path / "arm2" / "irb120_calibrated.urdf").is_file()
    assert batch_main([paths[0], "--out", str(tmp_path / "one")]) == 0  # robot from the file


@pytest.mark.parametrize("argv, message", [
    (["--out", "x"], "the following arguments are required: SESSION"),
    (["a.csv", "--out", "x", "--jobs", "0"], "expected a whole number from 1"),
    (["a.csv", "--out", "x", "--method", "nope"], "invalid choice"),
    (["a.csv", "--out", "x", "--loss", "nope"], "unknown loss 'nope'"),
    (["a.csv", "--out", "x", "--scheduler", "localhost"], "'localhost' is not a Dask scheduler address"),
])
def test_batch_cli_bad_options_are_one_line_exit_2(argv, message, capsys):
    from calib_pin.cli.batch import batch_main

    try:
        status = batch_main(argv)
    except SystemExit as e:
        status = e.code
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and message in err[0]


def _trial_values(comparison) -> list:
    """A comparison's numbers except wall times."""
    out = []
    for t in comparison.trials:
        runs = [(r.method, r.train, r.test, r.fresh_rmse_mm, r.iterations, r.history_mm, r.test_residual_mm.tolist())
                for r in t.runs.values()]
        out.append((t.seed, t.before, t.before_fresh_rmse_mm, t.before_residual_mm.tolist(), runs))
    return out


def test_compare_trials_in_processes_match_the_serial_trials():
    kwargs = {"methods": ["lm", "ekf"], "trials": 3, "seed": 4, "simulate_noise": "gauss", "poses": 40}
    serial = cp.compare("irb120", **kwargs)
    parallel = cp.compare("irb120", jobs=2, **kwargs)
    assert _trial_values(parallel) == _trial_values(serial)
    assert [t.seed for t in serial.trials] == [4, 5, 6]
    # Against the simulator's truth: each calibration beats the nominal model on fresh poses.
    for t in serial.trials:
        assert all(r.fresh_rmse_mm < 0.3 * t.before_fresh_rmse_mm for r in t.runs.values())


def test_a_rerun_leaves_no_earlier_output_beside_a_set_that_now_fails(sets, tmp_path, capsys):
    """Two sets that calibrated, then fail (a broken file; identical poses, which calibrate
    refuses): no earlier report or URDF is left beside them, and the summary says failed."""
    from calib_pin.cli.batch import batch_main

    broken, refused = tmp_path / "arm.csv", tmp_path / "arm_b.csv"
    text = Path(sets[0][0].data).read_text()
    broken.write_text(text)
    refused.write_text(text)
    out = tmp_path / "out"
    assert batch_main([str(broken), str(refused), "--out", str(out)]) == 0
    for name in ("arm", "arm_b"):
        assert {p.name for p in (out / name).iterdir()} == {"irb120_calibrated.urdf", "irb120_calibration.json",
                                                           "report.json"}
    broken.write_text("q1_deg,q2_deg\n1,2\n")
    lines = text.splitlines()
    meta = [line for line in lines if line.startswith("#")]
    rows = [line for line in lines if line and not line.startswith("#")]
    refused.write_text("\n".join([*meta, rows[0], *[rows[1]] * 40]) + "\n")
    capsys.readouterr()
    assert batch_main([str(broken), str(refused), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "2 of 2 set(s) failed" in err[0]
    assert not (out / "arm").exists()
    assert not (out / "arm_b" / "irb120_calibrated.urdf").exists()
    assert not (out / "arm_b" / "irb120_calibration.json").exists()
    if (out / "arm_b").exists():  # the refused set's report of this run, which says why
        assert [p.name for p in (out / "arm_b").iterdir()] == ["report.json"]
        report = json.loads((out / "arm_b" / "report.json").read_text())
        assert report["urdf"] is None and report["urdf_refused"]
    with (out / "summary.csv").open() as f:
        summary = list(csv.DictReader(f))
    assert [(r["set"], r["status"]) for r in summary] == [("arm", "failed"), ("arm_b", "failed")]
    assert "arm.csv" in summary[0]["error"] and summary[1]["error"]


def test_rerun_keys_depend_on_inputs_and_options(sets, tmp_path):
    """A finished set is reused only for the same file content, robot, method, seed and options."""
    from calib_pin.studies.batch import task_key

    path = tmp_path / "k.csv"
    path.write_bytes(Path(sets[0][0].data).read_bytes())
    task = BatchTask("irb120", str(path), "lm", 0, {"test_fraction": 0.2})
    key = task_key(task)
    assert task_key(BatchTask("irb120", str(path), "lm", 0, {"test_fraction": 0.2})) == key
    assert task_key(BatchTask("irb120", str(path), "lm", 1, {"test_fraction": 0.2})) != key
    assert task_key(BatchTask("irb120", str(path), "pso", 0, {"test_fraction": 0.2})) != key
    assert task_key(BatchTask("irb120", str(path), "lm", 0, {"test_fraction": 0.3})) != key
    assert task_key(BatchTask(None, str(path), "lm", 0, {"test_fraction": 0.2})) != key
    path.write_bytes(path.read_bytes() + b"\n")
    assert task_key(task) != key

"""batch and compare on multi-set calibrations: ``a.csv+b.csv`` is one calibration of
two sets, ``compare --data a.csv --data b.csv`` runs on the sets stacked, and the
checkpoint key holds every set's file digest."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.cli.batch import batch_main, calibration_files
from calib_pin.cli.compare import compare_main
from calib_pin.exceptions import CalibPinError
from calib_pin.studies.batch import BatchTask, run_batch, task_key


@pytest.fixture(scope="module")
def sessions(tmp_path_factory, chain, params):
    """Two drawstring sessions of one true robot (40 poses each, own anchors) as files."""
    folder = tmp_path_factory.mktemp("sessions")
    sets, truth = cp.simulate_sessions(chain, params, 40, seed=8, sessions=2)
    paths = [folder / f"s_{k + 1}.csv" for k in range(2)]
    for path, data in zip(paths, sets, strict=True):
        cp.write_measurements(path, data)
    return [str(p) for p in paths], truth


def test_a_plus_joined_argument_is_one_calibration():
    assert calibration_files("a.csv") == "a.csv"
    assert calibration_files("a.csv+b.csv+c.csv") == ("a.csv", "b.csv", "c.csv")
    with pytest.raises(CalibPinError, match="empty set"):
        calibration_files("a.csv++b.csv")
    assert BatchTask("irb120", ("x/a.csv", "y/b.csv")).name == "a+b"


def test_batch_of_a_multi_set_calibration_equals_calibrate(sessions, tmp_path, capsys):
    paths, _ = sessions
    assert batch_main(["+".join(paths), paths[0], "--robot", "irb120", "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "s_1+s_2" / "report.json").read_text())
    direct = cp.calibrate("irb120", paths, method="lm")
    assert [s["label"] for s in report["sets"]] == [s.label for s in direct.sets]
    assert np.isclose(report["test"]["after"]["rmse_mm"], direct.metrics["test"]["after"].rmse_mm, rtol=0, atol=1e-9)
    rows = {r["set"]: r for r in csv.DictReader((tmp_path / "summary.csv").open())}
    assert rows["s_1+s_2"]["status"] == "ok" and rows["s_1+s_2"]["rows"] == "80" and rows["s_1"]["rows"] == "40"
    assert "s_1+s_2" in capsys.readouterr().out


def test_the_key_of_a_multi_set_task_holds_every_sets_digest(sessions, tmp_path):
    paths, _ = sessions
    copies = []
    for k, p in enumerate(paths):
        copies.append(tmp_path / f"c{k}.csv")
        copies[-1].write_bytes(open(p, "rb").read())
    task = BatchTask("irb120", tuple(str(c) for c in copies))
    key = task_key(task)
    assert task_key(BatchTask("irb120", tuple(str(c) for c in copies))) == key
    assert task_key(BatchTask("irb120", tuple(str(c) for c in reversed(copies)))) != key
    assert task_key(BatchTask("irb120", str(copies[0]))) != key
    copies[1].write_bytes(copies[1].read_bytes() + b"\n")  # the second set's bytes changed
    assert task_key(task) != key
    outcomes = run_batch([task], out=tmp_path / "out")
    assert outcomes[0].status == "ok" and outcomes[0].name == "c0+c1"


def test_compare_on_stacked_sets(sessions, tmp_path, capsys):
    paths, _ = sessions
    table = cp.compare("irb120", paths, methods=["lm", "ekf-qibas"], trials=2)
    assert "80 rows of 2 sets stacked (s_1.csv, s_2.csv)" in table.data
    for trial, seed in zip(table.trials, (0, 1), strict=True):
        direct = cp.calibrate("irb120", paths, method="lm", seed=seed)
        assert np.isclose(trial.runs["lm"].test.rmse_mm, direct.metrics["test"]["after"].rmse_mm, rtol=1e-9)
        assert trial.runs["lm"].test.rmse_mm < 0.1 and trial.before.rmse_mm > 1.0  # noise 0.05 mm, nominal 2 mm
    out = tmp_path / "cmp"
    assert compare_main(["irb120", "--data", paths[0], "--data", paths[1], "--methods", "lm", "--out", str(out),
                         "--quiet"]) == 0
    assert "2 sets stacked" in (out / "table1.md").read_text()
    with pytest.raises(CalibPinError, match="several sets"):
        cp.compare("irb120", paths, methods=["rbf"])
    assert compare_main(["irb120", "--data", paths[0], "--data", paths[1], "--methods", "lm",
                         "--out", paths[0], "--quiet"]) == 2
    capsys.readouterr()


def test_a_set_folder_name_is_safe_and_unique():
    """Many sessions joined stay under the file system's 255 bytes, a stem '..', '.' or a
    hidden one never names a folder outside --out or the checkpoint's, and different sets
    keep different names."""
    from calib_pin.studies.batch import NAME_LIMIT, folder_name

    long = [f"session_recorded_on_2024_03_{k:02d}_station_long_name" for k in range(1, 13)]
    name = folder_name(long)
    assert name.startswith("session_recorded_on_2024_03_01_station_long_name+11-more-")
    assert len(name.encode()) <= NAME_LIMIT and folder_name(long[:11] + ["other"]) != name
    for stems in (["..", "x"], [".."], ["."], [".calib-pin-checkpoint"], [""], ["é" * 200]):
        made = folder_name(stems)
        assert made and not made.startswith(".") and "/" not in made and len(made.encode()) <= NAME_LIMIT, made
    assert folder_name([".."]) != folder_name(["."]) and folder_name(["a", "b"]) == "a+b"
    assert BatchTask("irb120", "x/...csv").name.startswith("set-")


def test_a_file_name_holding_plus_can_be_joined(tmp_path, monkeypatch):
    """a+b.csv+c.csv: the '+' that leave existing files cut it; two such ways are refused,
    and where none does the missing file is the one named (a name beyond the file system's
    limit is no file, not an error)."""
    monkeypatch.chdir(tmp_path)
    for name in ("a+b.csv", "c.csv"):
        (tmp_path / name).write_text("x")
    assert calibration_files("a+b.csv+c.csv") == ("a+b.csv", "c.csv")
    assert calibration_files("a+b.csv+d.csv") == ("a+b.csv", "d.csv")  # d.csv then named as missing
    assert calibration_files("+".join(["s" * 60 + ".csv"] * 6)) == ("s" * 60 + ".csv",) * 6
    for name in ("a", "b.csv"):
        (tmp_path / name).write_text("x")
    with pytest.raises(CalibPinError, match="two readings of existing files, 'a' \\+ 'b.csv' \\+ 'c.csv' and"):
        calibration_files("a+b.csv+c.csv")


def test_batch_writes_a_dot_dot_stem_inside_out(sessions, tmp_path, capsys):
    """A set file named '...csv' (stem '..') writes its report inside --out, not beside it."""
    paths, _ = sessions
    odd = tmp_path / "...csv"
    odd.write_bytes(Path(paths[0]).read_bytes())
    out = tmp_path / "deep" / "out"
    assert batch_main([str(odd), "--robot", "irb120", "--out", str(out)]) == 0
    assert sorted(p.name for p in (tmp_path / "deep").iterdir()) == ["out"]
    (folder,) = [p for p in out.iterdir() if p.is_dir()]
    assert folder.name.startswith("set-") and (folder / "report.json").is_file()

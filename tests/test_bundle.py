"""write_outputs (calib_pin/report/bundle.py): a calibration's files all together or none,
the same for the CLI, batch and library users: no corrected robot past the sanity bound,
an earlier run's stale files removed, an input never written over nor removed."""

from __future__ import annotations

import json

import pytest

import calib_pin as cp
from calib_pin.calibration.result import CalibrationResult
from calib_pin.export.calibration_file import load_calibration
from calib_pin.report.bundle import render_outputs


@pytest.fixture(scope="module")
def result(session):
    data, _ = session
    return cp.calibrate("irb120", data, method="lm", seed=0)


def test_write_outputs_writes_the_robot_its_calibration_file_and_the_report(result, session, tmp_path):
    stale = tmp_path / "irb120_dh.toml"  # an earlier run's export this run does not write
    stale.write_text("old\n")
    done = cp.write_outputs(result, tmp_path, ("urdf", "yaml"), html=False)
    names = [p.name for p in done.files]
    assert names == ["irb120_calibrated.urdf", "irb120_joint_origins.yaml", "irb120_calibration.json", "report.json"]
    assert done.refused is None and done.removed == [stale] and not stale.exists()
    report = json.loads((tmp_path / "report.json").read_text())
    assert report == done.report
    assert report["urdf"] == str(tmp_path / "irb120_calibrated.urdf") and report["urdf_refused"] is None
    assert report["exports"]["yaml"] == str(tmp_path / "irb120_joint_origins.yaml")
    # The files are the result's: the calibration file reads back as the calibrated robot.
    back = load_calibration(tmp_path / "irb120_calibration.json")
    q = session[0].q[:5]
    assert len(back.forward(q)) == 5 and back.chain.name == "irb120"
    assert report["test"]["after"]["rmse_mm"] == pytest.approx(result.metrics["test"]["after"].rmse_mm)


def test_report_json_holds_each_list_of_values_on_one_line(result, tmp_path):
    """report.json's per-row lists are one line each (export/json_text): its lines do not grow
    with the rows, where one number a line gave several per row (about 4 000 lines here)."""
    done = cp.write_outputs(result, tmp_path, html=False)
    lines = (tmp_path / "report.json").read_text().splitlines()
    assert len(json.dumps(done.report, indent=2).splitlines()) > 3000
    assert len(lines) < 1000
    assert sum(line.lstrip().startswith('"after_mm": [') for line in lines) == 1
    assert lines[0] == "{" and lines[1].startswith('  "')  # the structure still indented


def test_a_fit_beyond_the_sanity_bound_writes_the_report_only(result, tmp_path, monkeypatch):
    cp.write_outputs(result, tmp_path, html=False)  # an earlier, good run
    monkeypatch.setattr(CalibrationResult, "sanity_error", lambda self: "d_2 = 2 m: the data cannot support it")
    done = cp.write_outputs(result, tmp_path, html=False)
    assert [p.name for p in done.files] == ["report.json"]
    assert done.refused == done.report["urdf_refused"] == "d_2 = 2 m: the data cannot support it"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]  # no stale URDF beside the refusal
    assert json.loads((tmp_path / "report.json").read_text())["urdf"] is None


def test_an_input_is_never_an_output_nor_removed(result, tmp_path):
    data = tmp_path / "irb120_calibrated.urdf"  # a caller's input under an output's name
    data.write_text("input\n")
    with pytest.raises(cp.OutputError, match="is an input"):
        cp.write_outputs(result, tmp_path, html=False, inputs={"--data": data})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["irb120_calibrated.urdf"]  # nothing written
    kept = tmp_path / "irb120_joint_origins.yaml"  # an input a run does not write: not removed as stale
    kept.write_text("input\n")
    done = cp.write_outputs(result, tmp_path / ".", ("dh",), html=False, inputs={"--data": kept})
    assert kept.read_text() == "input\n" and done.removed == [data]


def test_rendered_outputs_are_json_and_refuse_an_unknown_format(result):
    rendered = render_outputs(result, ("urdf",), html=False)
    assert json.loads(json.dumps(rendered.files)) == rendered.files  # what a batch checkpoint keeps
    assert list(rendered.files) == ["irb120_calibrated.urdf", "irb120_calibration.json"]
    with pytest.raises(cp.CalibPinError, match="unknown export format 'stl'"):
        render_outputs(result, ("stl",), html=False)


def test_the_planned_files_are_the_files_written(result, tmp_path):
    from calib_pin.report.bundle import planned_files

    done = cp.write_outputs(result, tmp_path, "urdf,dh", html=False)
    assert planned_files(result, "urdf,dh", html=False) == [p.name for p in done.files]


def test_calibrate_names_an_earlier_runs_files_it_removes(tmp_path, capsys):
    """A run into the folder of an earlier one whose exports it does not write (rbf: no kinematics) removes them
    and says so in one note on stderr, naming the files."""
    from calib_pin.cli import command

    out = str(tmp_path / "out")
    assert command("calibrate")(["irb120", "--method", "lm", "--no-html", "--out", out]) == 0
    capsys.readouterr()
    assert command("calibrate")(["irb120", "--method", "rbf", "--no-html", "--out", out]) == 0
    err = capsys.readouterr().err
    assert "note: removed 2 file(s) an earlier run wrote in" in err and "irb120_calibrated.urdf" in err
    assert not (tmp_path / "out" / "irb120_calibrated.urdf").exists()

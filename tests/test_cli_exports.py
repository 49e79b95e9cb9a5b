"""calibrate.py's outputs beyond report.json: report.html, --no-html, --export formats."""

import json
import tomllib

import pytest
import yaml

from calib_pin.cli.calibrate import calibrate_main
from calib_pin.exceptions import CalibPinError


def _exit_code(argv) -> int:
    try:
        return calibrate_main(argv)
    except SystemExit as e:  # argparse
        return int(e.code or 0)


def test_report_html_beside_report_json_and_no_html(tmp_path, capsys):
    assert calibrate_main(["irb120", "--method", "lm", "--out", str(tmp_path)]) == 0
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    report = json.loads((tmp_path / "report.json").read_text())
    assert f"{report['test']['after']['rmse_mm']:.4g}" in page and page.count("<img ") == 6
    assert f"wrote {tmp_path / 'report.html'}" in capsys.readouterr().out
    assert calibrate_main(["irb120", "--method", "lm", "--out", str(tmp_path), "--no-html"]) == 0
    assert not (tmp_path / "report.html").exists()  # the earlier run's page is not left beside the new JSON
    assert "report.html" not in capsys.readouterr().out


def test_without_matplotlib_a_warning_and_no_html(tmp_path, capsys, monkeypatch):
    def missing(module):
        raise CalibPinError(f"this needs the optional package '{module}': pip install 'calib-pin[plots]'")

    monkeypatch.setattr("calib_pin.util.optional.require", missing)
    assert calibrate_main(["irb120", "--method", "lm", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'calib-pin[plots]'" in err[0] and err[0].startswith("warning: no report.html")
    assert (tmp_path / "report.json").is_file() and not (tmp_path / "report.html").exists()


def test_export_yaml_and_dh(tmp_path, capsys):
    assert calibrate_main(["irb120", "--method", "lm", "--model", "hayati", "--out", str(tmp_path),
                           "--export", "yaml,dh", "--no-html"]) == 0
    out = capsys.readouterr().out
    origins = yaml.safe_load((tmp_path / "irb120_joint_origins.yaml").read_text())
    assert set(origins["joint_1"]) == {"x", "y", "z", "roll", "pitch", "yaw"}
    table = tomllib.loads((tmp_path / "irb120_dh.toml").read_text())["dh"]
    assert len(table["a_mm"]) == 6 and "beta_deg" in table
    assert not (tmp_path / "irb120_calibrated.urdf").exists()  # urdf only when asked for
    for name in ("irb120_joint_origins.yaml", "irb120_dh.toml", "report.json"):
        assert f"wrote {tmp_path / name}" in out
    report = json.loads((tmp_path / "report.json").read_text())
    assert set(report["exports"]) == {"yaml", "dh"} and report["urdf"] is None


@pytest.mark.parametrize(("args", "message"), [
    (["--export", "urdf,sdf"], "unknown export format 'sdf' (valid: urdf, yaml, dh"),
    (["--export", "dh", "--model", "placement"], "the placement model has no DH table"),
])
def test_export_refusals_one_line_nothing_written(tmp_path, capsys, args, message):
    assert _exit_code(["irb120", "--method", "lm", "--out", str(tmp_path / "o"), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not (tmp_path / "o").exists()


def test_an_end_frame_no_urdf_can_hold_is_refused_before_the_fit(tmp_path, capsys, monkeypatch):
    """calibrate and batch at an end frame that is the last joint's own link refuse before
    any fit (it was refused at the export, after it), and write nothing."""
    from pathlib import Path

    import calib_pin.calibration.solve as solve_module
    from calib_pin.cli import command

    def no_fit(*args, **kwargs):
        raise AssertionError("fitted before the refusal")

    monkeypatch.setattr(solve_module, "solve", no_fit)
    shipped = (Path(__file__).resolve().parent.parent / "robots" / "irb120_default.csv").read_text()
    data = tmp_path / "l6.csv"
    data.write_text(shipped.replace("# end_frame: tool0", "# end_frame: link_6"))
    assert _exit_code(["irb120", "--data", str(data), "--method", "lm", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "end frame 'link_6' is the link of joint 'joint_6'" in err[0]
    assert not (tmp_path / "o").exists()
    assert command("batch")([str(data), "--out", str(tmp_path / "b")]) == 2
    assert "l6: end frame 'link_6' is the link of joint 'joint_6'" in capsys.readouterr().err

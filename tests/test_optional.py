"""Figures are optional: a bad MPLBACKEND, a broken matplotlib or a failed drawing costs
report.html (one warning line), never the calibration."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import calib_pin
from calib_pin.cli.calibrate import calibrate_main
from calib_pin.util.optional import figures_or_warn

ROOT = Path(__file__).resolve().parent.parent
#: A small, quick calibration (the shipped cable set, LM).
ARGS = ["irb120", "--method", "lm"]


def _written(out: Path) -> None:
    assert (out / "report.json").is_file() and (out / "irb120_calibrated.urdf").is_file()
    assert (out / "irb120_calibration.json").is_file()
    assert json.loads((out / "report.json").read_text())["robot"] == "irb120"


def test_bad_mplbackend_still_writes_everything(tmp_path):
    """MPLBACKEND=nonsense (matplotlib refuses it at import): calib-pin draws with Agg,
    says so in one line, and writes every output including report.html."""
    out = tmp_path / "o"
    env = {**os.environ, "MPLBACKEND": "nonsense"}
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "calibrate.py"), *ARGS, "--out", str(out)],
                         capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    warnings = [line for line in run.stderr.splitlines() if line.startswith("warning")]
    assert len(warnings) == 1 and "MPLBACKEND" in warnings[0] and "nonsense" in warnings[0], run.stderr
    _written(out)
    assert (out / "report.html").is_file()


def test_broken_matplotlib_import_still_writes_the_calibration(tmp_path, monkeypatch, capfd):
    """An ImportError inside matplotlib: one warning line, no report.html, the rest written."""
    monkeypatch.setitem(sys.modules, "matplotlib.backends.backend_agg", None)  # import fails
    monkeypatch.delitem(sys.modules, "calib_pin.report.figures", raising=False)
    monkeypatch.delattr(calib_pin.report, "figures", raising=False)  # imported anew, so it fails
    out = tmp_path / "o"
    assert calibrate_main([*ARGS, "--out", str(out)]) == 0
    err = capfd.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("warning: no report.html") and "matplotlib" in lines[0], err
    _written(out)
    assert not (out / "report.html").exists()


def test_failure_while_drawing_still_writes_the_calibration(tmp_path, monkeypatch, capfd):
    """An exception inside a figure: one warning line naming it, the rest written."""
    from calib_pin.report import figures as report_figures

    def broken(report):
        raise RuntimeError("font cache is corrupt")

    monkeypatch.setattr(report_figures, "residuals", broken)
    out = tmp_path / "o"
    assert calibrate_main([*ARGS, "--out", str(out)]) == 0
    lines = [line for line in capfd.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1 and "font cache is corrupt" in lines[0], lines
    _written(out)
    assert not (out / "report.html").exists()


def test_figures_or_warn(capsys):
    """The shared helper: the drawing's value, or None after one line; Ctrl-C is not swallowed."""
    assert figures_or_warn("x.png", lambda: b"png") == b"png"
    assert figures_or_warn("x.png", lambda: 1 / 0) is None
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("warning: no x.png:") and "ZeroDivisionError" in err[0]

    def interrupted():
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        figures_or_warn("x.png", interrupted)

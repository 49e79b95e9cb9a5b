"""Command line: the main job, its outputs, and one-line errors with exit 2."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from calib_pin.cli.calibrate import calibrate_main
from calib_pin.cli.compare import compare_main
from calib_pin.cli.simulate import simulate_main

ROOT = Path(__file__).resolve().parent.parent


def test_calibrate_writes_urdf_and_report(tmp_path, capsys):
    """calibrate.py irb120 on the shipped data prints the table and writes both files."""
    assert calibrate_main(["irb120", "--no-html", "--out", str(tmp_path), "--method", "lm", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "train before" in out and "test after" in out and "wrote" in out
    report = json.loads((tmp_path / "report.json").read_text())
    for split in ("train", "test"):
        for stage in ("before", "after"):
            assert set(report[split][stage]) == {"rmse_mm", "mean_mm", "max_mm"}
    assert report["method"] == "lm" and report["time_s"] > 0 and report["iterations"] >= 1
    assert "theta_6_deg" in report["deviations"] and len(report["anchor_mm"]) == 3
    assert "length_offset_mm" in report
    assert len(report["split"]["train"]) == 96 and len(report["split"]["test"]) == 24
    assert report["test"]["after"]["rmse_mm"] < 0.2 * report["test"]["before"]["rmse_mm"]
    assert (tmp_path / "irb120_calibrated.urdf").is_file()
    ident = report["identifiability"]
    assert ident["rank"] == 20 and ident["unidentifiable"] == ["theta_6"]
    assert "d_2 +1 mm with d_3 -1 mm" in ident["combinations"]
    assert abs(report["deviations"]["theta_6_deg"]) < 1e-3  # blind: at zero along the direction no reading sees
    assert "not determined (held at zero): theta_6" in out and "accuracy where the robot works" in out
    assert report["uncertainty"]["parameters"]["theta_6_deg"]["status"] == "not determined"


def test_simulate_then_calibrate(tmp_path, capsys):
    """simulate.py writes a set and its truth file, which calibrate.py then reads."""
    csv = tmp_path / "s.csv"
    assert simulate_main(["irb120", "--poses", "60", "--seed", "1", "--out", str(csv)]) == 0
    assert (tmp_path / "s.truth.json").is_file()
    assert calibrate_main(["irb120", "--no-html", "--data", str(csv), "--out", str(tmp_path / "o"), "--method", "ekf"]) == 0


def _run(*args, script="calibrate.py"):
    return subprocess.run(
        [sys.executable, str(ROOT / "scripts" / script), *args],
        capture_output=True, text=True, cwd=ROOT,
    )


@pytest.mark.parametrize(
    "args, message",
    [
        (["irb120", "--method", "gauss"], "unknown method 'gauss' (valid: ekf, bas, ukf, pso, rbf, lm, de, qibas, ekf-qibas, lm+rbf)"),
        (["nosuchbot"], "unknown robot 'nosuchbot'"),
        (["irb120", "--data", "missing.csv"], "missing.csv: no such file"),
        (["irb120", "--test-fraction", "1.5"], "expected a number in [0, 1)"),
        (["irb120", "--anchor-mm", "1,2"], "expected 3 numbers"),
        (["ur5", "--model", "dh"], "robot 'ur5' has no DH table for the 'dh' model"),
        (["ur5"], "robot 'ur5' has no default measurement set"),
        (["irb120", "--model", "mdh"], "invalid choice: 'mdh'"),
        (["irb120", "--estimate", "anchor,hook"], "cannot estimate 'hook'"),
        (["irb120", "--seed", "-1"], "expected a non-negative int, got '-1'"),
        (["irb120", "--length-offset-mm", "nan"], "expected a finite number, got 'nan'"),
        # the library's ArgumentError named by the flag that gave it
        (["irb120", "--method", "lm", "--cv", "500"], "argument --cv: 500 folds for 96 training poses: give 2 to 96"),
        (["irb120", "--method", "ekf_qibas"], "argument --method: unknown method 'ekf_qibas': did you mean ekf-qibas?"),
        (["ur5", "--method", "lm"], "argument --data: robot 'ur5' has no default measurement set: give one"),
        (["irb120", "--method", "lm", "--test-data", str(ROOT / "robots" / "irb120_wu2015.csv"), "--test-fraction", "0.5"],
         "argument --test-fraction: 0.5 beside a separate validation session"),
        (["irb120", "--data", str(ROOT / "robots" / "irb120_wu2015.csv"), "--anchor-mm", "600,200,-100"],
         f"error: --anchor-mm is for drawstring data; {ROOT / 'robots' / 'irb120_wu2015.csv'} holds positions"),
    ],
)
def test_bad_input_one_line_exit_2(args, message, tmp_path, capsys):
    """Bad input: exit 2, one line on stderr, nothing written."""
    assert _exit_code(calibrate_main, [*args, "--out", str(tmp_path / "o")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0]
    assert not (tmp_path / "o").exists()


def _exit_code(main, argv) -> int:
    """A command's exit status, whether it returns it or argparse exits."""
    try:
        return main(argv)
    except SystemExit as stop:
        return stop.code


@pytest.mark.parametrize(
    "args, message",
    [
        (["irb120", "--poses", "0"], "expected a whole number from 1 to"),
        (["nosuchbot"], "unknown robot 'nosuchbot'"),
        (["panda"], "no frame 'tool0'"),
        (["irb120", "--noise-mm", "-1"], "expected a non-negative float"),
        (["irb120", "--length-offset-mm", "inf"], "expected a finite number"),
    ],
)
def test_simulate_bad_input(tmp_path, capsys, args, message):
    """simulate.py: bad input gives exit 2 and one line on stderr."""
    code = _exit_code(simulate_main, [*args, "--out", str(tmp_path / "s.csv")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and message in err[0]
    assert not (tmp_path / "s.csv").exists()


def test_bad_csv_row_one_line(tmp_path):
    """A bad value in the data file: its file, line and field in one line."""
    lines = (ROOT / "robots" / "irb120_default.csv").read_text().splitlines()
    assert lines[10][0].isdigit() or lines[10][0] == "-"  # line 11 is a data row
    lines[10] = "abc" + lines[10][lines[10].index(","):]
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    proc = _run("irb120", "--data", str(bad), "--out", str(tmp_path))
    assert proc.returncode == 2
    assert proc.stderr.strip() == f"error: {bad}:11: q1_deg: 'abc' is not a number"


def test_calibrate_rbf_writes_report_but_no_urdf(tmp_path, capsys):
    """rbf learns no kinematic parameters: the report is written, the URDF is not, and it says so."""
    assert calibrate_main(["irb120", "--no-html", "--method", "rbf", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "no URDF written: rbf learns a correction" in out
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["kinematic_parameters"] is False and report["urdf"] is None
    assert not list(tmp_path.glob("*.urdf"))


def test_compare_writes_tables_and_figures(tmp_path, capsys):
    """compare.py prints Table I and writes table1.csv, table1.md and the two figures."""
    args = ["irb120", "--simulate", "outliers", "--poses", "40", "--methods", "lm,rbf", "--out", str(tmp_path)]
    assert compare_main(args) == 0
    out = capsys.readouterr().out
    assert "Before" in out and "M6" in out and "outliers noise" in out
    for name in ("table1.csv", "table1.md", "fig2_residuals.png", "fig3_convergence.png"):
        assert (tmp_path / name).is_file(), name
    assert "python scripts/compare.py irb120 --simulate outliers" in (tmp_path / "table1.md").read_text()


@pytest.mark.parametrize(
    "args, message",
    [
        (["irb120", "--methods", "lm,nope"], "unknown method 'nope' (valid: ekf, bas"),
        (["irb120", "--methods", "lm,,ekf"], "empty method name in 'lm,,ekf'"),
        (["irb120", "--simulate", "gauss", "--scheduler", "http://127.0.0.1:8786"],
         "'http://127.0.0.1:8786' is not a Dask scheduler address"),
        (["irb120", "--trials", "0"], "expected a whole number from 1 to 100000, got '0'"),
        (["irb120", "--simulate", "pink"], "invalid choice: 'pink'"),
        (["irb120", "--data", "missing.csv"], "missing.csv: no such file"),
        (["irb120", "--data", "x.csv", "--simulate", "gauss"], "either --data or --simulate"),
    ],
)
def test_compare_bad_input_one_line_exit_2(args, message, tmp_path, capsys):
    assert _exit_code(compare_main, [*args, "--out", str(tmp_path / "o")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0]
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("script", ["calibrate.py", "compare.py"])
def test_scripts_exit_2_without_traceback(script):
    """The scripts themselves: a user's mistake is one line on stderr and exit 2."""
    proc = _run("irb120", "--data", "missing.csv", script=script)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines() == ["error: missing.csv: no such file"]


def test_analyze_prints_report_and_estimates_nothing(tmp_path, capsys):
    assert calibrate_main(["irb120", "--analyze", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "rank 20 of 24" in out and "d_2 +1 mm with d_3 -1 mm" in out and "base parameter set" in out
    assert not (tmp_path / "o").exists()


def test_runaway_deviation_exit_2_report_kept(tmp_path, capsys):
    """Data that asks for deviations of tens of mm: exit 2 naming the parameter; the report
    is kept, no URDF is written."""
    csv = tmp_path / "wild.csv"
    assert simulate_main(["irb120", "--poses", "60", "--seed", "1", "--nominal-rmse-mm", "300",
                          "--out", str(csv)]) == 0
    code = calibrate_main(["irb120", "--no-html", "--data", str(csv), "--method", "lm", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "is beyond the sanity bound" in err[0]
    assert (tmp_path / "o" / "report.json").is_file() and not list((tmp_path / "o").glob("*.urdf"))


def test_a_refused_fit_prints_its_table_then_the_set_that_misfits(tmp_path, capsys):
    """Two sessions, the second's anchor 100 mm off in its file: the fit runs away beyond
    the sanity bound. The table of what was computed is printed (it was not), then the one
    refusal line, which names the set the start misses most (it named none); exit 2."""
    lines = (ROOT / "robots" / "irb120_default.csv").read_text().splitlines()
    meta, head, rows = lines[:6], lines[6], lines[7:]
    (tmp_path / "a.csv").write_text("\n".join([*meta, head, *rows[:40]]) + "\n")
    moved = [meta[0], meta[1], meta[2].replace("-100.000000", "-200.000000"), *meta[3:]]
    (tmp_path / "b.csv").write_text("\n".join([*moved, head, *rows[60:100]]) + "\n")
    code = calibrate_main(["irb120", "--data", str(tmp_path / "a.csv"), "--data", str(tmp_path / "b.csv"), "--method",
                           "lm", "--no-html", "--out", str(tmp_path / "o")])
    out, err = capsys.readouterr()
    err_lines = [line for line in err.strip().splitlines() if not line.startswith(("warning: ", "note: "))]
    assert code == 2 and len(err_lines) == 1 and "is beyond the sanity bound" in err_lines[0]
    assert "set b misfits most: the start misses its training rows by 71.3 mm RMS (the other sets: a 1.8" in err_lines[0]
    assert "set a: 40 rows" in out and "set b: 40 rows" in out and "train after" in out and "deviations:" in out
    assert "wrote" not in out


def test_models_and_sensor_unknowns_from_the_command_line(tmp_path, capsys):
    """--model hayati and --estimate anchor,offset reach the report and the analysis."""
    out = tmp_path / "o"
    assert calibrate_main(["irb120", "--no-html", "--model", "hayati", "--estimate", "anchor,offset", "--method", "lm",
                           "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "hayati model" in text and "sensor geometry estimated: anchor_x_mm" in text
    report = json.loads((out / "report.json").read_text())
    assert report["model"] == "hayati" and "beta_2_deg" in report["deviations"]
    assert set(report["sensor_corrections"]) == {"anchor_x_mm", "anchor_y_mm", "anchor_z_mm", "offset_mm"}
    assert calibrate_main(["irb120", "--analyze", "--estimate", "anchor", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "dh model, drawstring sensor, offset known, anchor estimated" in text
    assert "d_1 +1 mm with anchor_z +1 mm" in text


def test_simulate_with_a_model_then_calibrate_it(tmp_path, capsys):
    csv = tmp_path / "h.csv"
    assert simulate_main(["ur5", "--model", "placement", "--poses", "60", "--out", str(csv)]) == 0
    assert "joint-placement deviations" in capsys.readouterr().out
    assert calibrate_main(["ur5", "--no-html", "--data", str(csv), "--method", "lm", "--out", str(tmp_path / "o")]) == 0
    assert "placement model" in capsys.readouterr().out


def test_every_command_runs_blas_on_one_thread():
    """The thread limit covers the libraries loaded after the command starts too (scipy's
    own OpenBLAS, Pinocchio's OpenMP), not only those loaded before."""
    code = ("from calib_pin.cli import command; command('calibrate'); "
            "import scipy.linalg, scipy.optimize, pinocchio; from calib_pin.estimators import ekf; "
            "from threadpoolctl import threadpool_info; print(max(i['num_threads'] for i in threadpool_info()))")
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.strip() == "1"


def test_the_thread_limit_before_any_blas_loads_is_the_environment_alone():
    """Limited before numpy loads, the pools read the environment (threadpoolctl is not
    imported); limited again after a caller changed them, threadpoolctl sets them back."""
    code = ("import sys; from calib_pin.cli import limit_blas_threads; limit_blas_threads(); "
            "import numpy, scipy.linalg, pinocchio; before = 'threadpoolctl' in sys.modules; limit_blas_threads(); "
            "from threadpoolctl import threadpool_info, threadpool_limits; first = max(i['num_threads'] for i in "
            "threadpool_info()); threadpool_limits(2); limit_blas_threads(); "
            "print(before, first, max(i['num_threads'] for i in threadpool_info()))")
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.split() == ["False", "1", "1"]


def test_ctrl_c_while_a_command_loads_or_parses_is_one_line(monkeypatch, capsys):
    """Ctrl-C in the half second the libraries load, or while the options are parsed,
    once printed a 30-line traceback: it is one line and exit 130 (the interrupt is raised
    where a real one lands: inside the import, inside argparse)."""
    import argparse
    import importlib

    import calib_pin.cli as cli

    real = importlib.import_module

    def interrupted_import(name, *args):
        if name.startswith("calib_pin.cli."):
            raise KeyboardInterrupt
        return real(name, *args)

    monkeypatch.setattr(cli.importlib, "import_module", interrupted_import)
    assert cli.main(["calibrate", "irb120"]) == 130
    monkeypatch.setattr(cli.importlib, "import_module", real)

    def interrupted_parse(self, *args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(argparse.ArgumentParser, "parse_known_args", interrupted_parse)
    assert cli.command("make-poses")(["irb120"]) == 130
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert err == ["stopped by Ctrl-C: nothing was written"] * 2, err


@pytest.mark.parametrize("name", sorted(__import__("calib_pin.cli", fromlist=["COMMANDS"]).COMMANDS))
def test_every_help_names_the_calib_pin_command(name, capsys):
    """``--help`` shows ``calib-pin <command>`` (the scripts/*.py wrappers run the same parser)."""
    from calib_pin.cli import command

    with pytest.raises(SystemExit) as done:
        command(name)(["--help"])
    assert done.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: calib-pin {name} ")


def _with_temperature(text: str) -> str:
    """A measurement set with a temp_C column after its others (ignored, with a warning)."""
    lines = text.splitlines()
    head = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    return "\n".join([*lines[:head], lines[head] + ",temp_C", *(line + ",21.5" for line in lines[head + 1:])]) + "\n"


@pytest.mark.parametrize("analyze", [False, True], ids=["calibrate", "analyze"])
def test_warnings_go_to_stderr_and_stdout_keeps_the_results(tmp_path, capsys, analyze):
    """An ignored column is a warning line on stderr, for a calibration and for --analyze;
    stdout, which scripts parse, holds no warning or note."""
    data = tmp_path / "d.csv"
    data.write_text(_with_temperature((ROOT / "robots" / "irb120_default.csv").read_text()))
    tail = ["--analyze"] if analyze else ["--method", "lm", "--no-html", "--out", str(tmp_path / "out")]
    assert calibrate_main(["irb120", "--data", str(data), *tail]) == 0
    printed = capsys.readouterr()
    assert "warning: ignored columns: temp_C (in d.csv; read and kept, not used)" in printed.err.splitlines()
    assert not [line for line in printed.out.splitlines() if line.startswith(("warning:", "note:"))], printed.out
    assert ("rank" if analyze else "test after") in printed.out


def test_no_command_prints_a_warning_or_note_on_stdout():
    """Every 'warning:' or 'note:' line of the commands goes through cli.common.warn (stderr):
    none is printed to stdout."""
    import re

    found = []
    for path in sorted((ROOT / "calib_pin" / "cli").glob("*.py")):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if re.search(r"""print\(f?["'](warning|note):""", line) and "sys.stderr" not in line:
                found.append(f"{path.name}:{number}")
    assert not found


def test_calibrate_looks_its_method_up_once(tmp_path, monkeypatch):
    """calibrate hands solve the record it checked before reading the data: one lookup."""
    import calib_pin.calibration.solve as solve_module

    looked = []
    get_method = solve_module.get_method
    monkeypatch.setattr(solve_module, "get_method", lambda name: looked.append(name) or get_method(name))
    assert calibrate_main(["irb120", "--method", "ukf", "--no-html", "--out", str(tmp_path / "o")]) == 0
    assert looked == ["ukf"]

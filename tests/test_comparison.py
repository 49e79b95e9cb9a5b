"""The comparison runs methods on one split, aggregates trials and writes Table I."""

import csv

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.studies.comparison_figures import convergence_figure, residual_figure


@pytest.fixture(scope="module")
def tiny():
    """Two simulated trials of 40 poses, two fast methods (one iterative, rbf)."""
    return cp.compare("irb120", methods=["lm", "rbf"], trials=2, simulate_noise="gauss", poses=40, seed=3)


def test_trials_share_split_and_know_the_truth(tiny):
    """Each trial scores every method on the same held-out rows and against the truth."""
    assert [t.seed for t in tiny.trials] == [3, 4]
    for trial in tiny.trials:
        n_test = len(trial.before_residual_mm)
        assert n_test == 8
        assert all(len(r.test_residual_mm) == n_test for r in trial.runs.values())
        assert trial.before.rmse_mm > 1.0 and trial.runs["lm"].test.rmse_mm < 0.2
        assert trial.runs["lm"].fresh_rmse_mm < 0.2 and trial.before_fresh_rmse_mm > 1.0


def test_rows_aggregate_mean_and_sd(tiny):
    """Rows are Before then the methods with their paper label; values are mean and sd."""
    rows = tiny.rows()
    assert [r["item"] for r in rows] == ["Before", "M6", "M5"]
    values = [t.runs["lm"].test.rmse_mm for t in tiny.trials]
    assert rows[1]["rmse_mm"] == pytest.approx((np.mean(values), np.std(values)))
    assert rows[0]["time_s"] is None and rows[1]["time_s"][0] > 0


def test_table_writers(tiny, tmp_path):
    """table1.csv has mean/sd columns and the paper's numbers; table1.md shows mean ± sd."""
    tiny.write_csv(tmp_path / "table1.csv")
    with (tmp_path / "table1.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [r["item"] for r in rows] == ["Before", "M6", "M5"]
    assert float(rows[1]["rmse_mm_mean"]) == pytest.approx(tiny.rows()[1]["rmse_mm"][0], rel=1e-5)
    assert rows[1]["paper_rmse_mm"] == "0.5" and rows[0]["trials"] == "2"
    assert rows[0]["time_s_mean"] == ""
    md = tiny.write_markdown(tmp_path / "table1.md", "python scripts/compare.py irb120").read_text()
    assert "| M6 | lm |" in md and "±" in md and "| 2.09 | 2.00 | 3.36 |" in md
    assert "Command: `python scripts/compare.py irb120`" in md
    text = tiny.format_table()
    assert "Before" in text and "±" in text


def test_figures_are_png(tiny, tmp_path):
    """Fig. 2 and Fig. 3 are written as PNG files."""
    for draw, name in ((residual_figure, "fig2.png"), (convergence_figure, "fig3.png")):
        path = draw(tiny, tmp_path / name)
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000


def test_convergence_figure_of_a_method_at_the_optimum(tiny, tmp_path):
    """A method that starts at the optimum (0 iterations) is drawn as its one point, in the
    legend, without matplotlib's "no artists with labels" warning; with no iterative method
    at all the panels say so."""
    import dataclasses
    import warnings

    trial = tiny.trials[0]
    start = trial.runs["lm"].history_mm[:1]
    at_optimum = dataclasses.replace(trial.runs["lm"], iterations=0, history_mm=start, history_evaluations=[1.0])
    for runs in ({"lm": at_optimum, "rbf": trial.runs["rbf"]}, {"rbf": trial.runs["rbf"]}):
        trials = [dataclasses.replace(t, runs=runs) for t in tiny.trials]
        comparison = dataclasses.replace(tiny, trials=trials, methods=list(runs))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            path = convergence_figure(comparison, tmp_path / f"fig3_{len(runs)}.png")
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_shipped_set_uses_its_truth_file():
    """On the shipped set, the truth file next to it gives the fresh-pose column."""
    result = cp.compare("irb120", methods=["lm"])
    trial = result.trials[0]
    assert trial.before_fresh_rmse_mm > 1.0 and trial.runs["lm"].fresh_rmse_mm < 0.06


def test_bad_settings():
    with pytest.raises(cp.ArgumentError, match="argument methods: unknown method 'nope'"):
        cp.compare("irb120", methods=["nope"])
    with pytest.raises(cp.CalibPinError, match="trials must be at least 1"):
        cp.compare("irb120", methods=["lm"], trials=0)
    with pytest.raises(cp.CalibPinError, match="unknown noise kind 'pink'"):
        cp.compare("irb120", methods=["lm"], simulate_noise="pink")


def _compare_cli(tmp_path, env_extra=None, limit_bytes=None):
    """``calib-pin compare`` on 30 simulated poses with lm into tmp_path/out, started in a subprocess."""
    import os
    import resource
    import signal
    import subprocess
    import sys

    def full_disk():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    tmp_path.mkdir()
    env = {**os.environ, **(env_extra or {})}
    return subprocess.Popen([sys.executable, "-c", "import sys; from calib_pin.cli import main; sys.exit(main(sys.argv[1:]))",
                             "compare", "irb120", "--simulate", "gauss", "--poses", "30", "--methods", "lm", "--out", "out"],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=full_disk if limit_bytes else None)


def test_compare_writes_all_outputs_or_none_and_the_figures_are_optional(tmp_path):
    """A full disk with room for the tables but not the figures: nothing is written (the
    trial is kept for the rerun). A broken matplotlib: one warning, the tables. A bad
    MPLBACKEND: one warning, and the figures drawn off-screen."""
    fake = tmp_path / "fake"
    (fake / "matplotlib").mkdir(parents=True)
    (fake / "matplotlib" / "__init__.py").write_text("raise ImportError('a broken matplotlib')\n")
    full = _compare_cli(tmp_path / "full", limit_bytes=20_000)
    broken = _compare_cli(tmp_path / "broken", env_extra={"PYTHONPATH": str(fake)})
    backend = _compare_cli(tmp_path / "backend", env_extra={"MPLBACKEND": "nonsense"})
    results = {}
    for name, proc in (("full", full), ("broken", broken), ("backend", backend)):
        _, err = proc.communicate(timeout=60)
        results[name] = proc.returncode, [line for line in err.splitlines() if line.strip()], err
    tables = ["table1.csv", "table1.md"]

    code, lines, err = results["full"]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert "File too large" in lines[0] and "1 of 1 trial(s) kept in out; run the same command" in lines[0], err
    assert [p.name for p in (tmp_path / "full" / "out").iterdir()] == [".calib-pin-checkpoint"]

    code, lines, err = results["broken"]
    assert code == 0 and len(lines) == 1 and lines[0].startswith("warning: no figures") and "broken" in lines[0], err
    assert sorted(p.name for p in (tmp_path / "broken" / "out").iterdir()) == tables

    code, lines, err = results["backend"]
    assert code == 0 and len(lines) == 1 and "MPLBACKEND='nonsense'" in lines[0], err
    assert sorted(p.name for p in (tmp_path / "backend" / "out").iterdir()) == \
        ["fig2_residuals.png", "fig3_convergence.png", *tables]


def test_each_method_is_looked_up_and_checked_once(monkeypatch):
    """compare resolves each method's record once and hands the record to solve: one lookup
    per method (it was one more per check and per trial) and its loss checked by compare and
    by each trial's solve, nothing else."""
    from collections import Counter

    import calib_pin.estimators as estimators
    from calib_pin.estimators import Method

    looked, checked = Counter(), Counter()
    get_method, check = estimators.get_method, Method.check
    monkeypatch.setattr(estimators, "get_method", lambda name: looked.update([name]) or get_method(name))
    monkeypatch.setattr(Method, "check", lambda self, loss="linear": checked.update([self.name]) or check(self, loss))
    monkeypatch.setattr("calib_pin.calibration.solve.get_method", estimators.get_method)
    cp.compare("irb120", methods=["ekf", "ukf"], trials=2, simulate_noise="gauss", poses=40, seed=3)
    assert looked["ekf"] == looked["ukf"] == 1, looked
    assert checked["ekf"] == checked["ukf"] == 1 + 2, checked

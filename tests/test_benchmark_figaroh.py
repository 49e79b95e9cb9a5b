"""benchmark.py --against figaroh: the skip line without FIGAROH, the race with it."""

from __future__ import annotations

import builtins

import pytest

from calib_pin.cli.benchmark import _against_figaroh, benchmark_parser
from calib_pin.studies import benchmark_figaroh


@pytest.fixture
def no_figaroh(monkeypatch):
    """Make ``import figaroh`` fail as when it is not installed."""
    real = builtins.__import__

    def fake(name, *args, **kwargs):
        if name == "figaroh" or name.startswith("figaroh."):
            raise ImportError(f"No module named '{name}'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake)


def test_absent_figaroh_returns_none(no_figaroh):
    assert benchmark_figaroh.against_figaroh(["lm"], repeats=1) is None


def test_absent_figaroh_prints_one_skip_line(no_figaroh, capsys):
    args = benchmark_parser().parse_args(["--against", "figaroh", "--methods", "lm", "--repeats", "1"])
    _against_figaroh(args)
    out = capsys.readouterr().out
    assert out == "against figaroh: skipped, figaroh is not installed (pip install figaroh; not a dependency)\n"


def test_race_with_figaroh_scores_both_against_truth():
    pytest.importorskip("figaroh")
    structural, excitation = benchmark_figaroh.race(100, ["lm"], repeats=1, seed=0)
    assert (structural.selection, excitation.selection) == ("structural", "excitation")
    assert structural.calib_s > 0 and structural.figaroh_s > 0
    # both calibrate far below the nominal model's 2 mm error, calib-pin near the noise floor
    assert structural.calib_fresh_mm < 0.05
    assert structural.figaroh_fresh_mm < 0.5
    # selected on the measured poses, FIGAROH reaches calib-pin's least-squares fit
    assert excitation.figaroh_fresh_mm == pytest.approx(excitation.calib_fresh_mm, abs=1e-3)


def test_the_timed_calib_pin_run_fits_the_device_frame_every_time(device_fits):
    """The race times calib-pin from building the problem (its device-frame fit) through the
    estimate, as it says: the problem ``prepare`` kept is not reused (it was, until issue 24's
    fourth round, leaving the 2 ms fit out of every timed run)."""
    setup, _, _ = benchmark_figaroh.ur5_session(30, 0)  # prepare fitted it once
    device_fits.clear()
    for _ in range(2):
        benchmark_figaroh._calib_pin(setup, "lm", 0)
    assert device_fits == [30, 30]


def test_format_races_one_row_per_race():
    row = benchmark_figaroh.Race(100, "lm", "structural", 0.01, 0.5, 0.02, 0.02, 0.05, 0.06, 51, 25)
    text = benchmark_figaroh.format_races([row, row])
    assert len(text.splitlines()) == 3
    assert "50.0x" in text


def test_format_goal_judges_each_method_on_the_default_selection():
    def race(samples, method, selection, calib_s):
        return benchmark_figaroh.Race(samples, method, selection, calib_s, 1.0, 0.02, 0.02, 0.05, 0.06, 51, 25)

    rows = [race(100, "lm", "structural", 0.02), race(1000, "lm", "structural", 0.01),
            race(100, "ekf-qibas", "structural", 0.05), race(1000, "ekf-qibas", "structural", 0.02),
            race(100, "ekf-qibas", "excitation", 0.01)]  # not FIGAROH's default: not judged
    line = benchmark_figaroh.format_goal(rows)
    assert "lm 50.0x at 100, 100.0x at 1000 (met)" in line
    assert "ekf-qibas 20.0x at 100, 50.0x at 1000 (not met)" in line


def test_absent_figaroh_has_no_whole_process_race(no_figaroh):
    assert benchmark_figaroh.whole_processes(["lm"], repeats=1) is None


def test_format_processes_and_their_goals_at_the_largest_size():
    rows = [benchmark_figaroh.ProcessRace(100, "lm", 1.0, 5.0), benchmark_figaroh.ProcessRace(1000, "lm", 1.0, 25.0),
            benchmark_figaroh.ProcessRace(1000, "ekf-qibas", 2.0, 10.0)]
    text = benchmark_figaroh.format_processes(rows)
    assert len(text.splitlines()) == 4 and "25.0x" in text
    line = benchmark_figaroh.format_process_goal(rows)
    assert "lm 25.0x at 1000 (goal >= 20x, met)" in line
    assert "ekf-qibas 5.0x at 1000 (goal >= 10x, not met)" in line
    assert "at 100 " not in line


def test_the_ekf_qibas_stages_split_the_timed_run():
    """The stage line (printed under the race; no FIGAROH needed): the three stages timed, the
    QIBAS stage's iterations those of the whole EKF-QIBAS run's QIBAS stage."""
    import numpy as np

    from calib_pin.estimators import run_estimator

    stages, iterations = benchmark_figaroh.ekf_qibas_stages(samples=30, repeats=1)
    assert set(stages) == {"problem", "ekf", "qibas"} and all(v > 0 for v in stages.values())
    setup, _, _ = benchmark_figaroh.ur5_session(30, 0)
    problem = setup.problem_on(np.arange(30))
    whole = run_estimator("ekf-qibas", problem, np.zeros(problem.n_params), noise=setup.noise, history=False)
    assert iterations == whole.extras["stages"]["qibas"]
    line = benchmark_figaroh.format_stages(stages, iterations, 30)
    assert line.startswith("calib-pin's ekf-qibas at 30 samples by stage") and f"({iterations} iterations)" in line

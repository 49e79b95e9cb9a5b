"""Progress bars: silent off a terminal or when quiet, drawn on stderr on a terminal."""

import fcntl
import io
import os
import pty
import struct
import sys
import termios

import numpy as np
import pytest

from calib_pin.estimators import run_estimator
from calib_pin.util.progress import progress, progress_bar, quiet_progress


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_pipe_passes_items_through_silently(capsys):
    items = list(progress(range(5), desc="work"))
    captured = capsys.readouterr()
    assert items == [0, 1, 2, 3, 4]
    assert captured.out == "" and captured.err == ""


def test_quiet_on_a_terminal_draws_nothing():
    tty = _Tty()
    assert list(progress(iter("abc"), total=3, quiet=True, stream=tty)) == ["a", "b", "c"]
    assert tty.getvalue() == ""


def test_terminal_gets_a_bar_with_eta_and_stdout_stays_clean(capsys):
    tty = _Tty()
    assert list(progress(range(3), desc="trials", stream=tty)) == [0, 1, 2]
    drawn = tty.getvalue()
    assert "trials" in drawn and "/3 [" in drawn and "<" in drawn  # [elapsed<remaining
    assert capsys.readouterr().out == ""


def test_real_pseudo_terminal_is_recognised():
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # 100 columns
    try:
        term = io.TextIOWrapper(io.FileIO(slave, "w", closefd=False), write_through=True)
        assert list(progress([1, 2], desc="poses", stream=term)) == [1, 2]
        term.flush()
        os.set_blocking(master, False)
        assert b"poses" in os.read(master, 4096)
    finally:
        os.close(master)
        os.close(slave)


def test_quiet_progress_silences_every_bar_within():
    tty = _Tty()
    with quiet_progress():
        assert list(progress(range(2), stream=tty)) == [0, 1]
        with progress_bar(3, "x", stream=tty) as bar:
            assert bar is None
    assert tty.getvalue() == ""
    with progress_bar(3, "work", stream=tty) as bar:
        bar.update(3)
    assert "work" in tty.getvalue()


def test_pso_generations_bar_on_a_terminal_same_result(monkeypatch):
    import calib_pin

    problem = calib_pin.prepare("irb120").problem.subset(np.arange(40))
    x0 = np.zeros(problem.n_params)
    plain = run_estimator("pso", problem, x0, seed=1)  # stderr is no terminal under pytest
    tty = _Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    shown = run_estimator("pso", problem, x0, seed=1)
    assert "pso generations" in tty.getvalue() and "<" in tty.getvalue()
    np.testing.assert_array_equal(plain.x, shown.x)
    assert plain.history == shown.history


@pytest.mark.parametrize("quiet", [False, True])
def test_compare_bar_on_stderr_only_and_quiet(monkeypatch, tmp_path, capsys, quiet):
    from calib_pin.cli.compare import compare_main

    tty = _Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    argv = ["irb120", "--methods", "lm,ekf", "--trials", "2", "--out", str(tmp_path), *(["--quiet"] if quiet else [])]
    assert compare_main(argv) == 0
    out = capsys.readouterr().out
    assert "trials x methods" not in out and "it/s" not in out
    assert ("trials x methods" in tty.getvalue()) is not quiet

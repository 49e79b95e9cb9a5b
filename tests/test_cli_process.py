"""calib_pin.cli.process: a process's garbage-collector policy around a command."""

from __future__ import annotations

import gc
import subprocess
import sys
from pathlib import Path

import pytest

import calib_pin.cli as cli
from calib_pin.cli import process

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def recorded(monkeypatch: pytest.MonkeyPatch):
    """The collector's state while the (fake) command ran, and the freezes after it; the
    test process's own collector is put back as it was (no freeze of the test session)."""
    seen: dict[str, list] = {"enabled": [], "argv": [], "freezes": []}

    def fake_command(name: str):
        def main(argv):
            seen["enabled"].append(gc.isenabled())
            seen["argv"].append((name, list(argv)))
            if argv and argv[0] == "raise":
                raise RuntimeError("boom")
            return 7
        return main

    monkeypatch.setattr(cli, "command", fake_command)
    monkeypatch.setattr(process.gc, "freeze", lambda: seen["freezes"].append(gc.isenabled()))
    was = gc.isenabled()
    yield seen
    if was:
        gc.enable()


@pytest.mark.parametrize("name", sorted(process.ONE_PASS))
def test_a_one_pass_command_runs_with_the_collector_off_and_freezes_after(recorded, name):
    assert gc.isenabled()
    assert process.run_command(name, ["a", "b"]) == 7
    assert recorded["enabled"] == [False]
    assert recorded["argv"] == [(name, ["a", "b"])]
    assert len(recorded["freezes"]) == 1


@pytest.mark.parametrize("name", ["compare", "batch", "collect", "benchmark", "fake-indicator"])
def test_a_repeating_command_keeps_the_collector_on(recorded, name):
    assert process.run_command(name, []) == 7
    assert recorded["enabled"] == [True]
    assert len(recorded["freezes"]) == 1


def test_every_command_is_one_pass_or_repeating():
    assert set(cli.COMMANDS) >= process.ONE_PASS
    assert set(cli.COMMANDS) - process.ONE_PASS == {"compare", "batch", "collect", "benchmark", "fake-indicator"}


def test_the_freeze_comes_also_when_the_command_raises(recorded):
    with pytest.raises(RuntimeError, match="boom"):
        process.run_command("calibrate", ["raise"])
    assert len(recorded["freezes"]) == 1


def test_the_console_script_runs_a_command_through_run_command(recorded):
    assert process.main(["simulate", "--x"]) == 7
    assert recorded["argv"] == [("simulate", ["--x"])] and recorded["enabled"] == [False]


def test_the_console_script_answers_help_and_an_unknown_command_as_the_cli(recorded, capsys):
    assert process.main(["--help"]) == 0
    assert "calibrate" in capsys.readouterr().out
    assert process.main(["calibrat"]) == 2
    assert "unknown command 'calibrat'" in capsys.readouterr().err
    assert process.main([]) == 2
    assert recorded["argv"] == [] and recorded["freezes"] == []


def test_the_console_script_is_the_process_entry():
    text = (ROOT / "pyproject.toml").read_text()
    assert 'calib-pin = "calib_pin.cli.process:main"' in text


@pytest.mark.parametrize("script", sorted(p.name for p in (ROOT / "scripts").glob("*.py")))
def test_every_script_runs_its_command_as_a_process(script):
    text = (ROOT / "scripts" / script).read_text()
    name = script.removesuffix(".py").replace("_", "-")
    assert f'sys.exit(run_command("{name}", sys.argv[1:]))' in text


def test_a_script_process_exits_with_its_command_status(tmp_path):
    """A real process: a bad robot name is one line and exit 2, with the collector policy applied."""
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "calibrate.py"), "no-such-robot",
                           "--out", str(tmp_path / "out")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1 and "no-such-robot" in done.stderr
    assert not (tmp_path / "out").exists()


def test_collecting_turns_the_collector_on_for_its_part_with_what_came_before_frozen():
    """Inside a one-pass command (collector off): on within, every earlier object frozen
    (its passes skip them), off again after; with the collector on, nothing changes."""
    gc.disable()
    before = gc.get_freeze_count()
    with process.collecting():
        assert gc.isenabled()
        assert gc.get_freeze_count() > before
    assert not gc.isenabled()
    gc.enable()
    gc.unfreeze()
    frozen = gc.get_freeze_count()
    with process.collecting():
        assert gc.isenabled()
    assert gc.isenabled() and gc.get_freeze_count() == frozen


def test_a_report_of_several_sets_is_drawn_with_the_collector_on(monkeypatch, tmp_path):
    """calibrate's report.html of several sets (figures per set, freed only by the
    collector) is written inside collecting(); one set's is not."""
    import contextlib

    import calib_pin.cli.calibrate as calibrate_cli

    entered: list[int] = []

    @contextlib.contextmanager
    def spy():
        entered.append(1)
        yield

    monkeypatch.setattr(calibrate_cli, "collecting", spy)
    assert calibrate_cli.calibrate_main(["irb120", "--method", "lm", "--no-html", "--out", str(tmp_path / "one")]) == 0
    assert entered == []
    lines = (ROOT / "robots" / "irb120_default.csv").read_text().splitlines(keepends=True)
    head = [ln for ln in lines if ln.startswith("#")] + [next(ln for ln in lines if not ln.startswith("#"))]
    rows = [ln for ln in lines if ln not in head]
    for k, part in enumerate((rows[:60], rows[60:])):
        (tmp_path / f"s{k}.csv").write_text("".join(head + part))
    two = ["--data", str(tmp_path / "s0.csv"), "--data", str(tmp_path / "s1.csv")]
    code = calibrate_cli.calibrate_main(["irb120", *two, "--method", "lm", "--no-html", "--out", str(tmp_path / "two")])
    assert code == 0 and entered == [1]


def test_python_m_calib_pin_cli_is_the_console_script(tmp_path):
    """``python -m calib_pin.cli simulate ...`` runs the command as ``calib-pin`` does."""
    import subprocess
    import sys

    out = tmp_path / "s.csv"
    done = subprocess.run([sys.executable, "-m", "calib_pin.cli", "simulate", "irb120", "--poses", "5", "--out",
                           str(out)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and out.is_file(), done.stderr
    bad = subprocess.run([sys.executable, "-m", "calib_pin.cli", "frobnicate"], capture_output=True, text=True,
                         timeout=120)
    assert bad.returncode == 2 and "frobnicate" in bad.stderr

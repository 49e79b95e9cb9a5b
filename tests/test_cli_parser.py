"""The one ``calib-pin`` parser (calib_pin.cli.parser): a subparser per command, the shared
argument groups defined once (calib_pin.cli.common), the scripts/*.py wrappers parsing as
``calib-pin COMMAND`` does, and a skeleton that imports no numerical library."""

from __future__ import annotations

import argparse
import dataclasses
import runpy
import subprocess
import sys
from pathlib import Path

import pytest

import calib_pin.cli as cli
from calib_pin.cli import COMMANDS, CommandParser, command_parser, parser

ROOT = Path(__file__).resolve().parent.parent

#: Shared option -> the commands that take it from its one definition in cli/common.py.
SHARED = {
    "robot": ("calibrate", "simulate", "compare", "make-poses", "plan-poses", "detect"),
    "--end-frame": ("calibrate", "simulate", "make-poses", "plan-poses", "collect", "detect"),
    "--seed": ("calibrate", "simulate", "compare", "batch", "benchmark", "make-poses", "plan-poses"),
    "--test-fraction": ("calibrate", "compare", "batch"),
    "--loss": ("calibrate", "batch"),
    "--model": ("calibrate", "simulate", "compare", "batch", "plan-poses"),
    "--payload-kg": ("calibrate", "simulate", "compare"),
    "--payload-com-mm": ("calibrate", "simulate", "compare"),
    "--cable-tension-n": ("calibrate", "simulate", "compare"),
    "--jobs": ("compare", "batch"),
    "--scheduler": ("compare", "batch"),
    "--quiet": ("compare", "plan-poses", "collect"),
}


def _action(p: argparse.ArgumentParser, name: str) -> argparse.Action:
    return next(a for a in p._actions if name in (a.dest, *a.option_strings))


def _group_of(p: argparse.ArgumentParser, action: argparse.Action) -> str | None:
    return next(g.title for g in p._action_groups if action in g._group_actions)


@pytest.fixture(scope="module")
def full() -> argparse.ArgumentParser:
    """The parser with every command's arguments added."""
    return parser(populate=COMMANDS)


def test_skeleton_and_top_help_import_no_numerical_library():
    """Building the parser and ``calib-pin --help`` load no command module, numpy,
    scipy, Pinocchio or matplotlib; a command's arguments come when it is used."""
    code = ("import sys, contextlib, io; import calib_pin.cli as c; p = c.parser(); p.format_help(); "
            "contextlib.redirect_stdout(io.StringIO()).__enter__(); c.main(['--help']); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'scipy', 'pinocchio', 'matplotlib') "
            "or m.startswith('calib_pin.cli.')), file=sys.stderr)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stderr.strip() == "['calib_pin.cli.common']"


def test_top_help_lists_each_command_on_one_line(capsys):
    assert cli.main(["--help"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "usage: calib-pin [-h] COMMAND ..."
    for name, (_, _, what) in COMMANDS.items():
        assert sum(line.split() == [name, *what.split()] for line in lines) == 1, name


@pytest.mark.parametrize("name", COMMANDS)
def test_every_command_and_script_help_shows_calib_pin_command(name, full, monkeypatch, capsys):
    """The subparser's help, and ``python scripts/<command>.py --help``, start with
    ``usage: calib-pin <command> ``."""
    sub = command_parser(full, name)
    assert isinstance(sub, CommandParser) and sub.prog == f"calib-pin {name}"
    assert sub.format_help().startswith(f"usage: calib-pin {name} ")
    script = ROOT / "scripts" / f"{name.replace('-', '_')}.py"
    monkeypatch.setattr(sys, "argv", [str(script), "--help"])
    with pytest.raises(SystemExit) as done:
        runpy.run_path(str(script), run_name="__main__")
    assert done.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: calib-pin {name} ") and "calibrate.py" not in out


@pytest.mark.parametrize("option", SHARED)
def test_a_shared_option_is_one_definition(option, full):
    """The option is defined once: in every command that takes it the same help, type
    object, default, choices and group."""
    actions = {name: _action(command_parser(full, name), option) for name in SHARED[option]}
    first = next(iter(actions.values()))
    for name, a in actions.items():
        assert (a.help, a.default, a.choices, a.nargs, a.metavar) == \
            (first.help, first.default, first.choices, first.nargs, first.metavar), name
        assert a.type is first.type, name
        assert _group_of(command_parser(full, name), a) == _group_of(command_parser(full, SHARED[option][0]), first)
    others = [n for n in COMMANDS if n not in SHARED[option]]
    for name in others:  # a command's own option of that name is not the shared one
        own = [a for a in command_parser(full, name)._actions if option in (a.dest, *a.option_strings)]
        assert not own or own[0].help != first.help, (option, name)


def test_sensor_flags_come_from_the_set_up_records(full):
    """The sensor flags of calibrate, simulate and plan-poses are built from the sensors'
    dataclasses: each field's parser and help, in its sensor's group."""
    from calib_pin.sensors import setup_types
    from calib_pin.sensors.setup import flag_of

    checked = 0
    for name in ("calibrate", "simulate", "plan-poses"):
        sub = command_parser(full, name)
        seen: set[str] = set()  # a field two sensors share (tool_mm) is one flag, built from the first
        for setup in setup_types():
            for f in dataclasses.fields(setup):
                if "help" not in f.metadata or flag_of(f.name) not in sub._option_string_actions or f.name in seen:
                    continue
                seen.add(f.name)
                a = sub._option_string_actions[flag_of(f.name)]
                assert a.help.startswith(f.metadata["help"]), (name, f.name)
                if f.metadata["parser"] is not None:
                    assert a.type is f.metadata["parser"], (name, f.name)
                assert _group_of(sub, a).endswith(" set-up")
                checked += 1
    assert checked >= 8  # anchor, tool, offset, estimate of calibrate at least, and the others'


def test_a_registered_sensor_gets_its_flags_in_every_command_with_sensor_flags():
    """One definition: an invented sensor's record gives its flags to calibrate and plan-poses."""
    sys.path.insert(0, str(Path(__file__).parent))
    import fake_sensor

    fake_sensor.register()
    try:
        p = parser(populate=("calibrate", "plan-poses"))
        for name in ("calibrate", "plan-poses"):
            a = command_parser(p, name)._option_string_actions["--target-mm"]
            assert a.help.startswith("laser target point in the end frame")
            assert _group_of(command_parser(p, name), a) == "laser distance set-up"
    finally:
        fake_sensor.unregister()
    assert "--target-mm" not in command_parser(parser(), "calibrate")._option_string_actions


class _Parsed(Exception):
    """Raised by the spy with the namespace the command's subparser produced."""


#: A command line per command (no file is read: the spy stops the command after parsing).
ARGV = {
    "calibrate": ["irb120", "--seed", "3", "--tool-mm", "-2.2,0,50", "--data", "a.csv", "--data", "b.csv:noise_mm=0.1",
                  "--compliance", "joint_2", "--payload-kg", "1.5", "--method", "lm"],
    "simulate": ["irb120", "--out", "s.csv", "--anchor-mm", "-600,200,-100", "--sessions", "1", "--model", "placement"],
    "compare": ["irb120", "--methods", "lm,ekf", "--trials", "2", "--jobs", "2", "--quiet"],
    "collect": ["irb120", "--poses", "p.csv", "--port", "/dev/null", "--out", "o.csv", "--zero-mm", "-1.5"],
    "make-poses": ["irb120", "--n", "10", "--out", "p.csv", "--margin-deg", "2"],
    "plan-poses": ["irb120", "--n", "10", "--candidates", "50", "--estimate", "anchor", "--out", "p.csv"],
    "fake-indicator": ["--protocol", "ascii", "--value-mm", "-12.5"],
    "compensate": ["irb120", "--calibration", "c", "--targets", "t.csv", "--out", "o.csv", "--force"],
    "benchmark": ["--repeats", "2", "--methods", "lm", "--seed", "4"],
    "batch": ["a.csv+b.csv", "c.csv", "--out", "o", "--loss", "huber", "--test-fraction", "0.25"],
    "detect": ["irb120", "--images", "img", "--board", "charuco,9x7,30,22", "--camera-mount", "eye-to-hand",
               "--out", "c.csv"],
}


def _parse_through(run, monkeypatch) -> dict:
    """The namespace the command's subparser made when ``run()`` ran the command."""
    real = CommandParser.parse_known_args

    def spy(self, args=None, namespace=None):
        raise _Parsed(vars(real(self, args, namespace)[0]))

    monkeypatch.setattr(CommandParser, "parse_known_args", spy)
    with pytest.raises(_Parsed) as parsed:
        run()
    monkeypatch.setattr(CommandParser, "parse_known_args", real)
    return parsed.value.args[0]


@pytest.mark.parametrize("name", COMMANDS)
def test_script_and_entry_point_parse_alike(name, monkeypatch):
    """``python scripts/X.py ARGS`` and ``calib-pin X ARGS`` give the same arguments."""
    script = ROOT / "scripts" / f"{name.replace('-', '_')}.py"
    monkeypatch.setattr(sys, "argv", [str(script), *ARGV[name]])
    by_script = _parse_through(lambda: runpy.run_path(str(script), run_name="__main__"), monkeypatch)
    by_entry = _parse_through(lambda: cli.main([name, *ARGV[name]]), monkeypatch)
    assert by_script == by_entry
    assert by_entry == vars(command_parser(parser(), name).parse_args(ARGV[name]))
    if name == "calibrate":  # what the parse holds, not only that both agree
        assert by_entry["tool_mm"] == (-2.2, 0.0, 50.0) and by_entry["seed"] == 3
        assert by_entry["data"] == ["a.csv", "b.csv:noise_mm=0.1"] and by_entry["compliance"] == ("joint_2",)


@pytest.mark.parametrize(("argv", "fragment"), [
    (["make-poses", "irb120", "--out", "p.csv", "--se", "1"], "calib-pin make-poses: error: unrecognized arguments: --se 1"),
    (["make-poses", "irb120", "--out", "p.csv", "--seed", "1", "--seed=2"], "--seed given twice"),
    (["make-poses", "irb120", "--out", "p.csv", "--seed", "-1"], "argument --seed: expected a non-negative int, got '-1'"),
    (["batch", "a.csv", "--out", "o", "--jobs", "0"], "calib-pin batch: error: argument --jobs: expected a whole number"),
    (["compare", "irb120", "--test-fraction", "1"], "argument --test-fraction: expected a number in [0, 1)"),
])
def test_shared_options_fail_in_one_line(argv, fragment, capsys):
    """A shared option's bad value is the command's one-line error, exit 2."""
    with pytest.raises(SystemExit) as done:  # argparse's error exits
        cli.main(argv)
    assert done.value.code == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and fragment in err[0], err


def test_data_help_lists_every_key_the_parse_takes(tmp_path):
    """calibrate's --data help and its parse read one table (data_keys): every key the
    parse takes is in the help, with its unit or choices, and no other (noise_deg was missing)."""
    import re

    from calib_pin.cli.calibrate import data_argument, data_keys
    from calib_pin.exceptions import CalibPinError
    from calib_pin.sensors import setup_types

    text = " ".join(_action(command_parser(parser(), "calibrate"), "--data").help.split())
    listed = re.findall(r"(?:keys |\), )(\w+) \(", text.partition("FILE:key=value")[2])
    taken = [f.name for t in setup_types() for f in dataclasses.fields(t) if f.name != "estimate"]
    assert listed == list(data_keys()) == list(dict.fromkeys([*taken, "noise_mm", "role", "label"]))
    assert "noise_deg (deg; 6-D pose sets)" in text
    path = tmp_path / "a.csv"
    path.write_text("q1_deg\n")
    with pytest.raises(CalibPinError, match=re.escape(f"(valid: {', '.join(listed)})")):
        data_argument(f"{path}:colour=red")
    for key in listed:  # each listed key is one the parse takes (refused for its value, not as unknown)
        with pytest.raises(CalibPinError) as e:
            data_argument(f"{path}:{key}=" + ("" if key == "label" else "bad"))
        assert f": {key}: " in str(e.value) and "unknown key" not in str(e.value)

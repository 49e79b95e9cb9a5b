"""Files written by the previous version (``tests/data/previous_version``) still work."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.cli import main

DATA = Path(__file__).parent / "data" / "previous_version"
ROBOTS = Path(__file__).resolve().parent.parent / "robots"
FILES = ("irb120_cable", "irb120_wu_compliance", "ur5_placement", "irb120_mixed")


@pytest.mark.parametrize("name", FILES)
def test_a_calibration_file_of_the_previous_version_gives_the_same_robot(name):
    """Its end frame and compensated targets at four poses are those the previous version gave."""
    robot = cp.load_calibration(DATA / f"{name}_calibration.json")
    expected = json.loads((DATA / "forward.json").read_text())[name]
    q = np.array(expected["q"])
    frames = [m.homogeneous for m in robot.forward(q)]
    np.testing.assert_allclose(frames, expected["homogeneous"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(robot.compensate(q), expected["compensated"], rtol=0, atol=1e-10)


def _keys(value):
    """A report's key tree: each mapping's keys, each list of mappings item by item, and every
    other value's type name."""
    if isinstance(value, dict):
        return {k: _keys(v) for k, v in value.items()}
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        return [_keys(v) for v in value]
    return type(value).__name__


def _missing(old, new, path=""):
    """Where ``new`` lacks a key of ``old``'s tree or holds another type, as dotted paths.

    A number may turn int <-> float, and a value that was None may be anything now; a
    number (or any other value) that became None is refused.
    """
    if isinstance(old, dict):
        if not isinstance(new, dict):
            return [f"{path or 'the report'} (a mapping -> {new if isinstance(new, str) else 'a list'})"]
        return [p for key, kind in old.items()
                for p in ([f"{path}{key}"] if key not in new else _missing(kind, new[key], f"{path}{key}."))]
    if isinstance(old, list):
        if not isinstance(new, list) or len(new) != len(old):
            return [f"{path.rstrip('.')} ({len(old)} mappings -> {len(new) if isinstance(new, list) else new})"]
        return [p for k, (o, n) in enumerate(zip(old, new, strict=True)) for p in _missing(o, n, f"{path}{k}.")]
    if old != new and old != "NoneType" and {old, new} != {"int", "float"}:
        return [f"{path.rstrip('.')} ({old} -> {new if isinstance(new, str) else type(new).__name__})"]
    return []


def _simulated(tmp_path, name, argv):
    """The file(s) ``simulate`` writes for ``argv`` as ``tmp_path/name`` (a set is labelled by its
    file's stem, a key of report.json), as --data arguments."""
    assert main(["simulate", *argv, "--out", str(tmp_path / name)]) == 0
    files = sorted(tmp_path.glob(name.replace(".csv", "*.csv")))
    return [a for f in files for a in ("--data", str(f))]


#: The calibrations whose report.json keys the previous version recorded (tests/data/previous_version/README.md).
REPORTS = {
    "qs": lambda tmp: ["irb120"],
    "wu": lambda tmp: ["irb120", "--data", str(ROBOTS / "irb120_wu2015.csv"), "--method", "lm",
                       "--compliance", "joint_2,joint_3", "--export", "urdf,yaml,dh"],
    "ur5": lambda tmp: ["ur5", *_simulated(tmp, "p.csv", ["ur5", "--kinds", "position", "--poses", "120"]), "--model",
                        "placement", "--method", "lm"],
    "mixed": lambda tmp: ["irb120", *_simulated(tmp, "m.csv", ["irb120", "--kinds", "cable,position", "--sessions", "2",
                                                      "--poses", "45"]), "--method", "lm"],
}


@pytest.mark.parametrize("name", sorted(REPORTS))
def test_report_json_keeps_every_key_of_the_previous_version(tmp_path, name, capsys):
    """A report.json reader of the previous version finds every key it read, at any depth, of
    the same type (a number may not become None)."""
    assert main(["calibrate", *REPORTS[name](tmp_path), "--no-html", "--out", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    old = json.loads((DATA / "report_keys.json").read_text())[name]
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert [m for m in _missing(old, _keys(report)) if not _no_interval_by_design(m, report)] == []


def _no_interval_by_design(missing: str, report: dict) -> bool:
    """A deviation's ``std`` and ``ci95`` that are null because the data does not determine it
    alone (0.3.0: intervals only for what is determined; CHANGELOG.md, Changed)."""
    path = missing.split(" ")[0]
    head, _, key = path.rpartition(".")
    if not head.startswith("uncertainty.parameters.") or key not in ("std", "ci95"):
        return False
    entry = report["uncertainty"]["parameters"].get(head.removeprefix("uncertainty.parameters."), {})
    return entry.get("status") != "identified" and entry.get(key, 0) is None


def test_the_key_check_refuses_a_number_become_none_and_a_key_gone_deep():
    """What the check catches: a number that became None, a key missing three levels down, a
    set gone from a list of sets; what it lets pass: int <-> float, None that became a value."""
    old = {"a": "float", "b": {"c": {"d": "int"}}, "sets": [{"x": "str"}, {"y": "str"}], "e": "NoneType"}
    assert _missing(old, _keys({"a": None, "b": {"c": {}}, "sets": [{"x": "s"}], "e": 1.0})) == [
        "a (float -> NoneType)", "b.c.d", "sets (2 mappings -> 1)"]
    assert _missing(old, _keys({"a": 1, "b": {"c": {"d": 2.5}}, "sets": [{"x": ""}, {"y": ""}], "e": None})) == []


def test_a_one_set_calibration_keeps_the_previous_names(tmp_path, capsys):
    """The deviations, compliances and sensor unknowns of one set are named as before (no set label)."""
    assert main(["calibrate", "irb120", "--data", str(ROBOTS / "irb120_wu2015.csv"), "--method", "lm",
                 "--compliance", "joint_2,joint_3", "--no-html", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    old = json.loads((DATA / "irb120_wu_compliance_calibration.json").read_text())
    new = json.loads((tmp_path / "irb120_calibration.json").read_text())
    assert set(old) <= set(new)
    for key, value in old.items():
        if isinstance(value, dict):
            assert set(value) == set(new[key]), key

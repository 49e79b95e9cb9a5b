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


def _keys(value, depth=0):
    if isinstance(value, dict) and depth < 2:
        return {k: _keys(v, depth + 1) for k, v in value.items()}
    return type(value).__name__


def _missing(old, new, path=""):
    """Keys of ``old`` that ``new`` lacks or holds as another type, as dotted paths."""
    out = []
    for key, kind in old.items():
        if key not in new:
            out.append(f"{path}{key}")
        elif isinstance(kind, dict):
            out += _missing(kind, new[key], f"{path}{key}.") if isinstance(new[key], dict) else [f"{path}{key}"]
        elif kind != new[key] and "NoneType" not in (kind, new[key]) and {kind, new[key]} != {"int", "float"}:
            out.append(f"{path}{key} ({kind} -> {new[key]})")
    return out


@pytest.mark.parametrize(("name", "argv"), [
    ("qs", []),
    ("wu", ["--data", str(ROBOTS / "irb120_wu2015.csv"), "--method", "lm", "--compliance", "joint_2,joint_3", "--export", "urdf,yaml,dh"]),
])
def test_report_json_keeps_every_key_of_the_previous_version(tmp_path, name, argv, capsys):
    """A report.json reader of the previous version finds every key it read, of the same type."""
    assert main(["calibrate", "irb120", *argv, "--no-html", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    old = json.loads((DATA / "report_keys.json").read_text())[name]
    new = _keys(json.loads((tmp_path / "report.json").read_text()))
    assert _missing(old, new) == []


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

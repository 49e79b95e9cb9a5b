"""Per-set options: ``--data FILE:key=value:...`` on the command line, ``FitSet(setup=...)`` in the library."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin import FitSet
from calib_pin.cli.calibrate import calibrate_main, data_argument
from calib_pin.exceptions import CalibPinError
from calib_pin.sensors import CableModel, CableSetup, Drawstring

#: Three anchors of one drawstring, base frame [mm]; every file says WRONG_MM instead.
ANCHORS_MM = ((600.0, 200.0, -100.0), (-300.0, 550.0, -50.0), (100.0, -600.0, 150.0))
WRONG_MM = (400.0, 0.0, 0.0)
NOISE_M = 5e-5


@pytest.fixture(scope="module")
def wrong_files(chain, params, tmp_path_factory):
    """Three sessions of one true robot, each with its own anchor, written with a wrong anchor."""
    folder = tmp_path_factory.mktemp("perset")
    _, truth = cp.simulate(chain, params, 40, seed=21, anchor_mm=ANCHORS_MM[0])
    wrong = np.array(WRONG_MM) * 1e-3
    paths = []
    for k, anchor_mm in enumerate(ANCHORS_MM):
        poses, _ = cp.simulate(chain, params, 40, seed=210 + k, anchor_mm=anchor_mm, nominal_rmse_mm=0.0)
        sensor = Drawstring(np.array(anchor_mm) * 1e-3, truth.sensor.tool, 0.0)
        noise = np.random.default_rng(k).normal(scale=NOISE_M, size=len(poses))
        values = CableModel(chain, params, sensor).predict(truth.x, poses.q) + noise
        data = dataclasses.replace(poses, values=values, noise=None, anchor=wrong,
                                   sensor_meta={**poses.sensor_meta, "anchor": wrong})
        paths.append(folder / f"s{k + 1}.csv")
        cp.write_measurements(paths[-1], data)
    return paths


def _spec(path, anchor_mm) -> str:
    return f"{path}:anchor_mm={','.join(format(a, 'g') for a in anchor_mm)}"


def test_cli_per_set_anchor_wins_over_the_file_and_calibrates_to_the_noise(wrong_files, tmp_path, capsys):
    out = tmp_path / "o"
    argv = ["irb120", "--method", "lm", "--no-html", "--out", str(out)]
    specs = [_spec(p, a) for p, a in zip(wrong_files, ANCHORS_MM, strict=True)]
    specs[2] += ":noise_mm=0.05:label=third"
    assert calibrate_main([*argv, *[x for s in specs for x in ("--data", s)]]) == 0
    text = capsys.readouterr().out
    assert text.count("anchor_mm from the command line (over the file's)") == 3
    report = json.loads((out / "report.json").read_text())
    sets = report["sets"]
    assert [s["label"] for s in sets] == ["s1", "s2", "third"]
    assert sets[2]["noise_from"] == "caller" and sets[2]["noise_mm"] == pytest.approx(0.05)
    for s, anchor_mm in zip(sets, ANCHORS_MM, strict=True):
        assert s["anchor_mm"] == pytest.approx(anchor_mm)
        assert s["setup_from_caller"] == ["anchor_mm"] and s["setup_over_file"] == ["anchor_mm"]
        assert s["test"]["after"]["rmse_mm"] < 0.08  # reading noise 0.05 mm
    # the files' wrong anchor alone cannot be calibrated (the fit runs off the sanity bounds)
    assert calibrate_main([*argv, *[x for p in wrong_files for x in ("--data", str(p))]]) == 2
    assert "wrong anchor_mm" in capsys.readouterr().err


def test_library_fitset_setup_is_the_same_fit(wrong_files, tmp_path):
    specs = [_spec(p, a) for p, a in zip(wrong_files, ANCHORS_MM, strict=True)]
    out = tmp_path / "o"
    assert calibrate_main(["irb120", "--method", "lm", "--no-html", "--out", str(out),
                           *[x for s in specs for x in ("--data", s)]]) == 0
    cli = json.loads((out / "report.json").read_text())["sets"]
    lib = cp.calibrate("irb120", [FitSet(p, setup=CableSetup(anchor_mm=a)) for p, a in
                                  zip(wrong_files, ANCHORS_MM, strict=True)], method="lm")
    for s, c in zip(lib.sets, cli, strict=True):
        assert s.overrides == ("anchor_mm",)
        assert s.metrics["test"]["after"].rmse_mm == pytest.approx(c["test"]["after"]["rmse_mm"], rel=1e-9)


def test_one_data_file_with_options(wrong_files, tmp_path, capsys):
    out = tmp_path / "o"
    assert calibrate_main(["irb120", "--method", "lm", "--no-html", "--out", str(out),
                           "--data", _spec(wrong_files[0], ANCHORS_MM[0])]) == 0
    capsys.readouterr()
    report = json.loads((out / "report.json").read_text())
    assert report["test"]["after"]["rmse_mm"] < 0.08 and report["anchor_mm"] == pytest.approx(ANCHORS_MM[0])


def test_data_argument_forms(wrong_files, tmp_path):
    path = str(wrong_files[0])
    assert data_argument(path) == (path, {})
    colon = tmp_path / "a:b.csv"
    colon.write_text("x")
    assert data_argument(str(colon)) == (str(colon), {})  # the whole argument is a file
    assert data_argument(f"{colon}:role=test") == (str(colon), {"role": "test"})
    got = data_argument(f"{path}:anchor_mm=1,2,3:length_offset_mm=-4:role=train")
    assert got == (path, {"anchor_mm": (1.0, 2.0, 3.0), "length_offset_mm": -4.0, "role": "train"})
    assert data_argument("nowhere.csv") == ("nowhere.csv", {})  # the loader names the missing file
    for bad, message in [(f"{path}:colour=red", "unknown key 'colour'"),
                         (f"{path}:anchor_mm=1,2", "anchor_mm: expected 3 numbers"),
                         (f"{path}:role=validate", "role: expected one of split, train, test"),
                         (f"{path}:noise_mm=0", "noise_mm: 0 is not a sensor sigma"),
                         (f"{path}:role=test:role=train", "key 'role' given twice"),
                         (f"{path}:anchor_mm", "is not key=value"),
                         ("nowhere.csv:role=test", "no file 'nowhere.csv'")]:
        with pytest.raises(CalibPinError, match=message):
            data_argument(bad)


def test_a_cable_key_on_a_position_set_is_refused(tmp_path):
    text = Path("robots/irb120_wu2015.csv").read_text()
    (tmp_path / "a.csv").write_text(text)
    (tmp_path / "b.csv").write_text(text)
    data = [FitSet(tmp_path / "a.csv", setup=CableSetup(anchor_mm=(1, 2, 3))), FitSet(tmp_path / "b.csv")]
    with pytest.raises(CalibPinError, match="argument setup: anchor_mm is for drawstring data; .*a.csv holds positions"):
        cp.prepare("irb120", data)


@pytest.mark.parametrize(("files", "typed", "says"), [
    (["irb120_default"], "noise_deg=2", "noise_deg: is for 6-D data; {} holds drawstring readings"),
    (["irb120_contact_example"], "noise_deg=2", "noise_deg: is for 6-D data; {} holds contact fixtures"),
    (["irb120_wu2015"], "tool_mm=1,2,3", "tool_mm: is for drawstring and contact data; {} holds positions"),
    (["irb120_wu2015"], "anchor_mm=1,2,3", "anchor_mm: is for drawstring data; {} holds positions"),
    (["irb120_default"], "noise_deg=200", "noise_deg: expected a number in (0, 180] deg, got '200'"),
    (["irb120_default", "irb120_wu2015"], "noise_deg=2", "noise_deg: is for 6-D data; {} holds drawstring readings"),
    (["irb120_default", "irb120_wu2015"], "noise_deg=200", "noise_deg: expected a number in (0, 180] deg"),
])
def test_a_refused_per_set_option_names_the_data_argument(files, typed, says, capsys):
    paths = [f"robots/{name}.csv" for name in files]
    first = f"{paths[0]}:{typed}"
    argv = ["irb120", "--data", first, *[a for p in paths[1:] for a in ("--data", p)], "--analyze"]
    assert calibrate_main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: --data '{first}': {says.format(paths[0])}")
    assert err.count("\n") == 1 and "--noise-deg" not in err and "--tool-mm" not in err and "argument " not in err


def test_a_global_flag_refused_still_names_the_flag(capsys):
    assert calibrate_main(["irb120", "--data", "robots/irb120_default.csv:noise_mm=0.1", "--noise-deg", "2",
                           "--analyze"]) == 2
    assert capsys.readouterr().err == "error: --noise-deg is for 6-D data; robots/irb120_default.csv holds drawstring readings\n"


@pytest.mark.parametrize(("own", "shared", "field"), [
    ({"setup": CableSetup(anchor_mm=(600, 200, -100))}, {"setup": CableSetup(anchor_mm=(650, 200, -100))}, "anchor_mm"),
    ({"setup": CableSetup(tool_mm=(0, 0, 50))}, {"setup": CableSetup(tool_mm=(0, 0, 50))}, "tool_mm"),
    ({"noise_mm": 0.05}, {"noise_mm": 0.1}, "noise_mm"),
])
def test_a_value_given_for_the_set_and_for_every_set_is_refused(own, shared, field):
    """A set's own set-up value or noise beside the one given for every set: refused naming
    both (one of them was dropped without a word), even when they agree."""
    with pytest.raises(cp.ArgumentError, match=rf"argument {field}: set irb120_default.csv: given for the set "
                                               r"\(.*\) and for every set \(.*\): give one"):
        cp.prepare("irb120", [FitSet("robots/irb120_default.csv", **own)], **shared)


@pytest.mark.parametrize(("typed", "flag"), [
    ("anchor_mm=600,200,-100", ["--anchor-mm", "650,200,-100"]),
    ("noise_mm=0.05", ["--noise-mm", "0.1"]),
])
def test_a_per_set_option_and_its_global_flag_are_refused_together(typed, flag, capsys):
    code = calibrate_main(["irb120", "--data", f"robots/irb120_default.csv:{typed}", *flag, "--analyze"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == (f"error: --data 'robots/irb120_default.csv:{typed}' and {flag[0]} both give "
                                 f"{typed.split('=')[0]} of robots/irb120_default.csv: give one")

"""The sensor plug-in seam: no module outside calib_pin/sensors/ and the CSV layer names a
sensor kind, and an invented third sensor (tests/fake_sensor.py: one module, one registry
entry) reads, writes, calibrates and gets its CLI flags without touching calib-pin."""

from __future__ import annotations

import argparse
import ast
import io
import json
import tokenize
from pathlib import Path

import fake_sensor
import numpy as np
import pytest

import calib_pin as cp
from calib_pin.measurements.schema import SCHEMAS
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import SENSORS, CableSetup, PositionSetup, add_sensor_arguments, sensor_for, setup_record

PACKAGE = Path(cp.__file__).parent
#: Where kinds may be named: the sensors themselves and the CSV layer.
OWNERS = ("sensors/", "measurements/csv_reader.py", "measurements/csv_writer.py", "measurements/columns.py",
          "measurements/dialect.py",
          # the built-in kinds' file schemas (SCHEMAS), which the CSV layer reads below the sensors
          "measurements/schema.py",
          # a sensor's own simulator of example sessions, named for its kind
          "simulation/contact.py", "simulation/pose.py")
#: Modules that still name a kind, each with why (file -> reason). Shrink it; never grow it.
ALLOWED = {
    # The public API re-exports the sensor classes by name (calib_pin.CableModel, ...).
    "__init__.py": "public re-exports of the sensor classes",
    # Each sensor simulates its own rows (MeasurementModel.simulate_rows); what is left here
    # are the two sensors' public shorthands (simulate, simulate_positions and the anchors_mm /
    # devices arguments of simulate_sessions), whose signatures the users and the tests keep.
    "simulation/simulator.py": "the drawstring and position shorthands of the sensor-owned simulate_rows",
    # The collector drives a drawstring through its serial reader and writes its sessions;
    # a collector per sensor is the follow-up issue's (more low-cost sensors).
    "hardware/session.py": "the drawstring collector",
    # 'cable' there is the compliance's cable-pull argument (a Deflection input), not a
    # sensor kind: the compliance arguments belong to another part of this issue.
    "export/calibration_file.py": "the compliance's 'cable' pull argument name",
    # The trust study's cases are sets of named sensors (a cable hooked at the flange, ...).
    "studies/trust.py": "the study's cases, each a named sensor set-up",
    "export/compensation.py": "the compliance's 'cable' pull argument name",
}


def _class_names() -> set[str]:
    """The registered sensors' classes: model, geometry, set-up record."""
    return {n for m in SENSORS.values() for n in (m.__name__, m.geometry_type.__name__, m.setup_type.__name__)}


def _sensor_names() -> set[str]:
    """The kinds and the class names."""
    return set(SENSORS) | _class_names()


def _named(path: Path, names: set[str]) -> list[tuple[int, str]]:
    """(line, name) of every code token of ``path`` that names a sensor: an identifier that
    is a sensor class (``CableModel``), or a string literal equal to a kind or a class name
    (``"cable"``). A variable called ``cable`` and prose in comments and docstrings do not count."""
    classes = _class_names()
    hits = []
    for tok in tokenize.generate_tokens(io.StringIO(path.read_text(encoding="utf-8")).readline):
        if tok.type == tokenize.NAME and tok.string in classes:
            hits.append((tok.start[0], tok.string))
        elif tok.type == tokenize.STRING:
            try:
                value = ast.literal_eval(tok.string)
            except (ValueError, SyntaxError):
                continue
            if isinstance(value, str) and value in names:
                hits.append((tok.start[0], repr(value)))
    return hits


def test_no_module_outside_the_sensors_names_a_kind():
    names = _sensor_names()
    assert {"cable", "position", "CableModel", "PositionModel", "Drawstring"} <= names
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        if rel.startswith(OWNERS) or rel in ALLOWED:
            continue
        if hits := _named(path, names):
            found[rel] = hits
    assert not found, f"sensor kinds named outside calib_pin/sensors/ and the CSV layer: {found}"
    for rel in ALLOWED:  # an allowed module that no longer names one leaves the list
        assert _named(PACKAGE / rel, names), f"{rel} names no sensor kind any more: drop it from ALLOWED"


def test_the_scan_finds_a_kind_named(tmp_path):
    module = tmp_path / "m.py"
    module.write_text('"""A drawstring, in prose."""\n# a cable\ncable = 1\nif data.kind == "cable":\n    m = CableModel\n')
    assert _named(module, _sensor_names()) == [(4, "'cable'"), (5, "CableModel")]


def test_setup_records_are_validated_once_and_built_from_the_loose_options():
    setup = CableSetup(anchor_mm=[600, 200, -100], estimate="anchor")
    assert setup.anchor_mm.tolist() == [600, 200, -100] and setup.estimate == ("anchor",)
    with pytest.raises(cp.CalibPinError, match="anchor_mm"):
        CableSetup(anchor_mm=[1, 2])
    assert setup_record(None, anchor_mm=None, estimate=()) is None
    assert setup_record(None, tool_mm=(0, 0, 50)) == CableSetup(tool_mm=(0, 0, 50))
    merged = setup_record(setup, length_offset_mm=1.5)
    assert merged.length_offset_mm == 1.5 and merged.anchor_mm.tolist() == [600, 200, -100]
    with pytest.raises(cp.CalibPinError, match="setup"):
        setup_record({"anchor_mm": (1, 2, 3)})
    with pytest.raises(cp.CalibPinError, match="anchor_mm"):
        setup_record(PositionSetup(), anchor_mm=(1, 2, 3))


def test_calibrate_takes_a_setup_record_as_the_loose_keywords(tmp_path):
    data = cp.read_measurements(PACKAGE.parent / "robots" / "irb120_default.csv")
    filed = sensor_for(data.kind).setup_of(data)
    assert isinstance(filed, CableSetup) and filed.anchor_mm is not None
    kwargs = {"method": "lm", "seed": 0}
    with pytest.warns(DeprecationWarning, match="setup=calib_pin.CableSetup"):  # the shorthand, kept one release
        loose = cp.calibrate("irb120", data, anchor_mm=filed.anchor_mm + 0.5, estimate="anchor", **kwargs)
    record = cp.calibrate("irb120", data, setup=CableSetup(anchor_mm=filed.anchor_mm + 0.5,
                                                           estimate=("anchor",)), **kwargs)
    assert np.array_equal(loose.x, record.x)
    with pytest.raises(cp.CalibPinError, match="is for drawstring data"):
        cp.calibrate("irb120", PACKAGE.parent / "robots" / "irb120_wu2015.csv",
                     setup=CableSetup(anchor_mm=(1, 2, 3)), **kwargs)


@pytest.fixture
def distance():
    fake_sensor.register()
    yield fake_sensor.DistanceModel
    fake_sensor.unregister()


def _distance_set(tmp_path: Path, n: int = 80, noise_mm: float = 0.01) -> tuple[Path, Path, np.ndarray, object]:
    """A simulated laser-distance set (and a fresh one) of one true irb120."""
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    rng = np.random.default_rng(3)
    truth = rng.normal(size=len(params.names)) * params.scale * 0.5
    beam = fake_sensor.Beam(np.array([0.6, 0.0, 0.8]), np.array([0.0, 0.0, 0.05]), 0.002)
    model = fake_sensor.DistanceModel(chain, params, beam)
    x = np.concatenate([truth, [0.0]])
    paths = []
    for k, name in enumerate(("d.csv", "fresh.csv")):
        q = random_poses(chain, n, np.random.default_rng(10 + k))
        values = model.predict(x, q) + (rng.normal(size=n) * noise_mm * 1e-3 if k == 0 else 0.0)
        data = cp.MeasurementSet(q=q, values=values, kind="distance", robot=chain.name, end_frame=chain.end_frame,
                                 noise=noise_mm * 1e-3, sensor_meta={"target": beam.target, "zero": beam.zero})
        cp.write_measurements(tmp_path / name, data)
        paths.append(tmp_path / name)
    return paths[0], paths[1], x, model


def test_an_invented_sensor_reads_writes_and_calibrates(tmp_path, distance):
    path, fresh, x, model = _distance_set(tmp_path)
    text = path.read_text()
    assert "# target_mm: 0.000000, 0.000000, 50.000000" in text and "# zero_mm: 2.000000" in text
    assert [line for line in text.splitlines() if not line.startswith("#")][0].endswith(",q6_deg,distance_mm")
    data = cp.read_measurements(path)
    assert data.kind == "distance" and data.values.shape == (80,)
    assert sensor_for(data.kind).setup_of(data) == fake_sensor.DistanceSetup(target_mm=(0, 0, 50))
    with pytest.raises(cp.CalibPinError, match="argument setup: anchor_mm is for drawstring data; .*holds laser distances"):
        cp.calibrate("irb120", path, method="lm", setup=CableSetup(anchor_mm=(1, 2, 3)))
    result = cp.calibrate("irb120", path, method="lm", test_fraction=0.25, setup=fake_sensor.DistanceSetup(
        beam=(0.6, 0.0, 0.8)))
    assert result.metrics["test"]["after"].rmse_mm < 0.03 < result.metrics["test"]["before"].rmse_mm
    assert result.sensor.target.tolist() == [0.0, 0.0, 0.05]  # the zero is estimated (with the base, along the beam)
    # held-out poses against the noise-free truth
    session = cp.read_measurements(fresh)
    errors = result.sets[0].model.session_errors(result.x, session)
    assert np.sqrt(np.mean(errors**2)) < 0.03e-3


def test_an_invented_sensor_gets_its_cli_flags(tmp_path, distance, capsys):
    from calib_pin.cli.calibrate import calibrate_main, calibrate_parser

    p = argparse.ArgumentParser()
    add_sensor_arguments(p)
    args = p.parse_args(["--beam", "0,0,1", "--target-mm", "0,0,40", "--anchor-mm", "1,2,3"])
    assert args.beam == (0, 0, 1) and args.target_mm == (0, 0, 40) and args.anchor_mm == (1, 2, 3)
    assert "laser distance set-up" in calibrate_parser().format_help()
    path, _, _, _ = _distance_set(tmp_path)
    out = tmp_path / "out"
    code = calibrate_main(["irb120", "--data", str(path), "--method", "lm", "--beam", "0.6,0,0.8",
                           "--out", str(out), "--no-html"])
    printed = capsys.readouterr().out
    assert code == 0, printed
    assert "error per row: distance error" in printed
    report = json.loads((out / "report.json").read_text())
    assert report["test"]["after"]["rmse_mm"] < 0.03
    assert "distance" not in SENSORS or SENSORS["distance"] is fake_sensor.DistanceModel
    assert "distance" not in SCHEMAS or SCHEMAS["distance"] is fake_sensor.DistanceModel.schema


def test_an_invented_sensors_columns_are_checked_as_the_others(tmp_path, distance):
    joints = ",".join(f"q{i}_deg" for i in range(1, 7))
    mixed = tmp_path / "mixed.csv"
    mixed.write_text(f"{joints},length_mm,distance_mm\n0,0,0,0,0,0,500,20\n")
    with pytest.raises(cp.DataError, match="distance columns and others"):
        cp.read_measurements(mixed)
    twice = tmp_path / "twice.csv"
    twice.write_text(f"{joints},distance_mm,distance_m\n0,0,0,0,0,0,500,0.5\n")
    with pytest.raises(cp.DataError, match="two distance columns"):
        cp.read_measurements(twice)
    metres = tmp_path / "m.csv"
    metres.write_text(f"# target_m: 0, 0, 0.05\n{joints},distance_m\n0,0,0,0,0,0,0.5\n")
    data = cp.read_measurements(metres)
    assert data.kind == "distance" and data.values.tolist() == [0.5] and data.sensor_meta["target"][2] == 0.05
    without = tmp_path / "n.csv"
    without.write_text(f"{joints},distance_mm\n0,0,0,0,0,0,500\n")
    with pytest.raises(cp.DataError, match="no target point"):
        cp.calibrate("irb120", without, method="lm")

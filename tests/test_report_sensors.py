"""What the report shows of each sensor (calib_pin/report/html.py geometry_rows, the
Sensor section): every sensor's geometry as its model's ``geometry_report`` gives it, in
report.json and as a table in report.html, for one set or per set; and the shared
set-up flags naming the sensors that take them (calib_pin/sensors/setup.py)."""

from __future__ import annotations

import argparse
import html
import re

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.report.build import build_report
from calib_pin.report.html import geometry_rows, render_html, sensor_html
from calib_pin.sensors import SENSORS


def _sensor_section(page: str) -> str:
    """The text of report.html's Sensor section (or of that section's HTML), tags stripped."""
    if '<section id="sensor">' in page:
        page = page[page.index('<section id="sensor">'):]
        page = page[: page.index("</section>")]
    return html.unescape(re.sub(r"<[^>]+>", " ", re.sub(r"<img[^>]*>", "", page)))


@pytest.fixture(scope="module")
def chain():
    return cp.load_chain("irb120")


def _check_geometry_shown(text: str, geometry: dict) -> None:
    """Every number of ``geometry`` appears in the section's text (4 significant digits)."""
    def numbers(value):
        if isinstance(value, dict):
            for v in value.values():
                yield from numbers(v)
        elif isinstance(value, list | tuple):
            for v in value:
                yield from numbers(v)
        elif isinstance(value, int | float) and not isinstance(value, bool):
            yield value

    for v in numbers(geometry):
        assert f"{v:.4g}" in text, (v, text[:400])


@pytest.mark.parametrize("kind", ["cable", "position", "pose", "contact"])
def test_each_sensors_geometry_is_a_table_in_report_html(chain, kind):
    params = cp.parameter_model(chain)
    if kind == "contact":
        from calib_pin.simulation import simulate_contacts

        data = simulate_contacts(chain, params, 10, seed=3)[0]
    else:
        data = cp.simulate_sessions(chain, params, 40, seed=3, kinds=[kind])[0][0]
    result = cp.calibrate("irb120", data, method="lm")
    report = build_report(result)
    geometry = result.problem.model.geometry_report(result.x)
    assert report["sensor_geometry"] == geometry and report["sensor"] == result.problem.model.describe()
    residuals = report["residuals"]  # one entry per data row (a contact set's distance rows are not data rows)
    assert len(residuals["rows"]) == len(residuals["after_mm"]) == len(residuals["outlier"]) == len(data)
    text = _sensor_section(sensor_html(report, figures=False))  # the section report.html shows (next test)
    assert result.problem.model.describe() in text
    _check_geometry_shown(text, geometry)
    units = {row[2] for row in geometry_rows(geometry)}
    assert "mm" in units  # every sensor has a length somewhere
    if kind == "pose":
        assert "deg" in units and "Errors per part, each in its own unit" in text and "orientation" in text
    else:
        assert "Errors per part" not in text


def test_several_sets_show_each_sets_sensor_and_errors_in_its_own_units(chain):
    params = cp.parameter_model(chain)
    sets, _ = cp.simulate_sessions(chain, params, 12, seed=21, kinds=["cable", "pose"])
    result = cp.calibrate("irb120", sets, method="lm")
    report = build_report(result)
    text = _sensor_section(render_html(report))
    for s in result.sets:
        assert f"Set {s.label}" in text and s.model.describe() in text
        _check_geometry_shown(text, s.model.geometry_report(s.x))
    pose = report["sets"][1]["errors_by_part"]["test"]["after"]["orientation_deg"]["rmse_deg"]
    assert f"{pose:.4g}" in text


def test_geometry_rows_take_the_unit_from_the_key():
    rows = geometry_rows({"anchor_mm": [1.0, 2.0, 3.0], "frame": {"rpy_deg": [0.5, 0, 90], "meaning": "p = R q"},
                          "points_mm": {"A": [1, 2, 3]}, "offset_mm": 4.25, "tool": "given"})
    assert rows == [["anchor", "[1, 2, 3]", "mm"], ["frame / rpy", "[0.5, 0, 90]", "deg"],
                    ["frame / meaning", "p = R q", ""], ["points / A", "[1, 2, 3]", "mm"], ["offset", "4.25", "mm"],
                    ["tool point given or estimated", "given", ""]]


def test_a_contact_sets_tool_point_and_its_origin_have_distinct_rows(chain):
    """A contact set's geometry has the tool point (``tool_mm``) and whether it was given
    (``tool``): two rows that both read "tool" before; now named apart, the point in mm."""
    from calib_pin.report.html import fmt
    from calib_pin.simulation import simulate_contacts

    params = cp.parameter_model(chain)
    data = simulate_contacts(chain, params, 10, seed=3)[0]
    result = cp.calibrate("irb120", data, method="lm")
    geometry = build_report(result)["sensor_geometry"]
    rows = geometry_rows(geometry)
    labels = [row[0] for row in rows]
    assert len(labels) == len(set(labels)), labels
    by_label = {row[0]: row for row in rows}
    tool = geometry["tool_mm"]
    assert by_label["tool point (end frame)"][1:] == [f"[{', '.join(fmt(v) for v in tool)}]", "mm"]
    assert by_label["tool point given or estimated"][1:] == [geometry["tool"], ""]
    text = _sensor_section(sensor_html(build_report(result), figures=False))
    assert "tool point (end frame)" in text and "tool point given or estimated" in text


def test_a_shared_flag_names_every_sensor_that_takes_it():
    from calib_pin.sensors.setup import add_setup_arguments

    p = argparse.ArgumentParser()
    setups = [s.setup_type for s in SENSORS.values()]
    add_setup_arguments(p, setups)
    helps = {a.dest: a.help for a in p._actions}
    takers = [s.title for s in setups if "tool_mm" in s.field_names()]
    assert len(takers) >= 2 and helps["tool_mm"].endswith(f"for {' and '.join(takers)} sets")
    assert "cable tool point" not in helps["tool_mm"]
    assert "sets" not in helps["anchor_mm"]  # one sensor's flag: nothing added


def test_a_foreign_flag_names_every_sensor_that_takes_it(chain):
    params = cp.parameter_model(chain)
    data, _ = cp.simulate_sessions(chain, params, 5, seed=1, kinds=["pose"])
    with pytest.raises(cp.ArgumentError,
                       match="argument setup: tool_mm is for drawstring and contact data; the set holds 6-D poses"):
        cp.calibrate("irb120", data[0], method="lm", setup=cp.sensors.CableSetup(tool_mm=(0, 0, 50)))


def test_simulate_noise_deg_sets_the_pose_sessions_noise(tmp_path, monkeypatch, capsys):
    from calib_pin.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "irb120", "--kinds", "pose", "--poses", "200", "--noise-deg", "0.05", "--out", "p.csv"]) == 0
    data = cp.read_measurements("p.csv")
    assert data.notes["noise_deg"] == "0.05"
    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    truth = cp.Truth.from_json("p.truth.json", params)
    _, deg = truth.model(chain, params).part_errors(truth.x_model, data.q, data.values)
    assert np.sqrt(np.mean(deg**2)) / np.sqrt(3) == pytest.approx(0.05, rel=0.2)  # 0.05 deg per axis

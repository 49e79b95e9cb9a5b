"""The pre-fit misfit check: a unit or order mistake is named before the fit, a correct set never."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.calibration import misfit as check
from calib_pin.calibration.prepare import prepare
from calib_pin.sensors import sensor_for
from calib_pin.simulation.simulator import simulate_set

ROOT = Path(__file__).resolve().parent.parent
KINDS = ("cable", "position", "pose", "contact")


def _split(path: Path) -> tuple[list[str], list[str], list[list[str]]]:
    lines = path.read_text().splitlines()
    k = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    return lines[:k], lines[k].split(","), [row.split(",") for row in lines[k + 1 :]]


def _write(path: Path, meta: list[str], head: list[str], rows: list[list[str]]) -> Path:
    path.write_text("\n".join([*meta, ",".join(head), *(",".join(r) for r in rows)]) + "\n")
    return path


def _columns(path: Path, out: Path, names: tuple[str, ...], change) -> Path:
    """``path`` with each field of the columns ``names`` replaced by ``change(value)``."""
    meta, head, rows = _split(path)
    for row in rows:
        for k, name in enumerate(head):
            if name in names:
                row[k] = change(float(row[k]))
    return _write(out, meta, head, rows)


def _radians(path: Path, out: Path) -> Path:
    """``path`` with its joint angles written in radians under the ``_deg`` columns."""
    return _columns(path, out, tuple(f"q{j}_deg" for j in range(1, 7)), lambda v: f"{math.radians(v):.9f}")


def _metres(path: Path, out: Path) -> Path:
    """``path`` with its positions written in metres under the ``_mm`` columns."""
    return _columns(path, out, ("x_mm", "y_mm", "z_mm"), lambda v: f"{v * 1e-3:.9f}")


def _xyzw(path: Path, out: Path) -> Path:
    """``path`` with its quaternions written x, y, z, w under qw, qx, qy, qz."""
    meta, head, rows = _split(path)
    for row in rows:
        row[-4:] = row[-3:] + row[-4:-3]
    return _write(out, meta, head, rows)


def _meta(path: Path, out: Path, old: str, new: str) -> Path:
    """``path`` with its metadata text ``old`` replaced by ``new``."""
    text = path.read_text()
    assert old in text
    out.write_text(text.replace(old, new))
    return out


@pytest.fixture(scope="module")
def sets(chain, params, tmp_path_factory) -> dict[str, Path]:
    """A seeded simulated set of each kind, 40 poses (the contact set 60 touches), written as files."""
    folder = tmp_path_factory.mktemp("misfit")
    out = {}
    for kind in KINDS:
        data, _ = simulate_set(sensor_for(kind), chain, params, 60 if kind == "contact" else 40, seed=3)
        out[kind] = folder / f"{kind}.csv"
        cp.write_measurements(out[kind], data)
    return out


def _refusal(data, **kwargs) -> str:
    with pytest.raises(cp.DataError) as caught:
        prepare("irb120", data, **kwargs)
    return str(caught.value)


@pytest.mark.parametrize("kind", KINDS)
def test_radians_in_degree_columns_are_named(sets, kind, tmp_path):
    """Every sensor: radians under q<k>_deg are named with the columns and the fix, not fitted."""
    line = _refusal(_radians(sets[kind], tmp_path / "rad.csv"))
    assert line.startswith(f"{tmp_path / 'rad.csv'}: q1_deg..q6_deg: radians in degree columns? every angle")
    assert "read as radians, by" in line and line.endswith("convert them to degrees, or name the columns q1_rad..q6_rad")


@pytest.mark.parametrize("kind", ["position", "pose"])
def test_metres_under_mm_columns_are_named(sets, kind, tmp_path):
    line = _refusal(_metres(sets[kind], tmp_path / "m.csv"))
    assert ": x_mm, y_mm, z_mm: metres in mm columns? every value" in line
    assert line.endswith("give millimetres (x 1000), or name the columns x_m, y_m, z_m")


def test_quaternions_in_xyzw_order_are_named(sets, tmp_path):
    line = _refusal(_xyzw(sets["pose"], tmp_path / "q.csv"))
    assert ": qw, qx, qy, qz: x, y, z, w order? read in w, x, y, z order; the nominal robot misses the rows by " \
           "position" in line
    assert "with qw the last column, by position" in line and line.endswith("(the last column first)")


def test_an_anchor_in_metres_is_named_given_or_in_the_file(sets, tmp_path):
    """The caller's anchor (no line) and the file's (its line), each with its value in mm."""
    path = _meta(sets["cable"], tmp_path / "a.csv", "# anchor_mm: 600.000000, 200.000000, -100.000000",
                 "# anchor_mm: 0.6, 0.2, -0.1")
    line = _refusal(path)
    assert line.startswith(f"{path}:3: anchor_mm: metres, not mm? 0.6,0.2,-0.1 mm (the file's); the nominal robot")
    assert "; with 600,200,-100 mm, by " in line and line.endswith(": give it in mm (600,200,-100)")
    none = _meta(sets["cable"], tmp_path / "n.csv", "# anchor_mm: 600.000000, 200.000000, -100.000000\n", "")
    line = _refusal(none, setup=cp.CableSetup(anchor_mm=(0.6, 0.2, -0.1)))
    assert line.startswith(f"{none}: anchor_mm: metres, not mm? 0.6,0.2,-0.1 mm (given)")


@pytest.mark.parametrize(("written", "unit"), [("0.391535", "metres"), ("39.1535", "cm")])
def test_a_distance_line_in_another_unit_is_named(sets, written, unit, tmp_path):
    text = sets["contact"].read_text()
    length = re.search(r"# distance_mm: A, B, (\S+)", text).group(1)  # type: ignore[union-attr]
    shown = f"{float(length) * (1e-3 if unit == 'metres' else 0.1):.6g}"
    path = _meta(sets["contact"], tmp_path / "k.csv", f"# distance_mm: A, B, {length}", f"# distance_mm: A, B, {shown}")
    line = _refusal(path)
    assert line.startswith(f"{path}:3: distance_mm: {unit}, not mm? A, B, {shown} mm; the fixtures the nominal robot "
                           "locates are ")
    assert f"give it in mm (A, B, {float(shown) * (1000 if unit == 'metres' else 10):g})" in line


@pytest.fixture(scope="module")
def ur10(tmp_path_factory):
    """A ur10 drawstring set and three default_kinematics.yaml: the ur10's, in degrees, and a ur5's."""
    from calib_pin.export.yaml import write_ur_kinematics_yaml

    folder = tmp_path_factory.mktemp("ur10")
    chain = cp.load_chain("ur10")
    params = cp.parameter_model(chain)
    data, truth = simulate_set(sensor_for("cable"), chain, params, 40, seed=4)
    cp.write_measurements(folder / "u.csv", data)
    own = folder / "ur10.yaml"
    write_ur_kinematics_yaml(chain, params.deltas(truth.x), own)
    degrees = folder / "deg.yaml"
    degrees.write_text(re.sub(r"(roll|pitch|yaw): (\S+)", lambda m: f"{m.group(1)}: {math.degrees(float(m.group(2)))}",
                              own.read_text()))
    ur5 = cp.load_chain("ur5")
    other = folder / "ur5.yaml"
    write_ur_kinematics_yaml(ur5, [pin.SE3.Identity()] * 7, other)
    return folder


def test_a_start_in_degrees_or_of_another_ur_arm_is_named(ur10):
    data = ur10 / "u.csv"
    assert prepare("ur10", data, nominal=ur10 / "ur10.yaml").start is not None  # its own: accepted
    with pytest.raises(cp.DataError) as caught:
        prepare("ur10", data, nominal=ur10 / "deg.yaml")
    line = str(caught.value)
    assert line.startswith(f"{ur10 / 'deg.yaml'}: roll, pitch, yaw: degrees, not radians? its angles reach 90")
    assert "the start misses the rows by" in line and "(the catalogue ur10: " in line
    assert line.endswith("give roll, pitch and yaw in radians (x pi/180)")
    with pytest.raises(cp.DataError) as caught:
        prepare("ur10", data, nominal=ur10 / "ur5.yaml")
    line = str(caught.value)
    assert line.startswith(f"{ur10 / 'ur5.yaml'}: kinematics: a ur5's file, not a ur10's? its joint origins are "
                           "within 0.0 mm and 0.00 deg of a ur5's")
    assert line.endswith("give the ur10's own default_kinematics.yaml (or leave --nominal out)")


SHIPPED = ("irb120_default.csv", "irb120_wu2015.csv", "irb120_pose_example.csv", "irb120_contact_example.csv")


@pytest.mark.parametrize("name", SHIPPED)
def test_the_shipped_sets_are_near_a_robot_within_its_tolerances(name):
    """The shipped sets (one of a real IRB120) stay within the explained bound: never refused."""
    calibration = prepare("irb120", ROOT / "robots" / name)
    part = calibration.problem.parts[0]
    found = check.misfit(part, np.zeros(part.n_params), calibration.sets[0].sigma or calibration.noise,
                         calibration.prior)
    assert found.times < 3.0 < check.MISFIT_EXPLAINED


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("nominal_rmse_mm", [2.0, 60.0])
def test_simulated_sets_are_accepted_even_far_from_the_catalogue(chain, params, kind, nominal_rmse_mm, tmp_path):
    """Every kind is accepted; a robot 60 mm from its catalogue is far off, but no usual mistake explains it."""
    data, _ = simulate_set(sensor_for(kind), chain, params, 40, seed=5, nominal_rmse_mm=nominal_rmse_mm)
    cp.write_measurements(tmp_path / "s.csv", data)
    calibration = prepare("irb120", tmp_path / "s.csv")
    part = calibration.problem.parts[0]
    found = check.misfit(part, np.zeros(part.n_params), calibration.sets[0].sigma or calibration.noise,
                         calibration.prior)
    assert (found.times < 3.0) if nominal_rmse_mm == 2.0 else (found.times > check.MISFIT_FAR)


def test_a_set_near_the_nominal_robot_tries_no_reading(sets, monkeypatch):
    """The check costs one Jacobian a set: the readings are tried only for a set far off."""
    tried = []
    monkeypatch.setattr(check, "_explain", lambda *args: tried.append(args))
    for kind in KINDS:
        prepare("irb120", sets[kind])
    assert tried == []


def test_the_misfit_counts_known_distances_apart_from_the_touches(sets):
    """One distance row far off among many touches is far off (not diluted by the touches)."""
    calibration = prepare("irb120", sets["contact"])
    part = calibration.problem.parts[0]
    sigma = calibration.sets[0].sigma or calibration.noise
    fine = check.misfit(part, np.zeros(part.n_params), sigma, calibration.prior)
    fixtures = part.model.fixtures
    metres = replace(fixtures, distances=tuple((a, b, length * 1e-3) for a, b, length in fixtures.distances))
    moved = replace(part, model=type(part.model)(calibration.chain, calibration.params, metres))
    far = check.misfit(moved, np.zeros(moved.n_params), sigma, calibration.prior)
    assert fine.times < 3.0 and far.times > 100 and "known distances" in far.text


def test_drawstring_lengths_and_tool_points_in_metres_are_named(sets, tmp_path):
    """The same records serve every sensor: a drawstring's readings, its tool point and a
    contact set's tool point, each in metres."""
    anchor = "# anchor_mm: 600.000000, 200.000000, -100.000000\n"
    free = _meta(sets["cable"], tmp_path / "free.csv", anchor, "")  # the anchor pre-fitted on the readings
    line = _refusal(_columns(free, tmp_path / "len.csv", ("length_mm",), lambda v: f"{v * 1e-3:.9f}"))
    assert ": length_mm: metres in mm columns? every value" in line and line.endswith("name the columns length_m")
    path = _meta(sets["cable"], tmp_path / "t.csv", "# tool_mm: 0.000000, 0.000000, 50.000000", "# tool_mm: 0, 0, 0.05")
    assert _refusal(path).startswith(f"{path}:4: tool_mm: metres, not mm? 0,0,0.05 mm (the file's)")
    path = _meta(sets["contact"], tmp_path / "k.csv", "# noise_mm", "# tool_mm: 0.01, -0.005, 0.06\n# noise_mm")
    assert _refusal(path).startswith(f"{path}:4: tool_mm: metres, not mm? 0.01,-0.005,0.06 mm (the file's)")

"""The calibration file: written beside the URDF, read back as the same calibrated robot."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.calibration.record import write_calibration
from calib_pin.export.calibration_file import calibration_path
from calib_pin.robot.deflection import ComplianceSpec
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import setup_record

JOINTS_23 = ("joint_2", "joint_3")
TRUE_C = np.array([2.5e-5, 4e-5])
POINTS = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]])


@pytest.fixture(scope="module")
def cable_result(chain, params):
    """LM with compliance of joints 2, 3 on a simulated drawstring set with a 5 N pull."""
    spec = ComplianceSpec(JOINTS_23, cable_tension_n=5.0)
    data, _ = cp.simulate(chain, params, 80, seed=3, compliance=spec, true_compliance=TRUE_C)
    return cp.calibrate("irb120", data, method="lm", compliance=cp.Compliance(JOINTS_23, cable_tension_n=5.0),
                        setup=setup_record(estimate=("anchor",)))


def test_round_trip_positions(chain, params, tmp_path):
    """forward(q) of the loaded file is the result's own prediction of end-frame points
    (position and orientation), and .model is the result's geometric model."""
    data, _ = cp.simulate_positions(chain, params, 30, seed=4, compliance=ComplianceSpec(JOINTS_23),
                                    true_compliance=TRUE_C)
    result = cp.calibrate("irb120", data, method="lm", compliance="joint_2,joint_3")
    path = write_calibration(result, calibration_path(tmp_path, "irb120"))
    robot = cp.load_calibration(tmp_path)  # the folder finds the file
    q = random_poses(chain, 20, np.random.default_rng(0))
    frames = robot.forward(q)
    for point in POINTS:
        expected = result.sets[0].model.points_at(result.x, q, point)
        assert np.abs(np.array([f.act(point) for f in frames]) - expected).max() < 1e-12
    assert isinstance(robot.forward(q[0]), pin.SE3)
    a, b = robot.model, result.model
    for k in range(a.njoints):
        assert np.allclose(a.jointPlacements[k].homogeneous, b.jointPlacements[k].homogeneous, atol=1e-15)
    doc = json.loads(path.read_text())
    assert doc["robot"] == "irb120" and doc["end_frame"] == "tool0" and doc["parameter_model"] == "dh"
    assert set(doc["compliance"]["compliance_rad_per_Nm"]) == set(JOINTS_23)
    assert "device_frame" in doc["sensor"] and doc["calibration"]["method"] == "lm"
    assert set(doc["versions"]) == {"calib_pin", "pinocchio", "numpy"}
    assert np.isclose(doc["deviations"]["a_2_mm"], doc["deviations_si"]["a_2"] * 1e3)


def test_round_trip_cable_pull(cable_result, chain, tmp_path):
    """With cable=True the deflection carries the drawstring's pull as in the calibration;
    by default (the arm in use, no sensor) it does not."""
    result = cable_result
    path = write_calibration(result, tmp_path / "irb120_calibration.json")
    q = random_poses(chain, 15, np.random.default_rng(1))
    tool = result.sets[0].model.sensor.tool
    expected = result.sets[0].model.points_at(result.x, q, tool)
    measured_arm = cp.load_calibration(path, cable=True)
    in_use = cp.load_calibration(path, "irb120")
    assert np.abs(np.array([f.act(tool) for f in measured_arm.forward(q)]) - expected).max() < 1e-12
    assert np.abs(np.array([f.act(tool) for f in in_use.forward(q)]) - expected).max() > 1e-6


def test_refusals(cable_result, tmp_path):
    path = write_calibration(cable_result, tmp_path / "irb120_calibration.json")
    with pytest.raises(cp.CalibPinError, match="not 'ur5'"):
        cp.load_calibration(path, "ur5")
    with pytest.raises(cp.CalibPinError, match="no such calibration file"):
        cp.load_calibration(tmp_path / "missing.json")
    with pytest.raises(cp.CalibPinError, match="no \\*_calibration.json"):
        (tmp_path / "empty").mkdir()
        cp.load_calibration(tmp_path / "empty")
    doc = json.loads(path.read_text())
    doc["urdf_sha256"] = "0" * 64
    other = tmp_path / "other" / "irb120_calibration.json"
    other.parent.mkdir()
    other.write_text(json.dumps(doc))
    with pytest.raises(cp.CalibPinError, match="not the one calibrated"):
        cp.load_calibration(other)
    other.write_text("{}")
    with pytest.raises(cp.CalibPinError, match="not a calib-pin calibration"):
        cp.load_calibration(other)

"""Robots resolve by calib-pin name, example-robot-data name or URDF path."""

import pytest

import calib_pin as cp
from calib_pin.robot import resolve_robot
from calib_pin.robot.description import ROBOTS_DIR


def test_own_robot_has_urdf_dh_and_default_data():
    """irb120 resolves to the shipped URDF, a 6-row DH table and a default data set."""
    d = resolve_robot("irb120")
    assert d.urdf == ROBOTS_DIR / "irb120.urdf"
    assert d.end_frame == "tool0"
    assert d.dh is not None and d.dh.n_joints == 6
    assert d.default_data is not None and d.default_data.is_file()


def test_example_robot_data_name():
    """ur5 resolves to example-robot-data's URDF, whose tool0 is the end frame."""
    d = resolve_robot("ur5")
    assert d.urdf.is_file() and d.end_frame == "tool0" and d.dh is None


def test_urdf_path():
    """A URDF path resolves to itself, named by its stem."""
    d = resolve_robot(str(ROBOTS_DIR / "irb120.urdf"))
    assert d.name == "irb120" and d.end_frame == "tool0"


def test_unknown_robot_lists_choices():
    """An unknown name says what the valid kinds of names are."""
    with pytest.raises(cp.RobotError, match="unknown robot 'nosuchbot'.*irb120"):
        resolve_robot("nosuchbot")


def test_missing_urdf_path():
    """A .urdf path that does not exist is named in the error."""
    with pytest.raises(cp.RobotError, match="no such URDF file"):
        resolve_robot("/nowhere/robot.urdf")

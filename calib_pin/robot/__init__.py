"""The robot: where its description comes from, its serial chain, and the one FK path."""

from .chain import Chain, load_chain
from .description import DHTable, RobotDescription, resolve_robot
from .kinematics import Kinematics

__all__ = ["Chain", "DHTable", "Kinematics", "RobotDescription", "load_chain", "resolve_robot"]

"""Writing a calibrated robot in the formats a robot stack reads: the corrected URDF
(:mod:`.urdf`), joint-origin YAML for xacro and ur_description (:mod:`.yaml`), and the
corrected DH table (:mod:`.dh`); the atomic writer of a run's files (:mod:`.outputs`) and
what a calibration writes, all of it or none (:mod:`.bundle`, ``write_outputs``)."""

from .dh import write_dh_table
from .urdf import write_calibrated_urdf
from .yaml import write_joint_origins_yaml, write_ur_kinematics_yaml

__all__ = ["write_calibrated_urdf", "write_dh_table", "write_joint_origins_yaml", "write_ur_kinematics_yaml"]

"""Writing a calibrated robot in the formats a robot stack reads: the corrected URDF
(:mod:`.urdf`), joint-origin YAML for xacro and ur_description (:mod:`.yaml`), and the
corrected DH table (:mod:`.dh`)."""

from .dh import write_dh_table
from .urdf import write_calibrated_urdf
from .yaml import write_joint_origins_yaml, write_ur_kinematics_yaml

__all__ = ["write_calibrated_urdf", "write_dh_table", "write_joint_origins_yaml", "write_ur_kinematics_yaml"]

"""Writing a calibrated robot in the formats a robot stack reads.

The corrected URDF (:mod:`.urdf`), joint-origin YAML for xacro and ur_description
(:mod:`.yaml`), and the corrected DH table (:mod:`.dh`); the atomic writer of a run's
files (:mod:`.outputs`) and what a calibration writes, all of it or none (:mod:`.bundle`,
``write_outputs``).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

#: Public name -> the submodule that defines it; each is imported on first use, so a run
#: that writes only the URDF loads neither PyYAML nor the DH table's module.
_API = {"write_calibrated_urdf": "urdf", "write_dh_table": "dh", "write_joint_origins_yaml": "yaml",
        "write_ur_kinematics_yaml": "yaml"}


def __getattr__(name: str) -> Any:
    if name in _API:
        value = getattr(importlib.import_module(f".{_API[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


if TYPE_CHECKING:
    from .dh import write_dh_table
    from .urdf import write_calibrated_urdf
    from .yaml import write_joint_origins_yaml, write_ur_kinematics_yaml

__all__ = ["write_calibrated_urdf", "write_dh_table", "write_joint_origins_yaml", "write_ur_kinematics_yaml"]

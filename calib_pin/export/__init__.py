"""Writing a calibrated robot in the formats a robot stack reads."""

from .urdf import write_calibrated_urdf

__all__ = ["write_calibrated_urdf"]

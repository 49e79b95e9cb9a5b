"""Measurement sets: joint angles and sensor values, in memory and as CSV files."""

from .csv_reader import read_measurements
from .csv_writer import write_measurements, write_poses
from .dataset import MeasurementSet

__all__ = ["MeasurementSet", "read_measurements", "write_measurements", "write_poses"]

"""Measurement sets: joint angles and sensor values, in memory and as CSV files."""

from .csv_reader import read_measurements
from .csv_writer import write_measurements, write_poses
from .dataset import MeasurementSet, PointLabel, point_label

__all__ = ["MeasurementSet", "PointLabel", "point_label", "read_measurements", "write_measurements", "write_poses"]

"""Measurement sets: joint angles and sensor values, in memory and as CSV files.

Also what a file of each sensor kind holds (:mod:`.schema`).
"""

from .csv_reader import read_measurements
from .csv_writer import write_measurements, write_poses
from .dataset import MeasurementSet, PointLabel, point_label
from .schema import SCHEMAS, Schema, register_schema

__all__ = ["SCHEMAS", "MeasurementSet", "PointLabel", "Schema", "point_label", "read_measurements", "register_schema",
           "write_measurements", "write_poses"]

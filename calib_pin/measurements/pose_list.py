"""The pose list: the joint angles a robot is to visit.

``pose`` optional, default 1..n, and one column per joint, in the CSV layout of
:func:`.csv_reader.read_measurements` without readings, as ``calib-pin poses`` writes it
(:func:`.csv_writer.write_poses`) and ``collect``, ``simulate --poses`` and ``compensate``
read it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..robot.chain import Chain
from .csv_reader import read_measurements
from .dataset import MeasurementSet

__all__ = ["read_pose_list"]


def read_pose_list(path: str | Path, chain: Chain) -> MeasurementSet:
    """A pose list: ``pose`` (optional, default 1..n) and joint columns, within limits.

    Args:
        path: The CSV file.
        chain: The robot chain the joints and limits are read for.

    Raises:
        DataError: as :func:`calib_pin.measurements.read_measurements`.
    """
    poses = read_measurements(path, chain, readings=False)
    if poses.pose_ids is None:
        poses.pose_ids = np.arange(1, len(poses) + 1)
    return poses

"""Sensors: what a measurement set's values are, predicted from the robot's deviations.

- :class:`.cable.CableModel`: drawstring readings (the paper's sensor), set up by a
  :class:`.cable.CableSetup`;
- :class:`.position.PositionModel`: marker positions from a laser tracker or CMM, set up
  by a :class:`.position.PositionSetup`.;
- :class:`.pose.PoseModel`: 6-D poses (position and quaternion) from a tracker's 6-DoF
  probe or motion capture, set up by a :class:`.pose.PoseSetup`;
- :class:`.contact.ContactModel`: touches of fixed points and planes (no instrument), set
  up by a :class:`.contact.ContactSetup`;
- :class:`.camera.CameraModel`: a board's corners in a camera's images (eye in hand or eye
  to hand), set up by a :class:`.camera.CameraSetup`.

The registry :data:`SENSORS` maps a measurement set's ``kind`` to its model; what a
file of each kind holds (value columns, metadata keys) is the model's ``schema``, a
record of :data:`calib_pin.measurements.schema.SCHEMAS`, which the CSV layer asks without
importing the sensors. Everything else asks :data:`SENSORS`: the pipeline for a kind's
set-up record, the CLI for its flags (:func:`add_sensor_arguments`). Adding a sensor is
one module (a subclass of :class:`.base.MeasurementModel` with its
:class:`~calib_pin.measurements.schema.Schema` and :class:`.setup.SensorSetup`) and one
entry here (or :func:`register` at run time).
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable, Mapping
from typing import Any

from ..measurements.schema import default_kind
from .base import DEFAULT_NOISE_MM, MeasurementModel, NoisePart
from .cable import CABLE_EXTRAS, CableModel, CableSetup, Drawstring
from .camera import CameraModel
from .camera_rig import CameraRig, CameraSetup
from .contact import ContactModel, ContactSetup, Fixtures
from .lens import Board, Intrinsics
from .pose import PoseModel, PoseRig, PoseSetup
from .position import PositionDevice, PositionModel, PositionSetup, fit_device
from .registry import SENSORS, check_estimate, register, sensor_for, setup_fields, setup_types
from .setup import SensorSetup, add_setup_arguments, setup_record

for _model in (CableModel, PositionModel, PoseModel, ContactModel, CameraModel):
    register(_model)


def add_sensor_arguments(p: argparse.ArgumentParser, notes: Mapping[str, str] | None = None,
                         skip: Iterable[str] = (), defaults: Mapping[str, Any] | None = None,
                         append: Iterable[str] = ()) -> None:
    """Add every registered sensor's set-up flags to ``p``, one argument group a sensor.

    A field two sensors share comes once; ``append``: fields given once per session; see
    :func:`.setup.add_setup_arguments`.
    """
    add_setup_arguments(p, setup_types(), notes, skip, defaults, append)


def setup_from_args(args: argparse.Namespace) -> dict[str, Any]:
    """The set-up flags of parsed ``args`` as loose keyword options (field -> value)."""
    return {name: getattr(args, name) for name in setup_fields() if hasattr(args, name)}


__all__ = ["CABLE_EXTRAS", "DEFAULT_NOISE_MM", "NoisePart", "SENSORS", "Board", "CableModel", "CableSetup", "CameraModel",
           "CameraRig", "CameraSetup", "ContactModel", "ContactSetup", "Intrinsics",
           "Fixtures", "Drawstring", "MeasurementModel",
           "PoseModel", "PoseRig", "PoseSetup", "PositionDevice",
           "PositionModel", "PositionSetup", "SensorSetup", "add_sensor_arguments", "check_estimate", "default_kind",
           "fit_device", "register", "sensor_for", "setup_fields", "setup_from_args", "setup_record", "setup_types"]

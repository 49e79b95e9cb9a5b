"""Sensors: what a measurement set's values are, predicted from the robot's deviations.

- :class:`.cable.CableModel`: drawstring readings (the paper's sensor);
- :class:`.position.PositionModel`: marker positions from a laser tracker or CMM.

The registry :data:`SENSORS` maps a measurement set's ``kind`` to its model; adding a
sensor means adding a subclass of :class:`.base.MeasurementModel` here and its columns
to the CSV reader, nothing else.
"""

from __future__ import annotations

from .base import MeasurementModel
from .cable import CABLE_EXTRAS, CableModel, Drawstring
from .position import PositionDevice, PositionModel, fit_device

#: Measurement-set kind -> the measurement model that predicts it.
SENSORS: dict[str, type[MeasurementModel]] = {CableModel.kind: CableModel, PositionModel.kind: PositionModel}


def sensor_for(kind: str) -> type[MeasurementModel]:
    """The measurement model of a measurement set's ``kind``."""
    return SENSORS[kind]


__all__ = ["CABLE_EXTRAS", "SENSORS", "CableModel", "Drawstring", "MeasurementModel", "PositionDevice",
           "PositionModel", "fit_device", "sensor_for"]

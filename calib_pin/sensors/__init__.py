"""Sensors: what a measurement set's values are, predicted from the robot's deviations.

- :class:`.cable.CableModel`: drawstring readings (the paper's sensor), set up by a
  :class:`.cable.CableSetup`;
- :class:`.position.PositionModel`: marker positions from a laser tracker or CMM, set up
  by a :class:`.position.PositionSetup`.;
- :class:`.pose.PoseModel`: 6-D poses (position and quaternion) from a tracker's 6-DoF
  probe or motion capture, set up by a :class:`.pose.PoseSetup`;
- :class:`.contact.ContactModel`: touches of fixed points and planes (no instrument), set
  up by a :class:`.contact.ContactSetup`.

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

from ..exceptions import ArgumentError
from ..measurements.schema import default_kind, register_schema
from .base import DEFAULT_NOISE_MM, MeasurementModel, NoisePart
from .cable import CABLE_EXTRAS, CableModel, CableSetup, Drawstring
from .contact import ContactModel, ContactSetup, Fixtures
from .pose import PoseModel, PoseRig, PoseSetup
from .position import PositionDevice, PositionModel, PositionSetup, fit_device
from .setup import SensorSetup, add_setup_arguments, given

#: Measurement-set kind -> the measurement model that predicts it.
SENSORS: dict[str, type[MeasurementModel]] = {CableModel.kind: CableModel, PositionModel.kind: PositionModel}
SENSORS[PoseModel.kind] = PoseModel
SENSORS[ContactModel.kind] = ContactModel


def sensor_for(kind: str) -> type[MeasurementModel]:
    """The measurement model of a measurement set's ``kind``."""
    return SENSORS[kind]


def register(model: type[MeasurementModel]) -> type[MeasurementModel]:
    """Add a sensor to :data:`SENSORS` under its ``kind``, and its schema to
    :data:`~calib_pin.measurements.schema.SCHEMAS` (a plug-in's one line; usable as a
    class decorator). Returns the model."""
    register_schema(model.schema)
    SENSORS[model.kind] = model
    return model


def setup_types() -> tuple[type[SensorSetup], ...]:
    """Every registered sensor's set-up record type, in registry order."""
    return tuple(dict.fromkeys(m.setup_type for m in SENSORS.values()))


def setup_fields() -> tuple[str, ...]:
    """Every field name of the registered set-up records, each once."""
    return tuple(dict.fromkeys(n for t in setup_types() for n in t.field_names()))


def check_estimate(estimate: Any) -> tuple[str, ...]:
    """The sensor unknowns named in ``estimate`` (a comma-separated str or a sequence of
    names; blanks dropped).

    Raises:
        ArgumentError: not names, or a name no sensor can estimate.
    """
    from ..util.arguments import as_names

    valid = tuple(dict.fromkeys(e for s in SENSORS.values() for e in s.estimable))
    names = as_names(estimate, "estimate")
    for e in names:
        if e not in valid:
            raise ArgumentError("estimate", f"cannot estimate '{e}' (valid: {', '.join(valid)})")
    return names


def setup_record(setup: Any = None, **loose: Any) -> SensorSetup | None:
    """The caller's sensor set-up as one record: ``setup`` (a record), with the loose
    keyword options (``anchor_mm=...``, the shorthand) laid over it; without ``setup``,
    the first registered record that has every loose option given; None when nothing is given.

    Raises:
        ArgumentError: ``setup`` is no set-up record, or a loose option it (or any) has no field for.
    """
    import dataclasses

    chosen = {k: v for k, v in loose.items() if given(v)}
    if setup is not None:
        if not isinstance(setup, SensorSetup):
            names = ", ".join(t.__name__ for t in setup_types())
            raise ArgumentError("setup", f"expected a sensor set-up record ({names}), got {type(setup).__name__}")
        own = set(setup.field_names())
        for name in chosen:
            if name not in own:
                raise ArgumentError(name, f"is not an option of {type(setup).__name__} (its fields: {', '.join(own)})")
        return dataclasses.replace(setup, **chosen) if chosen else setup
    if not chosen:
        return None
    for record in setup_types():
        if set(chosen) <= set(record.field_names()):
            return record(**chosen)
    unknown = sorted(set(chosen) - set(setup_fields()))
    raise ArgumentError(unknown[0] if unknown else "setup",
                        "options of different sensors given together: pass one sensor's set-up")


def add_sensor_arguments(p: argparse.ArgumentParser, notes: Mapping[str, str] | None = None,
                         skip: Iterable[str] = (), defaults: Mapping[str, Any] | None = None,
                         append: Iterable[str] = ()) -> None:
    """Add every registered sensor's set-up flags to ``p``, one argument group a sensor
    (a field two sensors share once; ``append``: fields given once per session); see
    :func:`.setup.add_setup_arguments`."""
    add_setup_arguments(p, setup_types(), notes, skip, defaults, append)


def setup_from_args(args: argparse.Namespace) -> dict[str, Any]:
    """The set-up flags of parsed ``args`` as loose keyword options (field -> value)."""
    return {name: getattr(args, name) for name in setup_fields() if hasattr(args, name)}


__all__ = ["CABLE_EXTRAS", "DEFAULT_NOISE_MM", "NoisePart", "SENSORS", "CableModel", "CableSetup", "ContactModel", "ContactSetup",
           "Fixtures", "Drawstring", "MeasurementModel",
           "PoseModel", "PoseRig", "PoseSetup", "PositionDevice",
           "PositionModel", "PositionSetup", "SensorSetup", "add_sensor_arguments", "check_estimate", "default_kind",
           "fit_device", "register", "sensor_for", "setup_fields", "setup_from_args", "setup_record", "setup_types"]

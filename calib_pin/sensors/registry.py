"""The sensor registry: measurement-set kind -> the measurement model that predicts it.

It holds the models, not their modules: :mod:`calib_pin.sensors` registers the built-in ones
in order (drawstring, position, 6-D pose, contact), and a plug-in its own with
:func:`register`. Everything else asks it: the pipeline for a kind's model, the set-up
records for the unknowns a sensor can estimate, the command line for the flags.
"""

from __future__ import annotations

from typing import Any

from ..exceptions import ArgumentError
from ..measurements.schema import register_schema
from ..util.arguments import as_names

#: Measurement-set kind -> the measurement model (a subclass of
#: :class:`calib_pin.sensors.base.MeasurementModel`) that predicts it, in registration order.
SENSORS: dict[str, Any] = {}


def sensor_for(kind: str) -> Any:
    """The measurement model of a measurement set's ``kind``."""
    return SENSORS[kind]


def register(model: Any) -> Any:
    """Add a sensor to :data:`SENSORS` under its ``kind``, and its schema to the schemas.

    The schema goes to :data:`~calib_pin.measurements.schema.SCHEMAS`. A plug-in's one
    line; usable as a class decorator. Returns the model.
    """
    register_schema(model.schema)
    SENSORS[model.kind] = model
    return model


def setup_types() -> tuple[Any, ...]:
    """Every registered sensor's set-up record type, in registry order."""
    return tuple(dict.fromkeys(m.setup_type for m in SENSORS.values()))


def setup_fields() -> tuple[str, ...]:
    """Every field name of the registered set-up records, each once."""
    return tuple(dict.fromkeys(n for t in setup_types() for n in t.field_names()))


def check_estimate(estimate: Any) -> tuple[str, ...]:
    """The sensor unknowns named in ``estimate``; blanks dropped.

    Args:
        estimate: A comma-separated str or a sequence of names.

    Raises:
        ArgumentError: not names, or a name no sensor can estimate.
    """
    valid = tuple(dict.fromkeys(e for s in SENSORS.values() for e in s.estimable))
    names = as_names(estimate, "estimate")
    for e in names:
        if e not in valid:
            raise ArgumentError("estimate", f"cannot estimate '{e}' (valid: {', '.join(valid)})")
    return names

"""A sensor's set-up options as one record, and the CLI flags built from it.

Each sensor module defines its options as one frozen dataclass (``CableSetup``,
``PositionSetup``), its fields made with :func:`option`: the field's metadata carries the
help text, the unit and the argparse parser of its ``--flag``. The record is validated
once, in ``__post_init__``, and turned into the options mapping a sensor's
``problem_for`` reads with :meth:`SensorSetup.options`. :func:`add_setup_arguments` adds
the flags of a record's fields to a parser as an argument group.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
from collections.abc import Callable, Iterable, Mapping
from typing import Any, ClassVar

import numpy as np

from ..exceptions import ArgumentError
from .registry import check_estimate, setup_fields, setup_types

# --- the flags' parsers (argparse types; the CLI's other flags use them too) ---

#: The largest magnitude a flag's length takes, [mm] (:data:`calib_pin.util.arguments.MAX_MM`: 1 km,
#: beyond it a unit mistake).
FLAG_MAX_MM = 1e6


def xyz_mm(text: str) -> tuple[float, float, float]:
    """``x,y,z`` in mm: three finite numbers, each of magnitude below :data:`FLAG_MAX_MM`."""
    parts = [p for p in text.replace(",", " ").split() if p]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not all(np.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected 3 numbers 'x,y,z' in mm, got '{text[:40]}'")
    if not all(abs(v) < FLAG_MAX_MM for v in values):
        raise argparse.ArgumentTypeError(f"expected 3 numbers 'x,y,z' in mm, each of magnitude below "
                                         f"{FLAG_MAX_MM:.0f} (1 km: a unit mistake?), got '{text[:40]}'")
    return values  # type: ignore[return-value]


@functools.cache
def point_mm(frame: str) -> Callable[[str], tuple[float, float, float]]:
    """The parser of a point of ``frame`` (``"end frame"``: a tool point, ``"base"``: an
    anchor): :func:`xyz_mm`, within :data:`calib_pin.util.arguments.POINT_REACH_MM` of it
    (one parser a frame: every flag of a frame parses alike)."""
    from ..util.arguments import too_far

    def parse(text: str) -> tuple[float, float, float]:
        values = xyz_mm(text)
        why = too_far(values, frame)
        if why is not None:
            raise argparse.ArgumentTypeError(why)
        return values

    parse.__name__ = f"point_mm({frame!r})"
    return parse


def finite(text: str) -> float:
    """A finite number of magnitude below :data:`FLAG_MAX_MM` (the flags' lengths, mm)."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got '{text[:40]}'")
    if not abs(value) < FLAG_MAX_MM:
        raise argparse.ArgumentTypeError(f"expected a number of magnitude below {FLAG_MAX_MM:.0f} (mm: 1 km, a unit "
                                         f"mistake?), got '{text[:40]}'")
    return value


def estimate_names(text: str) -> tuple[str, ...]:
    """Comma-separated sensor unknowns to estimate."""
    try:
        names = check_estimate(text.split(","))
    except ArgumentError as e:
        raise argparse.ArgumentTypeError(f"{e.reason}, comma-separated") from None
    if not names:
        raise argparse.ArgumentTypeError(f"cannot estimate '{text}' (comma-separated names)")
    return names


def option(default: Any = None, *, help: str, unit: str = "", parser: Callable[[str], Any] | None = None,
           metavar: str | None = None) -> Any:
    """A set-up field with what its ``--flag`` needs.

    ``help`` (for people), ``unit`` (shown after the help), ``parser`` (argparse ``type``;
    None: text).
    """
    return dataclasses.field(default=default,
                             metadata={"help": help, "unit": unit, "parser": parser, "metavar": metavar})


def flag_of(name: str) -> str:
    """``--anchor-mm`` of a field ``anchor_mm``."""
    return "--" + name.replace("_", "-")


@dataclasses.dataclass(frozen=True, eq=False)
class SensorSetup:
    """Base of every sensor's set-up record: the options a caller gives a sensor.

    Each is None (or empty) when not given: the measurement file's, or the sensor's default.
    """

    #: What the record's argument group is called in ``--help``.
    title: ClassVar[str] = "sensor"

    @classmethod
    def from_options(cls, options: Mapping[str, Any]) -> SensorSetup:
        """The record of the loose options among ``options`` (others are ignored)."""
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in options.items() if k in names and v is not None})

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(cls))

    def options(self) -> dict[str, Any]:
        """The record as the options mapping of ``problem_for``."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def given(self) -> dict[str, Any]:
        """The fields the caller set (not None, not empty)."""
        return {k: v for k, v in self.options().items() if given(v)}

    def __eq__(self, other: object) -> bool:
        """Same record type and equal fields (arrays compared by value)."""
        if type(other) is not type(self):
            return NotImplemented
        return all(np.array_equal(np.asarray(a, dtype=object), np.asarray(b, dtype=object))
                   if isinstance(a, np.ndarray) or isinstance(b, np.ndarray) else a == b
                   for a, b in zip(self.options().values(), other.options().values(), strict=True))

    __hash__ = None  # type: ignore[assignment]


def given(value: Any) -> bool:
    """A set-up field the caller gave: not None, not an empty sequence."""
    return value is not None and not (isinstance(value, tuple | list) and len(value) == 0)


def add_setup_arguments(p: argparse.ArgumentParser, setups: Iterable[type[SensorSetup]],
                        notes: Mapping[str, str] | None = None, skip: Iterable[str] = (),
                        defaults: Mapping[str, Any] | None = None, append: Iterable[str] = ()) -> None:
    """Add the ``--flags`` of each record's fields, one argument group per record.

    Args:
        notes: Field name -> text appended to its help (``default: the file's``).
        skip: Field names not to add; a field two records share is added once.
        defaults: Field name -> the flag's default (else the field's).
        append: Field names whose flag may be given once per session (a list).
    """
    append = set(append)
    setups = list(setups)
    notes, defaults, seen = notes or {}, defaults or {}, set(skip)
    for setup in setups:
        fields = [f for f in dataclasses.fields(setup) if f.name not in seen and "help" in f.metadata]
        if not fields:
            continue
        group = p.add_argument_group(f"{setup.title} set-up")
        for f in fields:
            seen.add(f.name)
            meta = f.metadata
            text = meta["help"] + (f", {meta['unit']}" if meta["unit"] else "")
            takers = [other.title for other in setups if f.name in other.field_names()]
            if len(takers) > 1:  # one flag several sensors take: say which
                text += f"; for {' and '.join(takers)} sets"
            if f.name in notes:
                text += f" ({notes[f.name]})"
            elif f.name in defaults:
                given = defaults[f.name]
                text += f" (default {format(given, 'g') if isinstance(given, float) else given})"
            default = defaults.get(f.name, () if f.default == () else None)
            if f.name in append:
                text += "; with --sessions K, give it once per session, or leave it out"
            kwargs: dict[str, Any] = {"default": default, "help": text}
            if f.name in append:
                kwargs["action"] = "append"
            if meta["parser"] is not None:
                kwargs["type"] = meta["parser"]
            if meta["metavar"]:
                kwargs["metavar"] = meta["metavar"]
            group.add_argument(flag_of(f.name), **kwargs)


def setup_record(setup: Any = None, **loose: Any) -> SensorSetup | None:
    """The caller's sensor set-up as one record; None when nothing is given.

    ``setup`` (a record), with the loose keyword options laid over it; without ``setup``,
    the first registered record that has every loose option given.

    Args:
        setup: A sensor's set-up record (:class:`~calib_pin.sensors.CableSetup`, ...), or None.
        loose: Loose set-up options, the shorthand (``anchor_mm=...`` [mm]).

    Raises:
        ArgumentError: ``setup`` is no set-up record, or a loose option it (or any) has no field for.
    """
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

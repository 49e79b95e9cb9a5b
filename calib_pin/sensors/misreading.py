"""The usual unit and order mistakes of a measurement set, each a frozen record.

A :class:`Misreading` is one usual mistake (radians in degree columns, metres in mm
columns, an anchor in metres, ...). Given what was read (a :class:`Suspect`) it gives the
readings that would undo it, each a :class:`Reading`: the set, its options or its start
read the other way, and how to say so. It gives none where the mistake cannot have
happened (angles beyond the joints' limits in radians were not radians).

Each sensor lists its own in ``MeasurementModel.misreadings`` (a calibration's start
lists its own in :data:`calib_pin.calibration.start.START_MISREADINGS`). The pre-fit
misfit check (:mod:`calib_pin.calibration.misfit`) tries them on a set the nominal robot
misses far more than a robot within its tolerances would, and names the one that
explains the misfit.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..util.arguments import CONTINUOUS_TURNS, LIMIT_TOLERANCE, outside_limits, too_far

if TYPE_CHECKING:
    from ..measurements import MeasurementSet
    from ..measurements.checks import FileHeader
    from ..parameters import ParameterModel
    from ..robot.chain import Chain


@dataclass(frozen=True)
class Suspect:
    """What a misreading may read another way: a set as prepared, or a calibration's start.

    Attributes:
        chain, params: The robot and its parameter model.
        data: The measurement set, as read.
        options: Its sensor options (the caller's set-up values, in mm).
        problem: Its problem as prepared: the sensor's start geometry fitted with the
            nominal robot (a :class:`~calib_pin.sensors.problem.SetProblem`).
        header: The set's file's metadata lines and columns, or None (a set in memory).
        start: The calibration's start (``--nominal``), or None.
    """

    chain: Chain
    params: ParameterModel
    data: MeasurementSet
    options: Mapping[str, Any]
    problem: Any
    header: FileHeader | None = None
    start: Any = None


@dataclass(frozen=True)
class Reading:
    """A set (or a start) read without one usual mistake, and how to say it.

    Attributes:
        cause: The likely mistake, for people (``radians in degree columns``).
        field: The column(s) or key at fault (``q1_deg..q6_deg``), or None.
        line: The file's line at fault (a metadata line), or None.
        shown: What was given that looks so (``every value is within ...``).
        read_as: How it is read here (``read as radians``).
        fix: What to do.
        data, options: The set and its options so read (None: as given).
        robot_x: The start's robot deviations so read (None: as given; zeros: the
            catalogue robot).
    """

    cause: str
    field: str | None
    line: int | None
    shown: str
    read_as: str
    fix: str
    data: MeasurementSet | None = None
    options: Mapping[str, Any] | None = None
    robot_x: np.ndarray | None = None


@dataclass(frozen=True)
class Misreading:
    """One usual mistake: the readings of a suspect that would undo it.

    Attributes:
        name: The mistake, for people and tests.
        readings: The readings of a :class:`Suspect` without the mistake; none where it
            cannot have been made.
    """

    name: str
    readings: Callable[[Suspect], Iterator[Reading]]


_JOINT_DEG = re.compile(r"^q(\d+)_deg$")


def _span(columns: list[str]) -> str:
    return columns[0] if len(columns) == 1 else f"{columns[0]}..{columns[-1]}"


def _radians(s: Suspect) -> Iterator[Reading]:
    """The joint angles of ``q<k>_deg`` columns read as radians, when they are within the
    joints' limits so read (a turn each way, twice, for a joint without limits)."""
    if s.header is None:
        return
    columns = [c for c in s.header.columns if _JOINT_DEG.match(c)]
    joints = [int(_JOINT_DEG.match(c).group(1)) - 1 for c in columns]  # type: ignore[union-attr]
    if not joints or max(joints) >= s.chain.n_joints:
        return
    written = np.degrees(np.asarray(s.data.q, dtype=float)[:, joints])
    turns = 2 * math.pi * CONTINUOUS_TURNS
    lower = np.maximum(s.chain.lower[joints], -turns)
    upper = np.minimum(s.chain.upper[joints], turns)
    if outside_limits(written, lower, upper, LIMIT_TOLERANCE) is not None:
        return
    q = np.array(s.data.q, dtype=float)
    q[:, joints] = written
    yield Reading("radians in degree columns", _span(columns), None,
                  f"every angle ({written.min():.4g} to {written.max():.4g}) is within the joints' limits in radians",
                  "read as radians", f"convert them to degrees, or name the columns "
                  f"{_span([c.replace('_deg', '_rad') for c in columns])}", data=replace(s.data, q=q))


#: A measuring device reads a point at most this far from its origin, [mm]: values of mm
#: columns that would all be within it in metres may be metres.
DEVICE_REACH_MM = 20000.0


def _metres(s: Suspect) -> Iterator[Reading]:
    """The values of ``<name>_mm`` columns read as metres, when every one would be within a
    device's reach (:data:`DEVICE_REACH_MM`) so read."""
    from ..measurements.schema import SCHEMAS

    schema = SCHEMAS.get(s.data.kind)
    if s.header is None or schema is None or not schema.value_columns:
        return
    columns = [f"{name}_mm" for name in schema.value_columns]
    if not set(columns) <= set(s.header.columns):
        return
    values = np.array(s.data.values, dtype=float)
    part = values.reshape(len(values), -1)[:, : len(columns)]  # a view: the value columns come first
    written = part * 1e3
    if not np.all(np.abs(written) * 1e3 <= DEVICE_REACH_MM):
        return
    part *= 1e3
    yield Reading("metres in mm columns", ", ".join(columns), None,
                  f"every value ({written.min():.4g} to {written.max():.4g}) is within {DEVICE_REACH_MM * 1e-3:g} "
                  "m in metres", "read as metres", f"give millimetres (x 1000), or name the columns "
                  f"{', '.join(c.replace('_mm', '_m') for c in columns)}", data=replace(s.data, values=values))


#: Every sensor's: its joint columns.
RADIANS_IN_DEGREE_COLUMNS = Misreading("radians in degree columns", _radians)
#: Every sensor's whose values are lengths (``length_mm``; ``x_mm``, ``y_mm``, ``z_mm``).
METRES_IN_MM_COLUMNS = Misreading("metres in mm columns", _metres)


def setup_in_metres(*points: tuple[str, str]) -> Misreading:
    """The misreading of set-up points given in metres where mm are expected.

    Args:
        points: (key, frame) of each point of the sensor's set-up (``("anchor_mm",
            "base")``, ``("tool_mm", "end frame")``): read x 1000 when that is within
            the frame's reach (:data:`~calib_pin.util.arguments.POINT_REACH_MM`).
    """

    def readings(s: Suspect) -> Iterator[Reading]:
        from .registry import sensor_for

        record = sensor_for(s.data.kind).setup_of(s.data)
        for key, frame in points:
            given = s.options.get(key)
            value = given if given is not None else getattr(record, key, None) if record is not None else None
            if value is None:
                continue
            mm = np.asarray(value, dtype=float).reshape(-1)
            if too_far(mm * 1e3, frame) is not None or not np.any(mm):
                continue
            shown = ",".join(f"{v:g}" for v in mm)
            line = None if given is not None or s.header is None else s.header.keys.get(key)
            origin = "given" if given is not None else "the file's"
            yield Reading("metres, not mm", key, line, f"{shown} mm ({origin})",
                          f"with {','.join(f'{v * 1e3:g}' for v in mm)} mm",
                          f"give it in mm ({','.join(f'{v * 1e3:g}' for v in mm)})",
                          options={**s.options, key: mm * 1e3})

    return Misreading("set-up points in metres", readings)

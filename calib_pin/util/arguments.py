"""Checks of the public functions' arguments: each wrong argument is one error naming it.

The error is an :class:`~calib_pin.exceptions.ArgumentError`, never a numpy, Pinocchio or
plain Python error from deep inside.

Every validator takes the value and the argument's name (as the caller wrote it, e.g.
``q`` or ``anchor_mm``) and returns the value in the form the function works with.
Units are those of the argument: ``as_xyz_mm`` takes [mm], ``as_angles_rad`` [rad]
(prismatic joints [m]).
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import ArgumentError

#: Largest coordinate accepted in [mm] (a kilometre: a bigger one is a unit mistake).
MAX_MM = 1e6
#: How far from its frame a point given to calib-pin may be, [mm]: a point of the tool (the
#: tool point, a payload's centre of mass) 2 m from the end frame, a sensor's anchor 20 m
#: from the robot's base. Farther is a unit or frame mistake (a 5 m tool), refused where
#: the point enters: a flag, a set-up record, a file's metadata, a simulation.
POINT_REACH_MM = {"end frame": 2000.0, "base": 20000.0}
#: Turns a continuous joint (no limits) may be given, each way.
CONTINUOUS_TURNS = 2
#: How far outside its URDF limits a joint angle is accepted, [rad] or [m]: the
#: tolerance of the measurement reader (:mod:`calib_pin.measurements.checks`).
LIMIT_TOLERANCE = 1e-9


def shown_value(value: Any) -> str:
    """A value for a message: its type for containers, a short repr otherwise."""
    if isinstance(value, (str, bytes)):
        text = repr(value)
        return text if len(text) <= 40 else text[:40] + "...'"
    if isinstance(value, (numbers.Number, type(None))):
        return repr(value)
    shape = getattr(value, "shape", None)
    return f"{type(value).__name__}{' of shape ' + str(tuple(shape)) if shape is not None else ''}"


def as_path(value: Any, arg: str) -> Path:
    """A file or folder path (str or os.PathLike)."""
    if isinstance(value, (str, os.PathLike)) and str(value).strip():
        return Path(value)
    raise ArgumentError(arg, f"expected a file path (str or pathlib.Path), got {shown_value(value)}")


def as_bool(value: Any, arg: str) -> bool:
    """True or False (numpy's bool too; not 0/1 nor text)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise ArgumentError(arg, f"expected True or False, got {shown_value(value)}")


def as_int(value: Any, arg: str, low: int | None = 0, high: int | None = None) -> int:
    """A whole number in [low, high] (an int or a numpy integer; not a bool, float or text)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise ArgumentError(arg, f"expected a whole number, got {shown_value(value)}")
    number = int(value)
    if (low is not None and number < low) or (high is not None and number > high):
        span = f"from {low}" if high is None else f"from {low} to {high}" if low is not None else f"up to {high}"
        raise ArgumentError(arg, f"expected a whole number {span}, got {number}")
    return number


def as_float(value: Any, arg: str, low: float | None = None, high: float | None = None, *,
             low_open: bool = False, high_open: bool = False, unit: str = "") -> float:
    """A finite real number in the range given (``low_open``: ``low`` itself excluded)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ArgumentError(arg, f"expected a number{' in ' + unit if unit else ''}, got {shown_value(value)}")
    number = float(value)
    if not math.isfinite(number):
        raise ArgumentError(arg, f"expected a finite number, got {number}")
    below = low is not None and (number <= low if low_open else number < low)
    above = high is not None and (number >= high if high_open else number > high)
    if below or above:
        left = "(" if low_open else "["
        right = ")" if high_open else "]"
        span = f"{left}{'-inf' if low is None else f'{low:g}'}, {'inf' if high is None else f'{high:g}'}{right}"
        raise ArgumentError(arg, f"expected a number in {span}{' ' + unit if unit else ''}, got {number:g}")
    return number + 0.0  # -0.0 is 0.0 (numpy's scale >= 0 checks refuse a negative zero)


def as_optional(check: Callable[..., Any], value: Any, arg: str, *args: Any, **kwargs: Any) -> Any:
    """None, or ``check(value, arg, ...)``."""
    return None if value is None else check(value, arg, *args, **kwargs)


def as_choice(value: Any, arg: str, choices: Iterable[str]) -> str:
    """One of ``choices`` (text)."""
    valid = tuple(choices)
    if not isinstance(value, str):
        raise ArgumentError(arg, f"expected one of {', '.join(valid)}, got {shown_value(value)}")
    if value not in valid:
        raise ArgumentError(arg, f"unknown {arg.replace('_', ' ')} {shown_value(value)} (valid: {', '.join(valid)})")
    return value


def as_names(value: Any, arg: str) -> tuple[str, ...]:
    """Names: a comma-separated str (``"anchor,offset"``) or a sequence of str; None gives ``()``.

    Blanks around names are dropped; a name given twice is refused (``joint_2,joint_2``
    would make two compliances of one joint, a file compensate refuses), and so is text
    that names nothing (``""``, ``",,"``).
    """
    if value is None:
        return ()
    if isinstance(value, str):
        if not value.replace(",", "").strip():
            raise ArgumentError(arg, f"{shown_value(value)} names nothing: give comma-separated names, or leave "
                                f"{arg} out")
        items: Sequence[Any] = value.split(",")
    elif isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim == 1):
        items = list(value)
    else:
        raise ArgumentError(arg, f"expected names (a comma-separated str or a sequence of str), got {shown_value(value)}")
    names = []
    for item in items:
        if not isinstance(item, str):
            raise ArgumentError(arg, f"expected names as str, got {shown_value(item)} in the sequence")
        if item.strip():
            if item.strip() in names:
                raise ArgumentError(arg, f"'{item.strip()}' is given twice: name each once")
            names.append(item.strip())
    return tuple(names)


def as_array(value: Any, arg: str, shape: Sequence[int | None] | None = None, *, finite: bool = True,
             unit: str = "") -> np.ndarray:
    """A float array of ``shape`` (None: any size on that axis; a shape None: any).

    Refuses text, None, ragged or non-numeric sequences, complex numbers, a wrong shape,
    and (with ``finite``) NaN or infinite entries, naming the first.
    """
    if value is None or isinstance(value, (str, bytes)):
        raise ArgumentError(arg, f"expected numbers{' in ' + unit if unit else ''}, got {shown_value(value)}")
    try:
        raw = np.asarray(value)
    except ValueError:  # ragged nested sequences
        raise ArgumentError(arg, "expected a regular array of numbers (rows of equal length)") from None
    if raw.dtype.kind not in "iuf" and not (raw.dtype.kind == "O" and raw.size == 0):
        what = {"b": "True/False values", "c": "complex numbers", "U": "text", "S": "text"}.get(raw.dtype.kind)
        raise ArgumentError(arg, f"expected real numbers, got {what or 'an array of ' + raw.dtype.name}")
    array = raw.astype(float)
    if shape is not None:
        expected = tuple(shape)
        if array.ndim != len(expected) or any(e is not None and s != e for s, e in zip(array.shape, expected, strict=True)):
            shown = "(" + ", ".join("n" if e is None else str(e) for e in expected) + ("," if len(expected) == 1 else "") + ")"
            raise ArgumentError(arg, f"expected shape {shown}, got shape {array.shape}")
    if finite and not np.all(np.isfinite(array)):
        where = tuple(int(i) for i in np.argwhere(~np.isfinite(array))[0])
        index = f"[{', '.join(map(str, where))}]" if where else ""
        raise ArgumentError(arg, f"{arg}{index} is {array[where]}: expected finite numbers")
    return array


def as_xyz_mm(value: Any, arg: str) -> np.ndarray:
    """A point or offset ``(x, y, z)`` in [mm]: shape (3,), finite, each below 1e6 mm."""
    xyz = as_array(value, arg, (3,), unit="mm")
    if np.abs(xyz).max() >= MAX_MM:
        raise ArgumentError(arg, f"{xyz.tolist()} mm is beyond {MAX_MM:g} mm: a unit mistake? (x, y, z in mm)")
    return xyz


def too_far(xyz_mm: Any, frame: str) -> str | None:
    """Why the point ``xyz_mm`` [mm] of ``frame`` (a key of :data:`POINT_REACH_MM`) is
    refused, or None when it is within reach."""
    xyz = np.asarray(xyz_mm, dtype=float).reshape(-1)
    reach, distance = POINT_REACH_MM[frame], float(np.linalg.norm(xyz))
    if distance <= reach:
        return None
    shown = ",".join(f"{v:g}" for v in xyz)
    return f"{shown} mm is {distance:.6g} mm from the {frame}, beyond the {reach:g} mm a point may be (a unit mistake?)"


def as_point_mm(value: Any, arg: str, frame: str) -> np.ndarray:
    """A point ``(x, y, z)`` [mm] of ``frame`` (``"end frame"``: a tool point, ``"base"``: a
    sensor's anchor) as :func:`as_xyz_mm` takes it, and within :data:`POINT_REACH_MM` of it."""
    xyz = as_xyz_mm(value, arg)
    why = too_far(xyz, frame)
    if why is not None:
        raise ArgumentError(arg, why)
    return xyz


def outside_limits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                   tolerance: float = LIMIT_TOLERANCE) -> tuple[int, ...] | None:
    """Index of the first joint value of q (..., n_joints) outside the limits, or None.

    Outside [lower - tolerance, upper + tolerance]; limits of shape (n_joints,), +-inf for none.
    """
    outside = (q < lower - tolerance) | (q > upper + tolerance)
    if not outside.any():
        return None
    return tuple(int(i) for i in np.argwhere(outside)[0])


def as_instance(value: Any, arg: str, kind: type | tuple[type, ...], what: str) -> Any:
    """``value`` when it is a ``kind``; ``what`` says what was expected (and how to make one)."""
    if not isinstance(value, kind):
        raise ArgumentError(arg, f"expected {what}, got {shown_value(value)}")
    return value


__all__ = ["CONTINUOUS_TURNS", "LIMIT_TOLERANCE", "MAX_MM", "POINT_REACH_MM", "as_array", "as_bool", "as_choice",
           "as_float", "as_instance", "as_int", "as_names", "as_optional", "as_path", "as_point_mm", "as_xyz_mm",
           "outside_limits", "shown_value", "too_far"]

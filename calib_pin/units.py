"""SI values for people: millimetres and degrees, with the unit in the name."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np


def for_humans(x: Iterable[float], names: Iterable[str], units: Iterable[str]) -> dict[str, float]:
    """Values keyed by name with their unit: ``a_2_mm`` for [m], ``theta_6_deg`` for [rad]."""
    out = {}
    for value, name, unit in zip(x, names, units, strict=True):
        if unit == "m":
            out[f"{name}_mm"] = float(value * 1e3)
        else:
            out[f"{name}_deg"] = float(np.rad2deg(value))
    return out


def from_humans(values: Mapping[str, float], names: Iterable[str], units: Iterable[str]) -> np.ndarray:
    """Inverse of :func:`for_humans`: SI values in ``names``' order.

    Raises:
        KeyError: a name missing from ``values``.
    """
    return np.array([values[f"{n}_mm"] * 1e-3 if u == "m" else np.deg2rad(values[f"{n}_deg"])
                     for n, u in zip(names, units, strict=True)])

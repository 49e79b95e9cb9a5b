"""SI values for people: millimetres, degrees and microradians per newton-metre.

The unit is in the name.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

#: SI unit -> (factor to the human unit, suffix of the key): a camera's intrinsics are in
#: pixels (``px``) and its distortion coefficients have no unit (``1``: no suffix).
HUMAN_UNITS = {"m": (1e3, "mm"), "rad": (float(np.rad2deg(1.0)), "deg"), "rad/Nm": (1e6, "urad_per_Nm"),
               "px": (1.0, "px"), "1": (1.0, "")}


def human_unit(unit: str) -> tuple[float, str]:
    """Factor and key suffix of an SI unit (``m`` -> 1e3, ``mm``; ``rad/Nm`` -> 1e6, ``urad_per_Nm``)."""
    return HUMAN_UNITS.get(unit, HUMAN_UNITS["rad"])


def for_humans(x: Iterable[float], names: Iterable[str], units: Iterable[str]) -> dict[str, float]:
    """Values keyed by name with their unit.

    ``a_2_mm`` for [m], ``theta_6_deg`` for [rad], ``compliance_joint_2_urad_per_Nm`` for [rad/Nm].
    """
    out = {}
    for value, name, unit in zip(x, names, units, strict=True):
        factor, suffix = human_unit(unit)
        out[f"{name}_{suffix}" if suffix else name] = float(value * factor)
    return out


def from_humans(values: Mapping[str, float], names: Iterable[str], units: Iterable[str]) -> np.ndarray:
    """Inverse of :func:`for_humans`: SI values in ``names``' order.

    Args:
        values: Values keyed by name with their unit (``a_2_mm``).
        names: The unknowns' names, in order.
        units: Their SI units (``m``, ``rad``, ``rad/Nm``), in the same order.

    Raises:
        KeyError: a name missing from ``values``.
    """
    out = []
    for name, unit in zip(names, units, strict=True):
        factor, suffix = human_unit(unit)
        out.append(values[f"{name}_{suffix}" if suffix else name] / factor)
    return np.array(out)

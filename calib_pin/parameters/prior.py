"""What a robot's deviations are like before any measurement: the prior the data cannot replace.

Some directions of the unknowns leave no trace in the readings (a turn of the whole arm
about a cable's anchor, d_2 - d_3 of parallel joints). A calibration keeps the robot at its
start along them (:mod:`calib_pin.calibration.gauge`), so the robot's true deviation along
them is an error the data cannot show. A :class:`Prior` bounds it: one standard deviation
per length and per angle of a deviation (a manufacturing tolerance), which the predicted
accuracy (:mod:`calib_pin.analysis.accuracy`) carries to the points a user works with.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..exceptions import ArgumentError

#: The largest prior a length or an angle may be given: beyond it no robot is described, [mm], [deg].
MAX_LENGTH_MM = 100.0
MAX_ANGLE_DEG = 10.0


@dataclass(frozen=True)
class Prior:
    """One standard deviation of a robot deviation before any measurement.

    Attributes:
        length_mm: Of a length (a link length, an offset, a translation), [mm].
        angle_deg: Of an angle (a twist, a joint offset, a rotation), [deg].

    Raises:
        ArgumentError: a value that is not a finite number in (0, 100] mm or (0, 10] deg.
    """

    length_mm: float = 1.0
    angle_deg: float = 0.1

    def __post_init__(self) -> None:
        for name, value, top, unit in (("length_mm", self.length_mm, MAX_LENGTH_MM, "mm"),
                                       ("angle_deg", self.angle_deg, MAX_ANGLE_DEG, "deg")):
            ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
            if not ok or not 0 < value <= top:
                raise ArgumentError(f"prior {name}", f"{value!r} is not a number in (0, {top:g}] {unit}")

    def sigma(self, units: Sequence[str], scale: np.ndarray) -> np.ndarray:
        """Each unknown's prior standard deviation, SI, shape (len(units),).

        Each unknown's prior standard deviation, SI, shape (len(units),): lengths ``m`` and
        angles ``rad`` from the prior, any other unit (a compliance) its typical size ``scale``.
        """
        length, angle = self.length_mm * 1e-3, math.radians(self.angle_deg)
        return np.array([length if u == "m" else angle if u == "rad" else float(s)
                         for u, s in zip(units, scale, strict=True)])

    def describe(self) -> str:
        """The prior in words, e.g. ``1 mm and 0.1 deg per deviation``."""
        return f"{self.length_mm:g} mm and {self.angle_deg:g} deg per deviation"

    def as_dict(self) -> dict[str, float]:
        return {"length_mm": self.length_mm, "angle_deg": self.angle_deg}

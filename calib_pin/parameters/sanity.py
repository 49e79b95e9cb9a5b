"""The sanity bounds of a robot's deviations: what no real arm's calibration exceeds.

One place for the bounds :meth:`calib_pin.calibration.result.CalibrationResult.sanity_error` refuses
an export with, and :func:`calib_pin.export.calibration_file.load_calibration` refuses a file with.
"""

from __future__ import annotations

import numpy as np

#: No deviation may exceed these (a real arm's errors are a few mm and tenths of a
#: degree); a larger one means the data could not determine it. [m], [rad].
SANITY_M = 20e-3
SANITY_RAD = float(np.deg2rad(5.0))


def beyond_sanity(value: float, unit: str) -> str | None:
    """Why a deviation ``value`` in SI ``unit`` is outside its sanity bound, else None.

    For example ``+500 mm is beyond the sanity bound 20 mm``; ``unit`` is ``m`` or ``rad``
    (other units: None).
    """
    if unit not in ("m", "rad"):
        return None
    bound = SANITY_M if unit == "m" else SANITY_RAD
    if abs(value) <= bound:
        return None
    factor, shown_unit = (1e3, "mm") if unit == "m" else (float(np.rad2deg(1.0)), "deg")
    return f"{value * factor:+.3g} {shown_unit} is beyond the sanity bound {bound * factor:g} {shown_unit}"

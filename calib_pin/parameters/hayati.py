"""DH deviations with Hayati's tilt for parallel consecutive joint axes."""

from __future__ import annotations

import numpy as np

from ..robot.chain import Chain
from ..robot.description import DHTable
from .dh import DHModel


class HayatiModel(DHModel):
    """DH deviations with Hayati's fix for parallel consecutive joint axes.

    Where joint i+1's axis is parallel to joint i's (DH row i has alpha_i = 0, e.g.
    joints 2 and 3 of the IRB120), a small tilt moves the common normal along the axis
    without bound, so d_i is ill-conditioned. Hayati replaces that row's Δd_i by a
    rotation beta_i about the row's y axis: S_i = Tz(d_i) Tx(a_i) Rx(alpha_i) Ry(beta_i).
    Names: ``beta_<i>`` [rad] in place of ``d_<i>``; everything else as
    :class:`DHModel`. The last row (the end frame) keeps its d.

    Args:
        tolerance: |alpha_i| below this counts as parallel, [rad].
    """

    #: Name on the command line (``--model``).
    name = "hayati"

    def __init__(self, chain: Chain, table: DHTable, scale_m: float = 1e-3, scale_rad: float = 2e-3,
                 tolerance: float = np.deg2rad(1.0)) -> None:
        self.hayati_rows = tuple(
            i for i in range(table.n_joints - 1) if abs(np.arctan2(np.sin(table.alpha[i]), np.cos(table.alpha[i]))) < tolerance
        )
        super().__init__(chain, table, scale_m, scale_rad)

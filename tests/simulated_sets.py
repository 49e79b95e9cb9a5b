"""Seeded rank-deficient measurement sets that are fine to calibrate (issue 20, section 3).

- :func:`small_wrist_cable`: a drawstring set of 120 poses with a small wrist (q4..q6 within
  +-0.3 deg) and base (q1 within +-2 deg) range, as a cable set measured in a tight corner
  of the workspace: with the anchor and the zero offset estimated it sees 10 of 28 directions.
- :func:`ur5_grid`: 1 000 UR5 poses (or fewer: 200 see the same), one marker measured by a
  laser tracker, under the placement model: 25 of 51 directions.

Both have sensor noise :data:`NOISE_MM` (1 sigma); a calibration of the identifiable
subspace predicts their held-out rows at about that error.
"""

from __future__ import annotations

import tempfile
from functools import cache
from pathlib import Path

import numpy as np

from calib_pin.measurements import write_measurements
from calib_pin.parameters import parameter_model
from calib_pin.robot import load_chain
from calib_pin.simulation import simulate, simulate_positions

#: Sensor noise of both sets, 1 sigma, [mm].
NOISE_MM = 0.02


def _text(data) -> str:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "set.csv"
        write_measurements(path, data)
        return path.read_text(encoding="utf-8")


@cache
def small_wrist_cable() -> str:
    """CSV text of the drawstring set with a small wrist range (irb120, dh: 10 of 28 with
    ``--estimate anchor,offset``)."""
    chain = load_chain("irb120")
    rng = np.random.default_rng(3)
    q = rng.uniform(chain.lower * 0.5, chain.upper * 0.5, size=(120, 6))
    q[:, 3:] = rng.uniform(-np.deg2rad(0.3), np.deg2rad(0.3), size=(120, 3))
    q[:, 0] = rng.uniform(-np.deg2rad(2.0), np.deg2rad(2.0), size=120)
    data, _ = simulate(chain, parameter_model(chain), 120, 1, noise_mm=NOISE_MM, poses=q)
    return _text(data)


@cache
def ur5_grid(poses: int = 1000) -> str:
    """CSV text of the UR5 laser-tracker set of ``poses`` poses, one marker (placement model: 25 of 51)."""
    chain = load_chain("ur5")
    data, _ = simulate_positions(chain, parameter_model(chain, "placement"), poses, 2, noise_mm=NOISE_MM,
                                 markers_mm=((0.0, 0.0, 50.0),))
    return _text(data)

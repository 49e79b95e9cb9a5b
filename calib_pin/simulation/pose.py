"""A simulated 6-D pose session of a known true robot."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..exceptions import ArgumentError
from ..measurements import MeasurementSet
from ..parameters import ParameterModel
from ..robot import Chain
from ..robot.poses import random_poses
from ..sensors.pose import PoseModel, PoseRig, default_rig
from .simulator import Truth


def simulate_poses(chain: Chain, params: ParameterModel, n_poses: int, seed: int, noise_mm: float = 0.05,
                   noise_deg: float = 0.01, nominal_rmse_mm: float = 2.0, rig: PoseRig | None = None,
                   true_x: np.ndarray | None = None) -> tuple[MeasurementSet, Any]:
    """Simulate a 6-D pose session of one true robot at ``n_poses`` random poses.

    The poses are random within the joint limits, each read with Gaussian noise
    (``noise_mm`` per coordinate, ``noise_deg`` per axis of the orientation).

    True deviations (unless ``true_x``, robot deviations in SI) are drawn normal with the
    parameter model's typical sizes, scaled so the nominal model's position error has RMSE
    ``nominal_rmse_mm``. ``rig``: the true device frame and body (default: the device 2 m
    in front of the robot turned 150 deg about z, the body 80 mm out of the flange, tilted).

    Returns:
        The set (``# noise_mm`` and ``# noise_deg`` stated) and its
        :class:`~calib_pin.simulation.simulator.Truth`.
    """
    if not (noise_mm > 0 and noise_deg > 0):
        raise ArgumentError("noise_mm", f"a pose set needs positive noise (its weighting), got {noise_mm} mm, "
                            f"{noise_deg} deg")
    rng = np.random.default_rng(seed)
    if rig is None:
        rig = default_rig()
    model = PoseModel(chain, params, rig, noise_mm * 1e-3, float(np.deg2rad(noise_deg)))
    q = random_poses(chain, n_poses, rng)
    if true_x is None:
        x = rng.normal(size=len(params.names)) * params.scale
        zeros = np.zeros(12)
        nominal = model._poses(None, q)[0]
        gap = np.linalg.norm(model._poses(np.concatenate([x, zeros]), q)[0] - nominal, axis=1)
        x = x * (nominal_rmse_mm * 1e-3 / np.sqrt(np.mean(gap**2))) if nominal_rmse_mm > 0 else np.zeros_like(x)
    else:
        x = np.asarray(true_x, dtype=float)
    values = model.noisy_readings(np.concatenate([x, np.zeros(12)]), q, rng)
    data = MeasurementSet(q=q, values=values, kind=PoseModel.kind, robot=chain.name, end_frame=chain.end_frame,
                          noise=noise_mm * 1e-3,
                          notes={"noise_deg": f"{noise_deg:g}",
                                 "source": f"calib-pin 6-D pose simulator, seed {seed}, noise {noise_mm:g} mm "
                                           f"per axis, {noise_deg:g} deg per axis"})
    truth = Truth(x, tuple(params.names), tuple(params.units), rig, PoseModel.kind, noise_mm * 1e-3, seed)
    return data, truth

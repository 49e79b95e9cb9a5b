"""How well the data pins the estimate down: standard errors and flange uncertainty.

At the estimate x, with the training Jacobian J, columns scaled by the typical sizes
D (J D = U S V^T, the r identifiable directions kept as the estimators do) and the
noise estimated from the residual (sigma^2 = RSS / (m - r)):

    cov(x) = sigma^2 D V_r S_r^-2 V_r^T D.

A parameter's standard error is the square root of its diagonal entry; the blind
directions contribute nothing because they are not estimated (they stay at zero).
The flange's predicted position uncertainty at a pose is sqrt(trace(P cov P^T)) with
P the derivative of the end frame's origin with respect to x.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..estimators.subspace import RCOND, Subspace
from ..robot.poses import random_poses
from ..util.units import human_unit

#: z of the two-sided 95 % normal interval.
Z95 = 1.959964


@dataclass(frozen=True)
class Uncertainty:
    """Uncertainty of an estimate.

    Attributes:
        names, units: Parameter names and SI units.
        x: The estimate, SI units.
        std: Standard error of each parameter, SI units (0 for what is not estimated).
        noise: Reading noise estimated from the residual, [m].
        flange_rms, flange_max: 1-sigma position uncertainty of the end frame's origin,
            RMS and max over ``poses`` random workspace poses, [m].
        poses: Number of workspace poses.
        workspace_points: The end frame's origin at each workspace pose, shape
            (poses, 3), [m], base frame (calibrated robot).
        flange_sigma: 1-sigma position uncertainty at each of those poses, shape
            (poses,), [m] (``flange_rms`` and ``flange_max`` summarise it).
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    x: np.ndarray
    std: np.ndarray
    noise: float
    flange_rms: float
    flange_max: float
    poses: int
    workspace_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    flange_sigma: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    def as_dict(self) -> dict:
        """JSON-ready: per parameter value, standard error and 95 % interval in mm/deg."""
        out = {}
        for name, unit, value, std in zip(self.names, self.units, self.x, self.std, strict=True):
            f, suffix = human_unit(unit)
            v, s = value * f, std * f
            out[f"{name}_{suffix}"] = {"value": v, "std": s, "ci95": [v - Z95 * s, v + Z95 * s]}
        return {
            "parameters": out,
            "noise_estimate_mm": self.noise * 1e3,
            "flange_position_1sigma_mm": {"rms": self.flange_rms * 1e3, "max": self.flange_max * 1e3,
                                          "poses": self.poses},
        }


def estimate_uncertainty(
    problem: Any, x: np.ndarray, *, rcond: float = RCOND, poses: int = 500, seed: int = 0
) -> Uncertainty:
    """Uncertainty of the estimate x fitted to ``problem`` (the training rows)."""
    model = problem.model
    space = Subspace.of(problem.jacobian(x), model.scale, x, rcond)
    residual = problem.residual(x)
    dof = max(problem.n_values - space.rank, 1)
    noise = float(np.sqrt(residual @ residual / dof))
    cov = space.covariance(noise)
    q = random_poses(problem.model.chain, poses, np.random.default_rng(seed))
    points, d_points = problem.model.point_jacobian(x, q, np.zeros(3))
    per_pose = np.einsum("nip,pk,nik->n", d_points, cov, d_points)
    flange = np.sqrt(np.clip(per_pose, 0.0, None))
    return Uncertainty(
        names=tuple(model.names), units=tuple(model.units), x=np.asarray(x, dtype=float),
        std=np.sqrt(np.clip(np.diag(cov), 0.0, None)), noise=noise,
        flange_rms=float(np.sqrt(np.mean(flange**2))), flange_max=float(flange.max()), poses=poses,
        workspace_points=np.asarray(points).reshape(-1, 3), flange_sigma=flange,
    )

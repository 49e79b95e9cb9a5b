"""Random joint poses of a chain: uniform within the joint limits less a margin [rad]."""

from __future__ import annotations

import numpy as np

from ..exceptions import CalibPinError
from .chain import Chain

__all__ = ["random_poses"]


def random_poses(
    chain: Chain, n: int, rng: np.random.Generator, margin: float = np.deg2rad(5.0)
) -> np.ndarray:
    """Uniform random joint angles within the limits less a margin, shape (n, n_joints) [rad].

    A continuous joint (no limits) is drawn in [-pi, pi].
    """
    lo = np.where(np.isfinite(chain.lower), chain.lower + margin, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper - margin, np.pi)
    if np.any(hi < lo):
        k = int(np.argmax(lo - hi))
        raise CalibPinError(f"joint '{chain.joint_names[k]}' has no range left inside its limits less a margin "
                            f"of {np.rad2deg(margin):g} deg")
    return rng.uniform(lo, hi, size=(n, chain.n_joints))

"""A 6D offset of every joint placement: the parameter model for any URDF chain."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..robot.chain import Chain


class PlacementModel:
    """A 6D offset of every chain joint's placement and of the end frame.

    Per placement, x holds a right twist (v_x, v_y, v_z [m], w_x, w_y, w_z [rad]);
    the placement becomes nominal * exp6(twist). Valid for any URDF chain. Many of its
    directions are not identifiable from readings, so calib-pin uses it to simulate
    robots that have no DH table.
    """

    #: Name on the command line (``--model``).
    name = "placement"

    def __init__(self, chain: Chain, scale_m: float = 1e-3, scale_rad: float = 2e-3) -> None:
        frames = (*chain.joint_names, chain.end_frame)
        parts = ("x", "y", "z", "rx", "ry", "rz")
        self.chain = chain
        self.names = tuple(f"{f}.{p}" for f in frames for p in parts)
        self.units = ("m", "m", "m", "rad", "rad", "rad") * len(frames)
        self.scale = np.tile([scale_m] * 3 + [scale_rad] * 3, len(frames)).astype(float)

    def deltas(self, x: np.ndarray) -> list[pin.SE3]:
        """exp6 of each placement's twist, shape of x (6 (n + 1),)."""
        return [pin.exp6(t) for t in np.asarray(x, dtype=float).reshape(-1, 6)]

    def delta_matrices(self, x: np.ndarray) -> np.ndarray:
        """:meth:`deltas` as homogeneous matrices, shape (n + 1, 4, 4)."""
        return np.array([m.homogeneous for m in self.deltas(x)])

    def delta_matrices_many(self, xs: list[np.ndarray]) -> np.ndarray:
        """:meth:`delta_matrices` at k points xs (each (6 (n + 1),)) in one array, shape (k, n + 1, 4, 4).

        The same exp6 of each twist, stacked (no per-point array).
        """
        twists = np.asarray(xs, dtype=float).reshape(-1, 6)
        return np.array([pin.exp6(t).homogeneous for t in twists]).reshape(len(xs), -1, 4, 4)

    def delta_jacobian(self, x: np.ndarray) -> np.ndarray:
        """Block diagonal of exp6's right Jacobians, shape (6 (n + 1), 6 (n + 1))."""
        twists = np.asarray(x, dtype=float).reshape(-1, 6)
        jac = np.zeros((twists.size, twists.size))
        for i, t in enumerate(twists):
            jac[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] = pin.Jexp6(t)
        return jac

"""The paper's parameter model (eq. 4-5): standard DH deviations (Δa, Δd, Δα, Δθ) per joint."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..exceptions import RobotError
from ..robot.chain import Chain
from ..robot.description import DHTable


def _rz(angle: float) -> pin.SE3:
    c, s = np.cos(angle), np.sin(angle)
    return pin.SE3(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.zeros(3))


def _rx(angle: float) -> pin.SE3:
    c, s = np.cos(angle), np.sin(angle)
    return pin.SE3(np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]), np.zeros(3))


def _link(d: float, a: float, alpha: float) -> pin.SE3:
    """Tz(d) Tx(a) Rx(alpha): the part of a DH transform after the joint rotation."""
    out = _rx(alpha)
    out.translation = np.array([a, 0.0, d])
    return out


def dh_transforms(table: DHTable, theta: np.ndarray) -> list[pin.SE3]:
    """Frames 0..n of a standard DH chain (eq. 1-2) in frame 0, for joint angles theta.

    Args:
        table: DH table; ``theta`` is added to its ``theta_offset``.
        theta: Joint readings, shape (n,), [rad].
    """
    frames = [pin.SE3.Identity()]
    for i in range(table.n_joints):
        a_i = _rz(table.theta_offset[i] + theta[i]) * _link(table.d[i], table.a[i], table.alpha[i])
        frames.append(frames[-1] * a_i)
    return frames


class DHModel:
    """Standard DH deviations (Δa, Δd, Δα, Δθ per joint, paper eq. 5) of a chain.

    The DH frames need not be the URDF's link frames. For each joint the constant
    transform C_i between DH frame i-1 (after its joint rotation) and the URDF's joint
    frame i is found at the zero pose, and the DH table is checked to describe the URDF
    at random poses. Then, with S_i = Tz(d_i) Tx(a_i) Rx(alpha_i),

        joint placement i = nominal_i * (W_i(0)^-1 S_{i-1}(0)^-1 S_{i-1}(x) W_i(x)),
        W_i(x) = Rz(theta_offset_i + Δθ_i) C_i,

    and the end frame's placement gets E^-1 S_n(0)^-1 S_n(x) E, with E the end frame in
    DH frame n. Zero deviation gives the nominal placements.

    Args:
        chain: The robot chain; the DH table's frame 0 is the URDF root frame.
        table: The chain's DH table; one row per chain joint, revolute joints only.
        scale_m, scale_rad: Typical deviation sizes for lengths [m] and angles [rad].

    Raises:
        RobotError: the table's size or geometry does not match the URDF.
    """

    #: Name on the command line (``--model``).
    name = "dh"

    #: Rows whose d deviation is replaced by a rotation beta about y (Hayati); none here.
    hayati_rows: tuple[int, ...] = ()

    def __init__(
        self, chain: Chain, table: DHTable, scale_m: float = 1e-3, scale_rad: float = 2e-3
    ) -> None:
        n = chain.n_joints
        if table.n_joints != n:
            raise RobotError(
                f"DH table of '{chain.name}' has {table.n_joints} rows, the chain to "
                f"'{chain.end_frame}' has {n} joints"
            )
        if not all(kind.startswith("JointModelR") for kind in chain.joint_kinds):
            raise RobotError(f"DH model of '{chain.name}' needs revolute joints only")
        self.chain = chain
        self.table = table
        beta = set(self.hayati_rows)
        self.names = tuple(
            f"{'beta' if p == 'd' and i - 1 in beta else p}_{i}"
            for i in range(1, n + 1) for p in ("a", "d", "alpha", "theta")
        )
        self.units = tuple(u for i in range(n) for u in ("m", "rad" if i in beta else "m", "rad", "rad"))
        self.scale = np.array(
            [v for i in range(n) for v in (scale_m, scale_rad if i in beta else scale_m, scale_rad, scale_rad)]
        )
        self._c, self._end = self._fit_frames()
        self._check_against_urdf()
        self._precompute()

    @property
    def end_transform(self) -> pin.SE3:
        """The fixed transform from DH frame n to the end frame (nominal) [m, rad]."""
        return self._end

    @property
    def n_params(self) -> int:
        return len(self.names)

    def _joint_frames(self, q: np.ndarray) -> tuple[list[pin.SE3], pin.SE3]:
        model = self.chain.model
        data = model.createData()
        pin.framesForwardKinematics(model, data, self.chain.configuration(q))
        return [data.oMi[j].copy() for j in range(1, model.njoints)], data.oMf[
            self.chain.frame_id
        ].copy()

    def _fit_frames(self) -> tuple[list[pin.SE3], pin.SE3]:
        q0 = np.zeros(self.chain.n_joints)
        joints, end = self._joint_frames(q0)
        dh = dh_transforms(self.table, q0)
        c = [
            (dh[i] * _rz(self.table.theta_offset[i])).actInv(joints[i])
            for i in range(self.chain.n_joints)
        ]
        return c, dh[-1].actInv(end)

    def _check_against_urdf(self) -> None:
        rng = np.random.default_rng(0)
        lo = np.maximum(self.chain.lower, -np.pi)
        hi = np.minimum(self.chain.upper, np.pi)
        for q in [np.zeros(len(lo))] + [rng.uniform(lo, hi) for _ in range(5)]:
            joints, end = self._joint_frames(q)
            dh = dh_transforms(self.table, q)
            for i, joint in enumerate(joints):
                via_dh = dh[i] * _rz(self.table.theta_offset[i] + q[i]) * self._c[i]
                gap = np.linalg.norm(pin.log6(via_dh.actInv(joint)).vector)
                if gap > 1e-9:
                    raise RobotError(
                        f"DH table of '{self.chain.name}' does not describe its URDF: joint "
                        f"'{self.chain.joint_names[i]}' is off by {gap:.3g} (m, rad)"
                    )
            gap = np.linalg.norm(pin.log6((dh[-1] * self._end).actInv(end)).vector)
            if gap > 1e-9:
                raise RobotError(
                    f"DH table of '{self.chain.name}' does not reach '{self.chain.end_frame}'"
                    f" of its URDF: off by {gap:.3g} (m, rad)"
                )

    def _split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        x = np.asarray(x, dtype=float).reshape(-1, 4)
        return x[:, 0], x[:, 1], x[:, 2], x[:, 3]

    def _precompute(self) -> None:
        """Constant 4x4 factors of :meth:`deltas`, so that delta k = pre_k S(x)_k post(x)_k."""
        t, n = self.table, self.table.n_joints
        c = np.array([ci.homogeneous for ci in self._c])
        end = self._end.homogeneous
        w0 = _rz_matrices(t.theta_offset) @ c
        s0 = _link_matrices(t.d, t.a, t.alpha, np.zeros(n))
        pre = np.empty((n + 1, 4, 4))
        pre[0] = _inverse(w0[0])
        pre[1:n] = _inverse(s0[:-1] @ w0[1:])
        pre[n] = _inverse(s0[-1] @ end)
        self._pre, self._c_matrices, self._end_matrix = pre, c, end
        self._hayati = np.isin(np.arange(n), self.hayati_rows)

    def _link_x(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """S_i(x) for every row, shape (n, 4, 4), and the joint rotations Rz(theta_offset + Δθ) C_i."""
        t = self.table
        da, dd, dal, dth = self._split(x)
        links = _link_matrices(t.d + np.where(self._hayati, 0.0, dd), t.a + da, t.alpha + dal,
                               np.where(self._hayati, dd, 0.0))
        return links, _rz_matrices(t.theta_offset + dth) @ self._c_matrices

    def deltas(self, x: np.ndarray) -> list[pin.SE3]:
        """Placement perturbations for deviations x, shape (4 n,), [m, m, rad, rad]
        (a Hayati row's second entry is beta [rad])."""
        n = self.table.n_joints
        links, w = self._link_x(x)
        mid = np.empty((n + 1, 4, 4))
        mid[0] = w[0]
        mid[1:n] = links[:-1] @ w[1:]
        mid[n] = links[-1] @ self._end_matrix
        out = self._pre @ mid
        return [pin.SE3(m[:3, :3], m[:3, 3]) for m in out]

    def delta_jacobian(self, x: np.ndarray) -> np.ndarray:
        """Right-twist derivative of :meth:`deltas`, shape (6 (n + 1), 4 n)."""
        t, n = self.table, self.table.n_joints
        _, dd, dal, dth = self._split(x)
        alpha = t.alpha + dal  # the a and d twists do not depend on a_i or d_i
        beta = np.where(self._hayati, dd, 0.0)
        ca, sa = np.cos(alpha), np.sin(alpha)
        # Twists in S_i's end frame, per row: columns a, d (or beta), alpha as (v, w).
        tw = np.zeros((n, 3, 6))
        tw[:, 0, 0] = 1.0  # a_i: Rx(alpha)^T x = x
        tw[:, 1, 1], tw[:, 1, 2] = sa, ca  # d_i: Rx(alpha)^T z
        tw[:, 2, 3] = 1.0  # alpha_i: about x
        ry = _ry_matrices(beta)  # Ry(beta)^-1 moves them behind a Hayati row's tilt
        tw = (tw.reshape(n, 6, 3) @ ry).reshape(n, 3, 6)  # v R = (R^T v)^T per 3-vector
        tw[self._hayati, 1] = (0.0, 0.0, 0.0, 0.0, 1.0, 0.0)  # beta_i: about y
        after = np.empty((n, 4, 4))
        after[:-1] = _rz_matrices(t.theta_offset[1:] + dth[1:]) @ self._c_matrices[1:]
        after[-1] = self._end_matrix
        jac = np.zeros((n + 1, 6, n, 4))
        rows = np.arange(n)
        jac[rows + 1, :, rows, :3] = _act_inv(after, tw).transpose(0, 2, 1)
        z = np.zeros((n, 6))
        z[:, 5] = 1.0
        jac[rows, :, rows, 3] = _act_inv(self._c_matrices, z[:, None])[:, 0]
        return jac.reshape(6 * (n + 1), 4 * n)


def _rz_matrices(angle: np.ndarray) -> np.ndarray:
    """Rz(angle) as 4x4 transforms, shape (n, 4, 4)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros((len(c), 4, 4))
    out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1] = c, -s, s, c
    out[:, 2, 2] = out[:, 3, 3] = 1.0
    return out


def _ry_matrices(angle: np.ndarray) -> np.ndarray:
    """Ry(angle) rotations, shape (n, 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros((len(c), 3, 3))
    out[:, 0, 0], out[:, 0, 2], out[:, 2, 0], out[:, 2, 2] = c, s, -s, c
    out[:, 1, 1] = 1.0
    return out


def _link_matrices(d: np.ndarray, a: np.ndarray, alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Tz(d) Tx(a) Rx(alpha) Ry(beta) as 4x4 transforms, shape (n, 4, 4)."""
    c, s = np.cos(alpha), np.sin(alpha)
    cb, sb = np.cos(beta), np.sin(beta)
    out = np.zeros((len(c), 4, 4))
    out[:, 0, 0], out[:, 0, 2], out[:, 0, 3] = cb, sb, a
    out[:, 1, 0], out[:, 1, 1], out[:, 1, 2] = s * sb, c, -s * cb
    out[:, 2, 0], out[:, 2, 1], out[:, 2, 2], out[:, 2, 3] = -c * sb, s, c * cb, d
    out[:, 3, 3] = 1.0
    return out


def _inverse(m: np.ndarray) -> np.ndarray:
    """Inverse of rigid 4x4 transforms (..., 4, 4)."""
    out = np.zeros_like(m)
    rt = np.swapaxes(m[..., :3, :3], -1, -2)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -(rt @ m[..., :3, 3, None])[..., 0]
    out[..., 3, 3] = 1.0
    return out


def _act_inv(m: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """M^-1 acting on twists (v, w): (R^T (v - p x w), R^T w); shapes (n, 4, 4) and
    (n, k, 6) -> (n, k, 6)."""
    rt = np.swapaxes(m[:, :3, :3], 1, 2)
    p = m[:, None, :3, 3]
    v, w = twist[..., :3], twist[..., 3:]
    p_x_w = np.stack([p[..., 1] * w[..., 2] - p[..., 2] * w[..., 1], p[..., 2] * w[..., 0] - p[..., 0] * w[..., 2],
                      p[..., 0] * w[..., 1] - p[..., 1] * w[..., 0]], axis=-1)
    out = np.empty(twist.shape)
    out[..., :3] = (v - p_x_w) @ np.swapaxes(rt, 1, 2)
    out[..., 3:] = w @ np.swapaxes(rt, 1, 2)
    return out

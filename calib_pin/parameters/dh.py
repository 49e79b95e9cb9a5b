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
        self._pre, self._end_matrix = pre, end
        self._hayati = np.isin(np.arange(n), self.hayati_rows)
        # Rz(phi) C_i = cos(phi) (E_c C_i) + sin(phi) (E_s C_i) + E_z C_i: the joint
        # rotations of delta_matrices as three constant factors per joint, shape (n, 4, 4) each.
        e_c, e_s, e_z = np.zeros((3, 4, 4))
        e_c[0, 0] = e_c[1, 1] = 1.0
        e_s[0, 1], e_s[1, 0] = -1.0, 1.0
        e_z[2, 2] = e_z[3, 3] = 1.0
        self._turn = (e_c @ c, e_s @ c, e_z @ c)
        # delta_jacobian: row i's theta column is constant, Ad(C_i^-1) e_wz at joint i;
        # its a, d|beta, alpha columns sit at placement i + 1 (the end frame for the last
        # row) behind the constant part of the placement after the link, C_{i+1} (end).
        rows = np.arange(n)
        e_wz = np.zeros((n, 1, 6))
        e_wz[:, 0, 5] = 1.0
        theta = np.zeros((n + 1, 6, n, 4))
        theta[rows, :, rows, 3] = _act_inv(c, e_wz)[:, 0]
        self._jac_theta = theta.reshape(6 * (n + 1), 4 * n)
        after = np.concatenate([c[1:], end[None]])
        self._ad_after_inv = _act_inv(after, np.broadcast_to(np.eye(6), (n, 6, 6))).transpose(0, 2, 1)
        index = np.arange(self._jac_theta.size).reshape(n + 1, 6, n, 4)
        self._jac_blocks = index[rows + 1, :, rows, :3]  # (n, 6, 3): the a, d|beta, alpha blocks

    def delta_matrices(self, x: np.ndarray) -> np.ndarray:
        """Placement perturbations for deviations x, as matrices, shape (n + 1, 4, 4).

        x has shape (4 n,), [m, m, rad, rad] (a Hayati row's second entry is beta [rad]);
        delta_0 = pre_0 W_0 and delta_i = pre_i S_(i-1) W_i, with the link S_i(x) and
        W_i = Rz(theta_offset_i + dtheta_i) C_i (W_n: the end matrix).
        """
        t = self.table
        da, dd, dal, dth = self._split(x)
        if self.hayati_rows:
            links = _link_matrices(t.d + np.where(self._hayati, 0.0, dd), t.a + da, t.alpha + dal,
                                   np.where(self._hayati, dd, 0.0))
        else:
            links = _link_matrices(t.d + dd, t.a + da, t.alpha + dal)
        phi = t.theta_offset + dth
        turn_c, turn_s, turn_z = self._turn
        w = np.cos(phi)[:, None, None] * turn_c + np.sin(phi)[:, None, None] * turn_s + turn_z
        mid = np.empty((len(phi) + 1, 4, 4))
        mid[0] = w[0]
        np.matmul(links[:-1], w[1:], out=mid[1:-1])
        np.matmul(links[-1], self._end_matrix, out=mid[-1])
        return self._pre @ mid

    def deltas(self, x: np.ndarray) -> list[pin.SE3]:
        """:meth:`delta_matrices` as Pinocchio transforms."""
        return [pin.SE3(m) for m in self.delta_matrices(x)]

    def delta_jacobian(self, x: np.ndarray) -> np.ndarray:
        """Right-twist derivative of :meth:`deltas`, shape (6 (n + 1), 4 n)."""
        t, n = self.table, self.table.n_joints
        _, dd, dal, dth = self._split(x)
        alpha = t.alpha + dal  # the a and d twists do not depend on a_i or d_i
        # Twists (v, w) per row in S_i's end frame, columns a, d (or beta), alpha.
        tw = np.zeros((n, 2, 3, 3))
        tw[:, 0, 0, 0] = 1.0  # a_i: Rx(alpha)^T x = x
        tw[:, 0, 1, 1], tw[:, 0, 2, 1] = np.sin(alpha), np.cos(alpha)  # d_i: Rx(alpha)^T z
        tw[:, 1, 0, 2] = 1.0  # alpha_i: about x
        tw[self._hayati, :, :, 1] = ((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))  # beta_i: about y
        # Carried behind Ry(beta) (the identity on non-Hayati rows; it keeps beta's own
        # axis) and Rz(theta_offset + dtheta) of the next joint (none for the end frame).
        phi = np.zeros(n)
        phi[:-1] = t.theta_offset[1:] + dth[1:]
        turn = _rz_matrices(phi)[:, :3, :3].transpose(0, 2, 1)
        if self.hayati_rows:
            turn = turn @ _ry_matrices(np.where(self._hayati, dd, 0.0)).transpose(0, 2, 1)
        blocks = self._ad_after_inv @ (turn[:, None] @ tw).reshape(n, 6, 3)
        jac = self._jac_theta.copy()
        jac.flat[self._jac_blocks] = blocks
        return jac


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


def _link_matrices(d: np.ndarray, a: np.ndarray, alpha: np.ndarray, beta: np.ndarray | None = None) -> np.ndarray:
    """Tz(d) Tx(a) Rx(alpha) Ry(beta) as 4x4 transforms, shape (n, 4, 4); beta None: zero."""
    c, s = np.cos(alpha), np.sin(alpha)
    out = np.zeros((len(c), 4, 4))
    out[:, 0, 3], out[:, 1, 1], out[:, 2, 1], out[:, 2, 3], out[:, 3, 3] = a, c, s, d, 1.0
    if beta is None:
        out[:, 0, 0], out[:, 1, 2], out[:, 2, 2] = 1.0, -s, c
    else:
        cb, sb = np.cos(beta), np.sin(beta)
        out[:, 0, 0], out[:, 0, 2], out[:, 1, 0], out[:, 1, 2] = cb, sb, s * sb, -s * cb
        out[:, 2, 0], out[:, 2, 2] = -c * sb, c * cb
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
    """M^-1 acting on twists (v, w): (R^T (v - p x w), R^T w).

    Shapes (n, 4, 4) and (n, k, 6) -> (n, k, 6).
    """
    rt = np.swapaxes(m[:, :3, :3], 1, 2)
    p = m[:, None, :3, 3]
    v, w = twist[..., :3], twist[..., 3:]
    p_x_w = np.stack([p[..., 1] * w[..., 2] - p[..., 2] * w[..., 1], p[..., 2] * w[..., 0] - p[..., 0] * w[..., 2],
                      p[..., 0] * w[..., 1] - p[..., 1] * w[..., 0]], axis=-1)
    out = np.empty(twist.shape)
    out[..., :3] = (v - p_x_w) @ np.swapaxes(rt, 1, 2)
    out[..., 3:] = w @ np.swapaxes(rt, 1, 2)
    return out

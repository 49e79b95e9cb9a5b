"""The paper's parameter model (eq. 4-5): standard DH deviations (Δa, Δd, Δα, Δθ) per joint."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..exceptions import RobotError
from ..robot.chain import Chain
from ..robot.description import DHTable

_LIN_X = pin.Motion(np.array([1.0, 0, 0]), np.zeros(3))
_LIN_Z = pin.Motion(np.array([0, 0, 1.0]), np.zeros(3))
_ANG_X = pin.Motion(np.zeros(3), np.array([1.0, 0, 0]))
_ANG_Y = pin.Motion(np.zeros(3), np.array([0, 1.0, 0]))
_ANG_Z = pin.Motion(np.zeros(3), np.array([0, 0, 1.0]))


def _rz(angle: float) -> pin.SE3:
    c, s = np.cos(angle), np.sin(angle)
    return pin.SE3(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.zeros(3))


def _rx(angle: float) -> pin.SE3:
    c, s = np.cos(angle), np.sin(angle)
    return pin.SE3(np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]), np.zeros(3))


def _ry(angle: float) -> pin.SE3:
    c, s = np.cos(angle), np.sin(angle)
    return pin.SE3(np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]), np.zeros(3))


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

    def _links(self, x: np.ndarray) -> list[tuple[pin.SE3, pin.SE3]]:
        """Per row i, (nominal S_i, S_i at x); S_i = Tz(d) Tx(a) Rx(alpha) [Ry(beta)]."""
        t = self.table
        da, dd, dal, _ = self._split(x)
        out = []
        for i in range(t.n_joints):
            s0 = _link(t.d[i], t.a[i], t.alpha[i])
            if i in self.hayati_rows:
                s = _link(t.d[i], t.a[i] + da[i], t.alpha[i] + dal[i]) * _ry(dd[i])
            else:
                s = _link(t.d[i] + dd[i], t.a[i] + da[i], t.alpha[i] + dal[i])
            out.append((s0, s))
        return out

    def deltas(self, x: np.ndarray) -> list[pin.SE3]:
        """Placement perturbations for deviations x, shape (4 n,), [m, m, rad, rad]
        (a Hayati row's second entry is beta [rad])."""
        t = self.table
        dth = self._split(x)[3]
        links = self._links(x)
        out = []
        for i in range(t.n_joints):
            w0 = _rz(t.theta_offset[i]) * self._c[i]
            w = _rz(t.theta_offset[i] + dth[i]) * self._c[i]
            if i == 0:
                out.append(w0.actInv(w))
            else:
                s0, s = links[i - 1]
                out.append(w0.actInv(s0.actInv(s * w)))
        s0, s = links[-1]
        out.append(self._end.actInv(s0.actInv(s * self._end)))
        return out

    def delta_jacobian(self, x: np.ndarray) -> np.ndarray:
        """Right-twist derivative of :meth:`deltas`, shape (6 (n + 1), 4 n)."""
        t = self.table
        n = t.n_joints
        da, dd, dal, dth = self._split(x)
        jac = np.zeros((6 * (n + 1), 4 * n))
        for i in range(n):
            # theta_i rotates about z in front of C_i: block of joint i.
            jac[6 * i : 6 * i + 6, 4 * i + 3] = self._c[i].actInv(_ANG_Z).vector
            # (d_i, a_i, alpha_i) sit in S_i: block of joint i+1, or of the end frame.
            after = _rz(t.theta_offset[i + 1] + dth[i + 1]) * self._c[i + 1] if i + 1 < n else self._end
            a, alpha = t.a[i] + da[i], t.alpha[i] + dal[i]
            xa = _rx(alpha)
            xa.translation = np.array([a, 0.0, 0.0])
            twists = {
                0: _rx(alpha).actInv(_LIN_X),  # a_i
                1: xa.actInv(_LIN_Z),  # d_i
                2: _ANG_X,  # alpha_i
            }
            if i in self.hayati_rows:  # S_i ends with Ry(beta_i), which replaces d_i
                tail = _ry(dd[i])
                twists = {col: tail.actInv(tw) for col, tw in twists.items() if col != 1}
                twists[1] = _ANG_Y
            for col, twist in twists.items():
                jac[6 * (i + 1) : 6 * (i + 2), 4 * i + col] = after.actInv(twist).vector
        return jac

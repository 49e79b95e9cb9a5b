"""The one forward-kinematics path: a chain under a placement perturbation, at many poses.

:class:`Kinematics` evaluates a :class:`~calib_pin.robot.chain.Chain` under a
perturbation: every joint placement and the end frame's placement are right-multiplied
by a small rigid transform, always rebuilt from the nominal placements (never
accumulated, never reverted). Parameter models (:mod:`calib_pin.parameters`) map their
deviations onto these transforms, so this one path serves them all.

Two evaluations share the perturbed placements:

- Positions (:meth:`Kinematics.points` without derivatives, what every cost evaluation
  of a search asks for) are computed for all poses of a batch together, a few numpy
  operations per joint whatever the number of poses. A Python loop of one Pinocchio
  call per pose pays a call overhead per pose, which the batched pass avoids
  (``benchmark.py`` prints the residual against that loop). Each
  joint moves by exp(S_i q_i), with S_i Pinocchio's motion subspace of the joint
  (:func:`~calib_pin.robot.chain.joint_motions`): after its placement M_i, its
  transform is f0 F0_i + f1 F1_i + F2_i with (f0, f1) = (cos q, sin q) for a revolute
  joint, (q, 0) for a prismatic one, and constant factors F_k,i = M_i E_k (Rodrigues:
  E_0 = I - w w^T, E_1 = [w]x, E_2 = w w^T plus the homogeneous 1; prismatic: E_0 = [0 v;
  0 0], E_2 = I). A joint that both turns and slides (a screw) is refused.
- Positions with derivatives (Jacobians, frames) come from Pinocchio per pose:
  ``forwardKinematics``/``computeJointJacobians``, ``computeFrameKinematicRegressor``
  and ``getFrameJacobian`` on a working copy of the model, whose placements are written
  only when a derivative is asked for.

The tests hold the batched positions to Pinocchio's to 1e-12 m for revolute, prismatic,
continuous and off-axis joints.

Frames and units: positions in [m] in the base (URDF root) frame, joint angles in
[rad] (prismatic [m]), twists as Pinocchio orders them (linear, angular) in the
perturbed placement's own frame.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError, RobotError
from .chain import Chain, joint_motions


def _factors(motions: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    """The constant factors E_k of each joint's motion, shape (3, n_joints, 4, 4)."""
    out = np.zeros((3, len(motions), 4, 4))
    for i, (v, w) in enumerate(zip(motions[:, :3], motions[:, 3:], strict=True)):
        if revolute[i]:  # Rodrigues' formula
            out[0, i, :3, :3] = np.eye(3) - np.outer(w, w)
            out[1, i, :3, :3] = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
            out[2, i, :3, :3] = np.outer(w, w)
            out[2, i, 3, 3] = 1.0
        else:  # prismatic: q along v
            out[0, i, :3, 3] = v
            out[2, i] = np.eye(4)
    return out


class Kinematics:
    """Forward kinematics of a chain under a placement perturbation.

    :meth:`set_perturbation` rebuilds the placements from the nominal ones (the batched
    factors and the working Pinocchio model follow when first used); :meth:`points` is
    the one FK path every estimator and the simulator use. One object holds one
    perturbation: share it between threads only behind a lock, and build a new one
    rather than copying it (a copy's live views point into the original's model).
    """

    def __init__(self, chain: Chain) -> None:
        if not isinstance(chain, Chain):
            raise ArgumentError("chain", f"expected a robot chain (calib_pin.load_chain), got {type(chain).__name__}")
        self.chain = chain
        self._model = chain.model.copy()
        self._data = self._model.createData()
        self._fid = chain.frame_id
        model = self._model
        placements = [model.jointPlacements[j] for j in range(1, model.njoints)] + [model.frames[self._fid].placement]
        #: Nominal joint placements, then the end frame's, shape (n_joints + 1, 4, 4).
        self._nominal = np.array([m.homogeneous for m in placements])
        # Live views into the working model: _working_model writes the placements in
        # place, and updateFramePlacement writes the end frame's pose where points reads it.
        self._targets = [(m.rotation, m.translation) for m in placements]
        self._placement = self._data.oMf[self._fid]
        self._rotation, self._translation = self._placement.rotation, self._placement.translation
        self._frame = _frame_view(self._rotation, self._translation)
        motions = joint_motions(model)
        turns, slides = np.linalg.norm(motions[:, 3:], axis=1), np.linalg.norm(motions[:, :3], axis=1)
        if np.any(np.minimum(turns, slides) > 1e-9):
            name = chain.joint_names[int(np.argmax(np.minimum(turns, slides)))]
            raise RobotError(f"joint '{name}' of '{chain.name}' both turns and slides (a screw joint); "
                             "calib-pin takes chains of revolute and prismatic joints")
        self._revolute = turns > slides
        self._basis = _factors(motions, self._revolute)
        self._basis_rows = np.ascontiguousarray(self._basis.transpose(1, 2, 0, 3).reshape(-1, 4, 12))  # (E_0 | E_1 | E_2)
        #: The last poses' shape and bits, and their factors (:meth:`_coefficients`).
        self._coef_cache: tuple[tuple[int, ...], bytes, np.ndarray] = ((0, len(motions)), b"",
                                                                       np.empty((len(motions), 12, 0)))
        self.set_perturbation(None)

    def set_perturbation(self, deltas: np.ndarray | None) -> None:
        """Rebuild the working placements as nominal * delta.

        Args:
            deltas: ``n_joints + 1`` homogeneous transforms, shape (n_joints + 1, 4, 4)
                (joints base to end, then the end frame; see
                :meth:`~calib_pin.parameters.base.ParameterModel.delta_matrices`), or
                None for the nominal robot.
        """
        if deltas is not None and np.shape(deltas) != self._nominal.shape:
            raise ArgumentError("deltas", f"expected shape {self._nominal.shape} (n_joints + 1 homogeneous "
                                f"transforms), got shape {np.shape(deltas)}")
        self._placements = self._nominal if deltas is None else self._nominal @ deltas
        self._backward: np.ndarray | None = None  # both rebuilt from _placements when used
        self._model_stale = True

    def _working_model(self) -> None:
        """Write the placements into the working Pinocchio model, if not done since set."""
        if self._model_stale:
            rotations, translations = self._placements[:, :3, :3], self._placements[:, :3, 3]
            for (rotation, translation), r, t in zip(self._targets, rotations, translations, strict=True):
                rotation[:], translation[:] = r, t
            self._model_stale = False

    def _backward_factors(self) -> np.ndarray:
        """Per joint, [v, 1] @ out[i] = (F0 v | F1 v | F2 v) row-wise, shape (n_joints, 4, 12)."""
        if self._backward is None:
            factors = self._placements[:-1] @ self._basis  # (3, n, 4, 4): F_k,i = M_i E_k
            self._backward = np.ascontiguousarray(factors.transpose(1, 3, 0, 2).reshape(-1, 4, 12))
        return self._backward

    def _coefficients(self, q: np.ndarray) -> np.ndarray:
        """The factors of F0 v, F1 v and F2 v in :func:`_through_joints`, shape (n_joints, 12, n_poses).

        (f0, f1, 1), each repeated for the 4 rows of its product. The last poses' are kept:
        a search evaluates the same poses many times.
        """
        shape, bits, coef = self._coef_cache
        key = q.tobytes()  # the same bits of a float (n_poses, n_joints) q: the same factors
        if not (q.shape == shape and key == bits):
            coef = np.ones((len(self._revolute), 12, len(q)))
            coef[:, 0:4] = np.where(self._revolute, np.cos(q), q).T[:, None]
            coef[:, 4:8] = np.sin(q).T[:, None]  # a prismatic joint's F1 is zero
            self._coef_cache = (q.shape, key, coef)
        return coef

    def _positions(self, q: np.ndarray, point: np.ndarray) -> np.ndarray:
        """Base-frame positions [m] of ``point`` (3,) or (n_poses, 3) at all poses q (n_poses, n_joints).

        Back to front: the point through each joint in turn.
        """
        q = _joint_positions(q, len(self._basis[0]), finite=False)  # checked on the result below
        end = self._placements[-1]
        v = np.empty((1, 4, len(q)))
        v[0, :3] = np.atleast_2d(point @ end[:3, :3].T + end[:3, 3]).T
        v[0, 3] = 1.0
        return _through_joints(v, self._backward_factors()[:, None], self._coefficients(q), q)[0]

    def points_many(self, deltas: list[np.ndarray | None] | np.ndarray, q: np.ndarray,
                    points: list[np.ndarray] | np.ndarray) -> np.ndarray:
        """:meth:`points` without derivatives for several perturbations at once, [m].

        The positions of ``points[j]`` (3,) or (n_poses, 3) under ``deltas[j]`` (as
        :meth:`set_perturbation` takes, None: nominal; or all of them stacked, shape
        (k, n_joints + 1, 4, 4)) at the poses q, shape (k, n_poses, 3),
        [m]. One batched pass for all k: the same numbers, to the bit, as k calls of
        :meth:`points` (the same products, stacked); the held perturbation is left as it is.
        No perturbation (k = 0): shape (0, n_poses, 3).
        """
        q = _joint_positions(q, len(self._basis[0]), finite=False)  # checked on the result below
        k, n_place = len(deltas), len(self._nominal)
        if not k:
            return np.empty((0, len(q), 3))
        if isinstance(deltas, np.ndarray):  # stacked already, shape (k, n_place, 4, 4): every point perturbed
            placements = self._perturbed(deltas)
        else:
            # Per placement i, one matmul for the perturbed points: nominal_i @ (delta_i^1 | ... ).
            given = [j for j, delta in enumerate(deltas) if delta is not None]
            if len(given) == k:
                placements = self._perturbed(np.array(deltas))  # (n_place, k, 4, 4)
            else:  # nominal (None) among them
                placements = np.empty((n_place, k, 4, 4))
                placements[:] = self._nominal[:, None]
                if given:
                    placements[:, given] = self._perturbed(np.array([deltas[j] for j in given]))
        ends_frame: np.ndarray | None = None  # the points in the end frame, stacked (k, 1 or n_poses, 3)
        if isinstance(points, np.ndarray) and points.shape in ((k, 3), (k, len(q), 3)):
            ends_frame = np.asarray(points, dtype=float).reshape(k, -1, 3)
        else:
            shapes = {np.shape(point) for point in points}
            if len(points) == k and len(shapes) == 1 and shapes <= {(3,), (len(q), 3)}:
                ends_frame = np.array(points, dtype=float).reshape(k, -1, 3)
        # Per joint i, one matmul for all k points: (M_i^1; ...; M_i^k) @ (E_0,i | E_1,i | E_2,i).
        factors = placements[:-1].reshape(n_place - 1, 4 * k, 4) @ self._basis_rows  # (n_joints, 4k, 12)
        # backward[i, j] = [v, 1] @ -> (F0 v | F1 v | F2 v) for point j, shape (n_joints, k, 4, 12)
        backward = factors.reshape(-1, k, 4, 3, 4).transpose(0, 1, 4, 3, 2).reshape(-1, k, 4, 12)
        v = np.empty((k, 4, len(q)))
        ends = placements[-1]
        if ends_frame is not None:
            # The same product and sum, the sum written straight into v (component-major).
            np.add((ends_frame @ ends[:, :3, :3].transpose(0, 2, 1)).transpose(0, 2, 1), ends[:, :3, 3, None],
                   out=v[:, :3])
        else:
            for j, (end, point) in enumerate(zip(ends, points, strict=True)):
                v[j, :3] = np.atleast_2d(np.asarray(point, dtype=float) @ end[:3, :3].T + end[:3, 3]).T
        v[:, 3] = 1.0
        return _through_joints(v, backward, self._coefficients(q), q)

    def _perturbed(self, deltas: np.ndarray) -> np.ndarray:
        """nominal @ delta for k stacked perturbations (k, n_place, 4, 4), as (n_place, k, 4, 4).

        Per placement one matmul for all k (nominal_i @ (delta_i^1 | ... | delta_i^k)).
        """
        n_place, k = len(self._nominal), len(deltas)
        stacked = deltas.transpose(1, 2, 0, 3).reshape(n_place, 4, -1)
        return (self._nominal @ stacked).reshape(n_place, 4, k, 4).transpose(0, 2, 1, 3)

    def frames(self, q: np.ndarray, jacobian: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The end frame's placement at many poses, and its frame Jacobian.

        Args:
            q: Joint positions, shape (n_poses, n_joints), [rad].
            jacobian: Also return Pinocchio's frame Jacobian (``pin.LOCAL``).

        Returns:
            rotations: shape (n_poses, 3, 3), base frame.
            translations: shape (n_poses, 3), [m], base frame.
            jacobians: shape (n_poses, 6, n_joints) or None: the end frame's local twist
                (linear [m], angular [rad]) per unit of each joint.
        """
        q = _joint_positions(q, self.chain.n_joints)
        self._working_model()
        model, data, fid = self._model, self._data, self._fid
        configs = self.chain.configuration(q)
        n = len(configs)
        rot, trans = np.empty((n, 3, 3)), np.empty((n, 3))
        jac = np.empty((n, 6, self.chain.n_joints)) if jacobian else None
        for k in range(n):
            if jac is not None:
                pin.computeJointJacobians(model, data, configs[k])
            else:
                pin.forwardKinematics(model, data, configs[k])
            placement = pin.updateFramePlacement(model, data, fid)
            rot[k], trans[k] = placement.rotation, placement.translation
            if jac is not None:
                jac[k] = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        return rot, trans, jac

    def points(
        self, q: np.ndarray, point: np.ndarray, jacobian: bool = False, joints: bool = False
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Base-frame positions of a point fixed in the end frame, at many poses.

        Args:
            q: Joint positions, shape (n_poses, n_joints), [rad].
            point: The point in the end frame, shape (3,), [m], or one point per pose,
                shape (n_poses, 3).
            jacobian: Also return the derivative with respect to the placement
                perturbation (from Pinocchio's frame kinematic regressor).
            joints: With ``jacobian``, append the derivative with respect to the joint
                positions (n_joints columns, [m/rad], Pinocchio's frame Jacobian).

        Returns:
            positions: shape (n_poses, 3), [m], base frame.
            d_positions: shape (n_poses, 3, 6 * (n_joints + 1)) or None: derivative of
                each position with respect to a right-multiplied twist (linear, angular;
                [m], [rad]) of each joint placement, then of the end frame placement.
                The end frame's three linear columns are its rotation matrix, which is
                also the derivative of the position with respect to the point.
                With ``joints``, n_joints more columns: d position / d q.
        """
        q = _joint_positions(q, self.chain.n_joints, finite=jacobian)
        point = np.asarray(point, dtype=float)
        if point.shape != (3,) and point.shape != (len(q), 3) or jacobian and not np.isfinite(point).all():
            raise ArgumentError("point", f"expected 3 finite numbers (x, y, z in m, end frame) or one point per pose "
                                f"({len(q)}, 3), got shape {point.shape}")
        if not jacobian:
            return self._positions(q, point), None
        return _lever(*self.regressors(q, joints), point)

    def regressors(self, q: np.ndarray, joints: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                        np.ndarray | None]:
        """Pinocchio's pass over the poses behind :meth:`points` with ``jacobian``.

        Per pose ``forwardKinematics`` (``computeJointJacobians`` with ``joints``) and
        ``computeFrameKinematicRegressor`` (``getFrameJacobian``) on the working model.

        Args:
            q: Joint positions, shape (n_poses, n_joints), [rad], finite (as :meth:`points` checked).

        Returns:
            rotations (n_poses, 3, 3) and translations (n_poses, 3) [m] of the end frame,
            base frame; the frame kinematic regressors (n_poses, 6, 6 n_joints) and, with
            ``joints``, the frame Jacobians (n_poses, 6, n_joints) (else None), ``pin.LOCAL``.
        """
        self._working_model()
        model, data, fid, local = self._model, self._data, self._fid, pin.LOCAL
        configs = self.chain.configuration(q)
        n, n_joints = len(configs), self.chain.n_joints
        # Per pose one plain copy of each of Pinocchio's matrices (row-major as returned):
        # the regressor (n, 6, 6 n_joints), the joint Jacobian (n, 6, n_joints), and the end
        # frame as its 12 numbers in place (the rotation column by column, then the origin).
        reg = np.empty((n, 6, 6 * n_joints))
        jac = np.empty((n, 6, n_joints)) if joints else None
        jac_rows = None if jac is None else jac[:, :, 0] if n_joints == 1 else jac  # one joint: Pinocchio gives (6,)
        frame = np.empty((n, 12))
        live, live_rot, live_trans = self._frame, self._rotation, self._translation
        moves = pin.computeJointJacobians if joints else pin.forwardKinematics  # with joints: FK and J in one pass
        regressor, frame_jacobian = pin.computeFrameKinematicRegressor, pin.getFrameJacobian
        if live is not None and jac_rows is None:  # the estimators' case: the loop at its leanest
            for k, config in enumerate(configs):
                moves(model, data, config)
                reg[k] = regressor(model, data, fid, local)  # the regressor call updated the frame
                frame[k] = live
        else:
            for k, config in enumerate(configs):
                moves(model, data, config)
                reg[k] = regressor(model, data, fid, local)
                if live is not None:
                    frame[k] = live
                else:
                    frame[k, :9], frame[k, 9:] = live_rot.T.reshape(9), live_trans
                if jac_rows is not None:
                    jac_rows[k] = frame_jacobian(model, data, fid, local)
        rot = np.ascontiguousarray(frame[:, :9].reshape(n, 3, 3).transpose(0, 2, 1))
        return rot, np.ascontiguousarray(frame[:, 9:]), reg, jac


def _joint_positions(q: np.ndarray, n_joints: int, finite: bool = True) -> np.ndarray:
    """q as a float array (n_poses, n_joints), finite unless ``finite`` is False.

    With ``finite`` False the batched positions check their result instead: every cost
    evaluation comes here.

    Raises:
        ArgumentError: another shape, or a value that is not a finite number.
    """
    try:
        q = np.atleast_2d(np.asarray(q, dtype=float))
    except (TypeError, ValueError):
        raise ArgumentError("q", "expected joint positions as numbers [rad] (prismatic [m])") from None
    if q.ndim != 2 or q.shape[1] != n_joints:
        raise ArgumentError("q", f"expected shape (n_poses, {n_joints}) or ({n_joints},), got shape {q.shape}")
    if finite and not np.isfinite(q).all():
        raise ArgumentError("q", "joint positions must be finite numbers (NaN or inf given)")
    return q


def _through_joints(v: np.ndarray, backward: np.ndarray, coef: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Points [v, 1] in the end joint's frame carried back to the base through every joint.

    Component-major (k, 4, n_poses) (each component of all poses contiguous, so each step
    is a few whole-array operations); positions shape (k, n_poses, 3), [m].
    Per joint i, last to first, v <- f0 (F0 v) + f1 (F1 v) + 1 (F2 v): the three products
    from one matmul with ``backward[i]`` (k, 4, 12; row-wise [v, 1] @ backward[i] =
    (F0 v | F1 v | F2 v), used transposed: the same BLAS call, so the same numbers, as
    the pose-major product), scaled by ``coef[i]`` (12, n_poses) of
    :meth:`Kinematics._coefficients` and summed in that order.

    Raises:
        ArgumentError: a NaN or inf in q (checked on the result: one sum, not a pass per input) or in a point.
    """
    k, n = len(v), v.shape[2]
    for i in range(len(coef) - 1, -1, -1):
        products = backward[i].swapaxes(1, 2) @ v  # (k, 12, n): F0 v, F1 v, F2 v
        products *= coef[i]
        v = np.add.reduce(products.reshape(k, 3, 4, n), axis=1)  # along the short middle axis: in order
    if not math.isfinite(v.sum()):
        _joint_positions(q, len(coef))
        raise ArgumentError("point", "expected finite numbers (x, y, z in m, end frame)")
    return np.ascontiguousarray(v[:, :3].transpose(0, 2, 1))


#: The end frame's own twist columns of the regressor (read only).
_EYE6 = np.eye(6)
_EYE6.setflags(write=False)

#: The Levi-Civita symbol as a (3, 9) matrix: point @ _CROSS gives -[point]x row-major,
#: the matrix of w -> w x point.
_CROSS = np.array([[[0, 0, 0], [0, 0, 1], [0, -1, 0]],
                   [[0, 0, -1], [0, 0, 0], [1, 0, 0]],
                   [[0, 1, 0], [-1, 0, 0], [0, 0, 0]]], dtype=float).reshape(3, 9)


def cross_matrices(points: np.ndarray) -> np.ndarray:
    """The matrices of w -> w x p (that is -[p]x) for points p, shape (..., 3) -> (..., 3, 3)."""
    return (points @ _CROSS).reshape(*np.shape(points)[:-1], 3, 3)


def _lever(rot: np.ndarray, trans: np.ndarray, reg: np.ndarray, jac: np.ndarray | None,
           point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions of ``point`` (3,) or (n, 3) and their derivative by local end-frame twists.

    From the end frames' rotations (n, 3, 3) and translations (n, 3), and local end-frame
    twists (v, w) per column: the regressor's (n, 6, m), the end frame's own six (the
    identity), then the joint Jacobian's (n, 6, n_joints) if given. A local twist moves the
    point by R (v + w x point) = [R, -R [point]x] (v, w): the lever; its product with the
    identity is the lever itself.
    """
    n, m = reg.shape[0], reg.shape[2]
    lever = np.empty((n, 3, 6))
    lever[:, :, :3] = rot
    if point.ndim == 1:  # one point: every pose's rows in one product (K = 3: the same bits as a product a pose)
        rows = rot.reshape(-1, 3)
        lever[:, :, 3:] = (rows @ cross_matrices(point)).reshape(n, 3, 3)
        positions = trans + (rows @ point).reshape(n, 3)
    else:
        lever[:, :, 3:] = rot @ cross_matrices(point)
        positions = trans + (rot @ point[..., None])[..., 0]
    d_points = np.empty((n, 3, m + 6 + (0 if jac is None else jac.shape[2])))
    np.matmul(lever, reg, out=d_points[:, :, :m])
    d_points[:, :, m : m + 6] = lever
    if jac is not None:
        np.matmul(lever, jac, out=d_points[:, :, m + 6 :])
    return positions, d_points


def _frame_view(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray | None:
    """One view of a live placement's 12 numbers when Pinocchio keeps them in one block, else None.

    The 12 numbers are the rotation column by column, then the origin; Pinocchio keeps them
    so (an SE3 holds its rotation, column-major, then its translation); else the two are
    copied apart.
    """
    start = rotation.__array_interface__["data"][0]
    if rotation.strides != (8, 24) or translation.strides != (8,) or (
            translation.__array_interface__["data"][0] != start + 72):
        return None
    return np.lib.stride_tricks.as_strided(rotation, shape=(12,), strides=(8,))

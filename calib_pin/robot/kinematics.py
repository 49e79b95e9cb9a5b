"""The one forward-kinematics path: a chain under a placement perturbation.

:class:`Kinematics` evaluates a :class:`~calib_pin.robot.chain.Chain` under a
perturbation: every joint placement and the end frame's placement are right-multiplied
by a small rigid transform, always rebuilt from the nominal placements (never
accumulated, never reverted). Parameter models (:mod:`calib_pin.parameters`) map their
deviations onto these transforms, so the one Pinocchio regressor serves them all.

Frames and units: positions in [m] in the base (URDF root) frame, joint angles in
[rad], twists as Pinocchio orders them (linear, angular) in the perturbed placement's
own frame.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .chain import Chain


class Kinematics:
    """Forward kinematics of a chain under a placement perturbation.

    Holds one working copy of the chain's model. :meth:`set_perturbation` rebuilds its
    placements from the nominal ones; :meth:`points` is the one FK path every estimator
    and the simulator use.
    """

    def __init__(self, chain: Chain) -> None:
        self.chain = chain
        self._model = chain.model.copy()
        self._data = self._model.createData()
        self._fid = chain.frame_id
        model = self._model
        placements = [model.jointPlacements[j] for j in range(1, model.njoints)] + [model.frames[self._fid].placement]
        #: Nominal joint placements, then the end frame's, shape (n_joints + 1, 4, 4).
        self._nominal = np.array([m.homogeneous for m in placements])
        # Live views into the working model: set_perturbation writes the placements in
        # place, and updateFramePlacement writes the end frame's pose where points reads it.
        self._targets = [(m.rotation, m.translation) for m in placements]
        self._placement = self._data.oMf[self._fid]
        self._rotation, self._translation = self._placement.rotation, self._placement.translation
        self._parent = self._data.oMi[model.frames[self._fid].parentJoint]  # forwardKinematics writes it
        self._parent_rotation, self._parent_translation = self._parent.rotation, self._parent.translation

    def set_perturbation(self, deltas: np.ndarray | None) -> None:
        """Rebuild the working placements as nominal * delta.

        Args:
            deltas: ``n_joints + 1`` homogeneous transforms, shape (n_joints + 1, 4, 4)
                (joints base to end, then the end frame; see
                :meth:`~calib_pin.parameters.base.ParameterModel.delta_matrices`), or
                None for the nominal robot.
        """
        placements = self._nominal if deltas is None else self._nominal @ deltas
        for (rotation, translation), placement in zip(self._targets, placements, strict=True):
            rotation[:] = placement[:3, :3]
            translation[:] = placement[:3, 3]

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
        model, data, fid = self._model, self._data, self._fid
        configs = self.chain.configuration(np.atleast_2d(q))
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
        model, data, fid = self._model, self._data, self._fid
        configs = self.chain.configuration(np.atleast_2d(q))
        n = len(configs)
        point = np.asarray(point, dtype=float)
        rot, trans = np.empty((n, 3, 3)), np.empty((n, 3))
        if not jacobian:  # the parent joint's placement, then the end frame's in it
            forward, live_rot, live_trans = pin.forwardKinematics, self._parent_rotation, self._parent_translation
            for k in range(n):
                forward(model, data, configs[k])
                rot[k] = live_rot
                trans[k] = live_trans
            frame_rot, frame_trans = self._targets[-1]
            local = point @ frame_rot.T + frame_trans  # the point in the parent joint's frame
            return trans + (rot @ local if local.ndim == 1 else (rot @ local[:, :, None])[:, :, 0]), None
        live_rot, live_trans = self._rotation, self._translation
        n_place = 6 * self.chain.n_joints
        # Columns: the placement regressor, the end frame's own local twist (identity),
        # then the joint Jacobian: one product with the lever below gives them all.
        reg = np.zeros((n, 6, n_place + 6 + (self.chain.n_joints if joints else 0)))
        reg[:, :, n_place : n_place + 6] = np.eye(6)
        for k in range(n):
            if joints:  # forward kinematics and the joint Jacobians in one pass
                pin.computeJointJacobians(model, data, configs[k])
            else:
                pin.forwardKinematics(model, data, configs[k])
            reg[k, :, :n_place] = pin.computeFrameKinematicRegressor(model, data, fid, pin.LOCAL)
            rot[k], trans[k] = live_rot, live_trans  # the regressor call updated the frame
            if joints:
                reg[k, :, n_place + 6 :] = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        return _lever(rot, trans, reg, np.broadcast_to(point, (n, 3)))


#: The Levi-Civita symbol as a (3, 9) matrix: point @ _CROSS gives -[point]x row-major,
#: the matrix of w -> w x point.
_CROSS = np.array([[[0, 0, 0], [0, 0, 1], [0, -1, 0]],
                   [[0, 0, -1], [0, 0, 0], [1, 0, 0]],
                   [[0, 1, 0], [-1, 0, 0], [0, 0, 0]]], dtype=float).reshape(3, 9)


def _lever(rot: np.ndarray, trans: np.ndarray, reg: np.ndarray,
           point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions of ``point`` (n, 3) and their derivative from the end frames' rotations
    (n, 3, 3) and translations (n, 3), and local end-frame twists (v, w) per column
    (n, 6, m). A local twist moves the point by R (v + w x point) = [R, -R [point]x] (v, w)."""
    n = len(rot)
    lever = np.empty((n, 3, 6))
    lever[:, :, :3] = rot
    lever[:, :, 3:] = rot @ (point @ _CROSS).reshape(n, 3, 3)
    return trans + (rot @ point[:, :, None])[:, :, 0], lever @ reg

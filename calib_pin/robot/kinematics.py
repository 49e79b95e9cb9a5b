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

from collections.abc import Sequence

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
        self._nominal = chain.model
        self._model = chain.model.copy()
        self._data = self._model.createData()
        self._fid = chain.frame_id
        self._frame_nominal = chain.model.frames[self._fid].placement.copy()
        self._joint_nominal = [
            chain.model.jointPlacements[j].copy() for j in range(1, chain.model.njoints)
        ]

    def set_perturbation(self, deltas: Sequence[pin.SE3] | None) -> None:
        """Rebuild the working placements as nominal * delta.

        Args:
            deltas: ``n_joints + 1`` transforms (joints base to end, then the end
                frame), or None for the nominal robot.
        """
        model = self._model
        if deltas is None:
            for j, nominal in enumerate(self._joint_nominal, start=1):
                model.jointPlacements[j] = nominal
            frame = model.frames[self._fid]
            frame.placement = self._frame_nominal
        else:
            for j, (nominal, delta) in enumerate(zip(self._joint_nominal, deltas, strict=False), start=1):
                model.jointPlacements[j] = nominal * delta
            frame = model.frames[self._fid]
            frame.placement = self._frame_nominal * deltas[-1]
        model.frames[self._fid] = frame

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
        point = np.broadcast_to(np.asarray(point, dtype=float), (n, 3))
        if not jacobian:
            positions = np.empty((n, 3))
            for k in range(n):
                pin.forwardKinematics(model, data, configs[k])
                positions[k] = pin.updateFramePlacement(model, data, fid).act(point[k])
            return positions, None
        rot = np.empty((n, 3, 3))
        trans = np.empty((n, 3))
        n_place = 6 * self.chain.n_joints
        reg = np.empty((n, 6, n_place + (self.chain.n_joints if joints else 0)))
        for k in range(n):
            if joints:  # forward kinematics and the joint Jacobians in one pass
                pin.computeJointJacobians(model, data, configs[k])
            else:
                pin.forwardKinematics(model, data, configs[k])
            placement = pin.updateFramePlacement(model, data, fid)
            rot[k] = placement.rotation
            trans[k] = placement.translation
            reg[k, :, :n_place] = pin.computeFrameKinematicRegressor(model, data, fid, pin.LOCAL)
            if joints:
                reg[k, :, n_place:] = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        # Local twist (v, w) of the end frame moves the point by R (v - [point]x w).
        eye = np.broadcast_to(np.eye(6), (n, 6, 6))
        local = np.concatenate([reg[:, :, :n_place], eye, reg[:, :, n_place:]], axis=2)
        lever = np.zeros((n, 3, 6))
        lever[:, :, :3] = np.eye(3)
        lever[:, :, 3:] = -np.cross(point[:, :, None], np.eye(3)[None], axis=1)
        return trans + np.einsum("nij,nj->ni", rot, point), rot @ (lever @ local)

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
        n_place = 6 * self.chain.n_joints
        frames = np.empty((n, 4, 4))
        reg = np.empty((n, 6, n_place + (self.chain.n_joints if joints else 0)))
        placement = data.oMf[fid]  # a live view: the regressor call updates it
        for k in range(n):
            if joints:  # forward kinematics and the joint Jacobians in one pass
                pin.computeJointJacobians(model, data, configs[k])
            else:
                pin.forwardKinematics(model, data, configs[k])
            reg[k, :, :n_place] = pin.computeFrameKinematicRegressor(model, data, fid, pin.LOCAL)
            frames[k] = placement.homogeneous
            if joints:
                reg[k, :, n_place:] = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        return self._lever(frames, reg, point, n_place)

    @staticmethod
    def _lever(frames: np.ndarray, reg: np.ndarray, point: np.ndarray,
               n_place: int) -> tuple[np.ndarray, np.ndarray]:
        """Positions of ``point`` and their derivative from the end frames (n, 4, 4) and
        local end-frame twists per column (n, 6, m): the placement regressor's first
        ``n_place`` columns, then any joint columns. A local twist (v, w) of the end
        frame moves the point by R (v + w x point); the end frame's own six columns go
        between the two groups."""
        n, m = len(frames), reg.shape[2]
        rot, trans = frames[:, :3, :3], frames[:, :3, 3]
        v, w = reg[:, :3], reg[:, 3:]
        px, py, pz = (point[:, i, None] for i in range(3))
        moved = np.empty((n, 3, m))
        moved[:, 0] = v[:, 0] + w[:, 1] * pz - w[:, 2] * py
        moved[:, 1] = v[:, 1] + w[:, 2] * px - w[:, 0] * pz
        moved[:, 2] = v[:, 2] + w[:, 0] * py - w[:, 1] * px
        minus_skew = np.zeros((n, 3, 3))  # -[point]x: w -> w x point
        minus_skew[:, 0, 1], minus_skew[:, 0, 2] = point[:, 2], -point[:, 1]
        minus_skew[:, 1, 0], minus_skew[:, 1, 2] = -point[:, 2], point[:, 0]
        minus_skew[:, 2, 0], minus_skew[:, 2, 1] = point[:, 1], -point[:, 0]
        rotated = rot @ moved
        d_positions = np.empty((n, 3, m + 6))
        d_positions[:, :, :n_place] = rotated[:, :, :n_place]
        d_positions[:, :, n_place : n_place + 3] = rot
        d_positions[:, :, n_place + 3 : n_place + 6] = rot @ minus_skew
        d_positions[:, :, n_place + 6 :] = rotated[:, :, n_place:]
        return trans + (rot @ point[:, :, None])[:, :, 0], d_positions

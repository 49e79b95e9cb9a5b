"""The robot as a Pinocchio model: the serial chain from the base to an end frame.

This module holds calib-pin's one forward-kinematics path. A :class:`Chain` is the
nominal model read from a URDF and reduced to the joints between the root and the end
frame. :class:`Kinematics` evaluates it under a perturbation: every joint placement and
the end frame's placement are right-multiplied by a small rigid transform, always
rebuilt from the nominal placements (never accumulated, never reverted). Parameter
models (:mod:`calib_pin.parameters`) map their deviations onto these transforms, so
the one Pinocchio regressor serves them all.

Frames and units: positions in [m] in the base (URDF root) frame, joint angles in
[rad], twists as Pinocchio orders them (linear, angular) in the perturbed placement's
own frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from .exceptions import RobotError
from .robots import RobotDescription, resolve_robot


def _load_urdf_model(description: RobotDescription) -> pin.Model:
    try:
        return pin.buildModelFromUrdf(str(description.urdf))
    except (RuntimeError, ValueError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise RobotError(f"{description.urdf}: Pinocchio cannot read this URDF: {first}") from e


def _body_frames(model: pin.Model) -> list[str]:
    return [f.name for f in model.frames if f.type == pin.FrameType.BODY]


@dataclass
class Chain:
    """Nominal serial chain from the URDF root to an end frame.

    Attributes:
        description: Where the robot came from.
        end_frame: Name of the end frame (e.g. ``tool0``).
        full_model: Pinocchio model of the whole URDF.
        model: ``full_model`` reduced to the chain's joints (others locked at zero).
        frame_id: Id of ``end_frame`` in ``model``.
        joint_names: Names of the chain's joints, base to end; shape (n,).
        lower, upper: Joint limits of the chain, shape (n,), in [rad] (or [m] for a
            prismatic joint); +-inf for a continuous joint.
    """

    description: RobotDescription
    end_frame: str
    full_model: pin.Model
    model: pin.Model
    frame_id: int
    joint_names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    _continuous: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0, bool))

    @property
    def n_joints(self) -> int:
        """Number of moving joints between base and end frame."""
        return len(self.joint_names)

    @property
    def name(self) -> str:
        return self.description.name

    @property
    def joint_kinds(self) -> tuple[str, ...]:
        """Pinocchio joint kind of each chain joint (``JointModelRY``, ...)."""
        return tuple(self.model.joints[j].shortname() for j in range(1, self.model.njoints))

    def configuration(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio configuration vectors for joint positions.

        Args:
            q: Joint positions, shape (n_poses, n_joints) or (n_joints,), [rad] or [m].

        Returns:
            Configurations, shape (n_poses, model.nq) (or (model.nq,)); a continuous
            joint's angle becomes its (cos, sin) pair.
        """
        q = np.asarray(q, dtype=float)
        if not self._continuous.any():
            return q
        cols = []
        for j in range(self.n_joints):
            if self._continuous[j]:
                cols += [np.cos(q[..., j]), np.sin(q[..., j])]
            else:
                cols.append(q[..., j])
        return np.stack(cols, axis=-1)

    def perturbed_model(self, deltas: Sequence[pin.SE3], full: bool = True) -> pin.Model:
        """A new Pinocchio model with perturbed joint placements and end frame.

        Args:
            deltas: ``n_joints + 1`` rigid transforms: one right-multiplied onto each
                chain joint's nominal placement, then one onto the end frame's.
            full: Perturb the whole URDF's model (True) or the reduced chain (False).
        """
        source = self.full_model if full else self.model
        out = source.copy()
        for name, delta in zip(self.joint_names, deltas[:-1], strict=True):
            j = out.getJointId(name)
            out.jointPlacements[j] = source.jointPlacements[j] * delta
        # The end frame's correction moves the whole tool chain rigidly, as in the URDF
        # export: every frame from the first fixed joint after the last moving joint on.
        end = source.frames[source.getFrameId(self.end_frame)].placement
        moved = end * deltas[-1] * end.inverse()
        for fid in tool_frames(source, source.getFrameId(self.end_frame)):
            frame = out.frames[fid]
            frame.placement = moved * source.frames[fid].placement
            out.frames[fid] = frame
        return out


def tool_frames(model: pin.Model, end_id: int) -> list[int]:
    """Frames that move with the end frame when its placement is corrected.

    These are the first fixed joint after the last moving joint on the way to the end
    frame, and every frame below it; just the end frame if no fixed joint lies between.
    """
    path, f = [], end_id
    while model.frames[f].type not in (pin.FrameType.JOINT, pin.FrameType.OP_FRAME) and f != 0:
        path.append(f)
        f = model.frames[f].parentFrame
    fixed = [f for f in reversed(path) if model.frames[f].type == pin.FrameType.FIXED_JOINT]
    if not fixed:
        return [end_id]
    root, out = fixed[0], []
    for fid in range(len(model.frames)):
        g = fid
        while g != root and g != 0 and model.frames[g].type != pin.FrameType.JOINT:
            g = model.frames[g].parentFrame
        if g == root:
            out.append(fid)
    return out


def load_chain(robot: str | RobotDescription, end_frame: str | None = None) -> Chain:
    """Load a robot and reduce it to the chain from its root to ``end_frame``.

    Args:
        robot: Robot name or URDF path (see :func:`calib_pin.robots.resolve_robot`), or
            a resolved description.
        end_frame: End frame name; default the description's (``tool0`` where it exists).

    Raises:
        RobotError: unknown robot, unreadable URDF, missing frame, or a chain joint
            with more than one degree of freedom.
    """
    description = robot if isinstance(robot, RobotDescription) else resolve_robot(robot)
    full = _load_urdf_model(description)
    end = end_frame or description.end_frame
    if end is None:
        raise RobotError(
            f"robot '{description.name}' has no frame 'tool0': choose the end frame with "
            f"--end-frame (body frames: {', '.join(_body_frames(full)[-8:])})"
        )
    if not full.existFrame(end):
        raise RobotError(
            f"robot '{description.name}' has no frame '{end}' "
            f"(body frames: {', '.join(_body_frames(full)[-8:])})"
        )
    chain_ids = []
    j = full.frames[full.getFrameId(end)].parentJoint
    while j > 0:
        chain_ids.append(j)
        j = full.parents[j]
    chain_ids.reverse()
    if not chain_ids:
        raise RobotError(f"frame '{end}' of robot '{description.name}' is on the fixed base")
    for j in chain_ids:
        if full.joints[j].nv != 1:
            raise RobotError(
                f"joint '{full.names[j]}' of robot '{description.name}' has "
                f"{full.joints[j].nv} degrees of freedom; calib-pin calibrates chains of "
                "revolute and prismatic joints"
            )
    locked = [j for j in range(1, full.njoints) if j not in chain_ids]
    model = pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full.copy()
    continuous = np.array([model.joints[j].nq == 2 for j in range(1, model.njoints)])
    lower = np.full(len(chain_ids), -np.inf)
    upper = np.full(len(chain_ids), np.inf)
    for k in range(len(chain_ids)):
        if not continuous[k]:
            iq = model.joints[k + 1].idx_q
            lower[k] = model.lowerPositionLimit[iq]
            upper[k] = model.upperPositionLimit[iq]
    return Chain(
        description=description,
        end_frame=end,
        full_model=full,
        model=model,
        frame_id=model.getFrameId(end),
        joint_names=tuple(model.names[1:]),
        lower=lower,
        upper=upper,
        _continuous=continuous,
    )


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
            for j, (nominal, delta) in enumerate(zip(self._joint_nominal, deltas), start=1):
                model.jointPlacements[j] = nominal * delta
            frame = model.frames[self._fid]
            frame.placement = self._frame_nominal * deltas[-1]
        model.frames[self._fid] = frame

    def points(
        self, q: np.ndarray, point: np.ndarray, jacobian: bool = False
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Base-frame positions of a point fixed in the end frame, at many poses.

        Args:
            q: Joint positions, shape (n_poses, n_joints), [rad].
            point: The point in the end frame, shape (3,), [m], or one point per pose,
                shape (n_poses, 3).
            jacobian: Also return the derivative with respect to the placement
                perturbation (from Pinocchio's frame kinematic regressor).

        Returns:
            positions: shape (n_poses, 3), [m], base frame.
            d_positions: shape (n_poses, 3, 6 * (n_joints + 1)) or None: derivative of
                each position with respect to a right-multiplied twist (linear, angular;
                [m], [rad]) of each joint placement, then of the end frame placement.
                The end frame's three linear columns are its rotation matrix, which is
                also the derivative of the position with respect to the point.
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
        reg = np.empty((n, 6, 6 * self.chain.n_joints))
        for k in range(n):
            pin.forwardKinematics(model, data, configs[k])
            placement = pin.updateFramePlacement(model, data, fid)
            rot[k] = placement.rotation
            trans[k] = placement.translation
            reg[k] = pin.computeFrameKinematicRegressor(model, data, fid, pin.LOCAL)
        # Local twist (v, w) of the end frame moves the point by R (v - [point]x w).
        local = np.concatenate([reg, np.broadcast_to(np.eye(6), (n, 6, 6))], axis=2)
        lever = np.zeros((n, 3, 6))
        lever[:, :, :3] = np.eye(3)
        lever[:, :, 3:] = -np.cross(point[:, :, None], np.eye(3)[None], axis=1)
        return trans + np.einsum("nij,nj->ni", rot, point), rot @ (lever @ local)

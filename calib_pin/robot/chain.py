"""The robot as a Pinocchio model: the serial chain from the base to an end frame.

A :class:`Chain` is the nominal model read from a URDF and reduced to the joints between
the root and the end frame; :func:`load_chain` builds it. The one forward-kinematics path
that evaluates it under a perturbation is :class:`calib_pin.robot.kinematics.Kinematics`.

Units: joint angles in [rad] (prismatic joints [m]), positions in [m], base frame.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any
from xml.etree import ElementTree

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError, RobotError
from ..util.arguments import (
    CONTINUOUS_TURNS,
    LIMIT_TOLERANCE,
    as_array,
    as_instance,
    as_optional,
    outside_limits,
)
from .description import RobotDescription, as_robot, resolve_robot


@contextlib.contextmanager
def _console_to(sink: IO[bytes]) -> Iterator[None]:
    """Send what C++ code prints on stderr (file descriptor 2) to ``sink``."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        os.dup2(sink.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _check_tree(path: Path) -> None:
    """Refuse a URDF whose links do not form a tree (a link with two parent joints)."""
    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError):
        return  # Pinocchio says what is wrong
    parents: dict[str, str] = {}
    for joint in root.iter("joint"):
        child = joint.find("child")
        link = child.get("link") if child is not None else None
        if link in parents:
            raise RobotError(f"{path}: link '{link}' is the child of two joints ('{parents[link]}' and "
                             f"'{joint.get('name')}'), a kinematic loop: calib-pin needs a tree of joints")
        if link:
            parents[link] = str(joint.get("name"))


def _load_urdf_model(description: RobotDescription) -> pin.Model:
    path = Path(description.urdf)
    try:
        path.read_bytes()
    except OSError as e:
        raise RobotError(f"{path}: cannot read the URDF: {e.strerror or e}") from None
    _check_tree(path)
    with tempfile.TemporaryFile() as console:
        try:
            with _console_to(console):  # urdfdom prints its own lines: keep their detail for ours
                return pin.buildModelFromUrdf(str(path))
        except (RuntimeError, ValueError) as e:
            console.seek(0)
            said = [ln.strip() for ln in console.read().decode("utf-8", "replace").splitlines() if ln.strip()]
            first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            detail = f" ({said[0].removeprefix('Error:').strip()[:200]})" if said else ""
            raise RobotError(f"{path}: Pinocchio cannot read this URDF: {first}{detail}") from e


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

    @functools.cached_property
    def joint_kinds(self) -> tuple[str, ...]:
        """Pinocchio joint kind of each chain joint (``JointModelRY``, ...).

        Read once: the CSV reader asks for every angle of every row.
        """
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
            parent = model.frames[g].parentFrame
            if parent == g:  # a joint locked by buildReducedModel can be its own parent
                break
            g = parent
        if g == root:
            out.append(fid)
    return out


def load_chain(robot: str | RobotDescription, end_frame: str | None = None) -> Chain:
    """Load a robot and reduce it to the chain from its root to ``end_frame``.

    Args:
        robot: Robot name or URDF path (see :func:`calib_pin.robot.description.resolve_robot`), or
            a resolved description.
        end_frame: End frame name; default the description's (``tool0`` where it exists).

    Raises:
        RobotError: unknown robot, unreadable URDF, missing frame, or a chain joint
            with more than one degree of freedom.
        ArgumentError: robot not a name, path or description; end_frame not text.
    """
    robot = as_robot(robot, "robot")
    end_frame = as_optional(as_instance, end_frame, "end_frame", str, "an end frame's name")
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
    _check_joints(full, chain_ids, description)
    locked = [j for j in range(1, full.njoints) if j not in chain_ids]
    model = pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full.copy()
    continuous, lower, upper = _limits(model, description.limit_margin)
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


def _limits(model: pin.Model, margin: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each joint of a chain model: continuous or not, and its limits ([rad] or [m]).

    The limits are +-inf for a continuous joint; a revolute joint's are widened by
    ``margin`` [rad] each way.
    """
    n = model.njoints - 1
    continuous = np.array([model.joints[j].nq == 2 for j in range(1, model.njoints)])
    lower, upper = np.full(n, -np.inf), np.full(n, np.inf)
    for k in range(n):
        if not continuous[k]:
            iq = model.joints[k + 1].idx_q
            widen = margin if not model.joints[k + 1].shortname().startswith("JointModelP") else 0.0
            lower[k] = model.lowerPositionLimit[iq] - widen
            upper[k] = model.upperPositionLimit[iq] + widen
    return continuous, lower, upper


def joint_motions(model: pin.Model) -> np.ndarray:
    """Each joint's motion subspace S (linear, angular) in its own frame, shape (njoints - 1, 6).

    A unit axis in the angular part for a revolute joint, in the linear part for a
    prismatic one (Pinocchio's local joint Jacobian at the neutral pose).
    """
    data = model.createData()
    pin.computeJointJacobians(model, data, pin.neutral(model))
    return np.array([np.reshape(pin.getJointJacobian(model, data, j, pin.LOCAL), (6, -1))[:, model.joints[j].idx_v]
                     for j in range(1, model.njoints)]).reshape(-1, 6)  # (6,) when the model has one dof


def _check_joints(full: pin.Model, chain_ids: list[int], description: RobotDescription) -> None:
    """Refuse a chain joint with a zero axis or with limits that leave no range."""
    motions = joint_motions(full)
    for j in chain_ids:
        name, joint = full.names[j], full.joints[j]
        if not np.linalg.norm(motions[j - 1]) > 0:
            raise RobotError(f"{description.urdf}: joint '{name}' has a zero axis (it moves nothing)")
        if joint.nq == 1:
            lower, upper = full.lowerPositionLimit[joint.idx_q], full.upperPositionLimit[joint.idx_q]
            if not lower < upper:
                raise RobotError(f"{description.urdf}: joint '{name}' has limits lower {lower:g} >= upper {upper:g}: "
                                 "no range to move in")


def as_chain(value: Any, arg: str = "chain") -> Chain:
    """A robot chain (:func:`calib_pin.load_chain`).

    Args:
        value: The value to check.
        arg: The argument's name, for messages.

    Raises:
        ArgumentError: anything else, naming ``arg``.
    """
    return as_instance(value, arg, Chain, "a robot chain (calib_pin.load_chain('irb120'))")  # type: ignore[no-any-return]


def as_angles_rad(q: Any, arg: str, chain: Chain, *, tolerance: float = LIMIT_TOLERANCE) -> np.ndarray:
    """Joint angles [rad] (prismatic joints [m]) of ``chain``, checked; the array keeps its shape.

    Shape (n_joints,) or (n, n_joints), finite, within the URDF limits (less ``tolerance``;
    a continuous joint within CONTINUOUS_TURNS turns).

    A value outside the limits, when some |q| is beyond a turn (2 pi) and every value
    read as degrees would fit, gets the hint "looks like degrees".

    Args:
        q: The joint angles [rad] (prismatic joints [m]).
        arg: The argument's name, for messages.
        chain: The robot chain whose limits apply.
        tolerance: How far outside a limit a value may be, [rad] (or [m]).

    Raises:
        ArgumentError: naming ``arg``: not numbers, another shape, not finite, outside the limits.
    """
    angles = as_array(q, arg, unit="rad")
    if angles.ndim not in (1, 2) or angles.shape[-1] != chain.n_joints:
        raise ArgumentError(arg, f"expected shape ({chain.n_joints},) or (n, {chain.n_joints}) (one angle per joint "
                            f"of '{chain.name}' to '{chain.end_frame}'), got shape {angles.shape}")
    turns = CONTINUOUS_TURNS * 2 * np.pi
    lower = np.where(np.isfinite(chain.lower), chain.lower, -turns)
    upper = np.where(np.isfinite(chain.upper), chain.upper, turns)
    where = outside_limits(angles, lower, upper, tolerance)
    if where is not None:
        j = where[-1]
        revolute = not chain.joint_kinds[j].startswith("JointModelP")
        unit = "rad" if revolute else "m"
        radians = np.deg2rad(angles)
        hint = ("; looks like degrees: give radians (np.deg2rad)" if revolute and np.abs(angles).max() > 2 * np.pi
                and outside_limits(radians, lower, upper, tolerance) is None else "")
        index = f"[{', '.join(map(str, where))}]"
        raise ArgumentError(arg, f"{arg}{index} = {angles[where]:.6g} {unit} is outside the limits of "
                            f"{chain.joint_names[j]} [{chain.lower[j]:.6g}, {chain.upper[j]:.6g}] {unit}{hint}")
    return angles

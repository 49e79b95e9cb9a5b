"""Unknowns held at their nominal value (``calibrate --fix`` / ``--free``).

A held unknown keeps its start value (the nominal, 0 deviation; with ``--nominal`` the
start's) and the estimator searches the others only, through the same reduced problem
the compliance bound uses (:class:`calib_pin.estimators.active_set.Fixed`, via
``run_estimator(..., fixed=...)``); ``--analyze`` leaves their columns out.

- ``fix``: the names to hold, any unknown of the problem: a robot deviation
  (``theta_1``, ``d_1``), a compliance (``compliance_joint_2``) or a sensor unknown
  (``device_rz``, ``anchor_x``). With several sets the robot's unknowns are shared (a
  name holds it for every set) and a set's sensor unknown carries its label (``s2:anchor_x``).
- ``free``: the robot's deviations and compliances to estimate; every other one is
  held. The sensor's own unknowns (device frame, markers, anchor) stay free: they are
  the set-up, not the robot.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..exceptions import ArgumentError
from ..util.arguments import as_names


def held_names(names: Sequence[str], n_robot_side: int, fix: Any = None, free: Any = None) -> tuple[str, ...]:
    """The unknowns to hold, in the problem's order.

    Args:
        names: Every unknown of the problem, in order (``problem.model.names``).
        n_robot_side: How many of them are the robot's (deviations and compliances,
            ``model.sensor_start``); the rest are the sensor's.
        fix, free: Names, a comma-separated str or a sequence (None: none).

    Raises:
        ArgumentError: an unknown name (with the valid ones), a name in both, an empty
            list (or text that names nothing), or every robot unknown held.
    """
    given = {"fix": fix, "free": free}
    fix, free = as_names(fix, "fix"), as_names(free, "free")
    for arg, held in (("fix", fix), ("free", free)):
        if given[arg] is not None and not held:  # free=[]: not "every unknown free", a list that lost its names
            raise ArgumentError(arg, f"an empty list names nothing: give the unknowns, or {arg}=None")
    robot = tuple(names[:n_robot_side])
    for arg, given, valid in (("fix", fix, tuple(names)), ("free", free, robot)):
        unknown = [n for n in given if n not in valid]
        if unknown:
            per_set = [n for n in valid if n.partition(":")[2] == unknown[0]]  # several sets: ``<label>:<name>``
            if per_set:
                raise ArgumentError(arg, f"'{unknown[0]}' is a sensor unknown of several sets: name the set's, "
                                    f"{' or '.join(per_set)}")
            raise ArgumentError(arg, f"no unknown '{unknown[0]}' in this calibration (valid: {', '.join(valid)})")
    both = set(fix) & set(free)
    if both:
        raise ArgumentError("fix", f"'{sorted(both)[0]}' is both fixed and free: name it once")
    held = set(fix) | ({n for n in robot if n not in free} if free else set())
    if held >= set(robot):
        raise ArgumentError("fix" if fix else "free", "every robot unknown is held: nothing of the robot is left "
                            "to calibrate")
    return tuple(n for n in names if n in held)

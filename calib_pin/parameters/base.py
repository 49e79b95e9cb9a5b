"""What every parameter model provides: named deviations -> placement perturbations.

A parameter model turns a deviation vector ``x`` (SI units: [m] and [rad]) into the
``n_joints + 1`` rigid transforms that :class:`calib_pin.robot.kinematics.Kinematics`
multiplies onto the nominal joint placements and the end frame's placement, and gives the
derivative of those transforms as right-multiplied twists. Every model therefore shares
the same forward kinematics and the same Pinocchio regressor.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError
from ..util.arguments import shown_value


class ParameterModel(Protocol):
    """What every parameter model provides.

    Attributes:
        name: The model's name on the command line (``dh``, ``hayati``, ``placement``).
        names: Parameter names, shape (n_params,), e.g. ``a_2``, ``theta_6``.
        units: SI unit of each parameter, ``m`` or ``rad``.
        scale: Typical size of each deviation in SI units, shape (n_params,): the
            prior standard deviation of the Kalman filters and the column scaling of
            the searches.
    """

    name: str
    names: tuple[str, ...]
    units: tuple[str, ...]
    scale: np.ndarray

    def delta_matrices(self, x: np.ndarray) -> np.ndarray:
        """Transforms right-multiplied onto each joint placement, then the end frame, as matrices.

        Homogeneous matrices, shape (n_joints + 1, 4, 4) (the FK path's form).
        """
        ...

    def deltas(self, x: np.ndarray) -> list[pin.SE3]:
        """:meth:`delta_matrices` as Pinocchio transforms."""
        ...

    def delta_jacobian(self, x: np.ndarray) -> np.ndarray:
        """Derivative of :meth:`deltas` as right twists, shape (6 (n_joints + 1), n_params)."""
        ...


def as_parameter_model(value: Any, arg: str, chain: Any = None) -> Any:
    """A parameter model (:func:`calib_pin.parameter_model`), of ``chain`` when given.

    Args:
        value: The value to check.
        arg: The argument's name, for messages.
        chain: The chain it must belong to, or None.

    Raises:
        ArgumentError: not a parameter model, or one of another chain, naming ``arg``.
    """
    if not all(hasattr(value, a) for a in ("names", "units", "delta_matrices")):
        raise ArgumentError(arg, f"expected a parameter model (calib_pin.parameter_model(chain)), got {shown_value(value)}")
    own = getattr(value, "chain", None)
    if chain is not None and own is not None and own is not chain and (
            own.name != chain.name or own.joint_names != chain.joint_names or own.end_frame != chain.end_frame):
        raise ArgumentError(arg, f"is a model of '{own.name}' to '{own.end_frame}', not of '{chain.name}' "
                            f"to '{chain.end_frame}'")
    return value

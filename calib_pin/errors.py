"""The error model: predicted drawstring readings, residuals and the identification Jacobian.

A drawstring (cable) sensor whose body sits at a fixed point P0 of the base frame reads
the distance to a hook point p on the end effector, plus a zero offset (paper eq. 6-7):

    reading(q) = || p(q, x) - P0 || + offset.

:class:`CableModel` predicts readings for deviations ``x`` of a parameter model and
gives their analytic derivative (the identification Jacobian H of eq. 5 projected on
the cable direction), built from Pinocchio's frame kinematic regressor.
:class:`CalibrationProblem` binds it to measured readings: the one residual function
and the one Jacobian every estimator uses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import Chain, Kinematics
from .parameters import ParameterModel


@dataclass(frozen=True)
class Drawstring:
    """Geometry of a drawstring sensor.

    Attributes:
        anchor: P0, the sensor's fixed point, shape (3,), [m], base frame.
        hook: Where the cable hooks on, shape (3,), [m], end frame.
        offset: Zero offset added to the distance, [m].
    """

    anchor: np.ndarray
    hook: np.ndarray
    offset: float = 0.0


class CableModel:
    """Drawstring readings of a chain whose deviations follow a parameter model."""

    def __init__(self, chain: Chain, params: ParameterModel, sensor: Drawstring) -> None:
        self.chain = chain
        self.params = params
        self.sensor = sensor
        self._kin = Kinematics(chain)

    @property
    def n_params(self) -> int:
        return len(self.params.names)

    def hook_positions(self, x: np.ndarray | None, q: np.ndarray) -> np.ndarray:
        """Hook point in the base frame, shape (n_poses, 3), [m]; x None: nominal."""
        self._kin.set_perturbation(None if x is None else self.params.deltas(x))
        return self._kin.points(q, self.sensor.hook)[0]

    def predict(self, x: np.ndarray | None, q: np.ndarray) -> np.ndarray:
        """Predicted readings, shape (n_poses,), [m], for joint angles q (n_poses, n) [rad]."""
        return np.linalg.norm(self.hook_positions(x, q) - self.sensor.anchor, axis=1) + self.sensor.offset

    def point_jacobian(self, x: np.ndarray, q: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A point fixed in the end frame and its derivative with respect to x.

        Returns:
            positions: shape (n_poses, 3), [m], base frame.
            jacobian: shape (n_poses, 3, n_params), [m per unit of each parameter].
        """
        self._kin.set_perturbation(self.params.deltas(x))
        points, d_points = self._kin.points(q, point, jacobian=True)
        return points, d_points @ self.params.delta_jacobian(x)

    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predicted readings and their derivative with respect to x.

        Returns:
            readings: shape (n_poses,), [m].
            jacobian: shape (n_poses, n_params), [m per unit of each parameter].
        """
        points, d_points = self.point_jacobian(x, q, self.sensor.hook)
        cable = points - self.sensor.anchor
        length = np.linalg.norm(cable, axis=1)
        direction = cable / length[:, None]
        return length + self.sensor.offset, np.einsum("ni,nij->nj", direction, d_points)


@dataclass
class CalibrationProblem:
    """Measured readings and the model that predicts them.

    Attributes:
        model: The cable model.
        q: Joint angles of the poses, shape (n_poses, n_joints), [rad].
        readings: Measured readings, shape (n_poses,), [m].
    """

    model: CableModel
    q: np.ndarray
    readings: np.ndarray

    @property
    def n_params(self) -> int:
        return self.model.n_params

    @property
    def n_poses(self) -> int:
        return len(self.readings)

    def subset(self, rows: np.ndarray) -> CalibrationProblem:
        """The same problem restricted to some poses (row indices)."""
        return CalibrationProblem(self.model, self.q[rows], self.readings[rows])

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Predicted minus measured reading, shape (n_poses,), [m]."""
        return self.model.predict(x, self.q) - self.readings

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Derivative of :meth:`residual`, shape (n_poses, n_params)."""
        return self.model.predict_with_jacobian(x, self.q)[1]

    def cost(self, x: np.ndarray) -> float:
        """Mean squared residual (paper eq. 6), [m^2]."""
        r = self.residual(x)
        return float(r @ r) / len(r)

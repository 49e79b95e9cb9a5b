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


#: Sensor quantities a cable model can estimate with the robot's parameters.
CABLE_EXTRAS = ("anchor", "offset")


class MeasurementModel:
    """What the cable and position models share: the robot's deviations followed by
    the sensor's own unknowns in one vector x.

    Attributes:
        chain, params: The robot chain and its parameter model.
        names, units, scale: Of every entry of x (robot deviations first, then the
            sensor's), shape (n_params,): the scale is the typical size in SI units.
        values_per_row: Numbers one data row holds (1 reading or 3 coordinates).
    """

    values_per_row = 1

    def __init__(self, chain: Chain, params: ParameterModel, extra: list[tuple[str, str, float]]) -> None:
        self.chain = chain
        self.params = params
        self._kin = Kinematics(chain)
        self.n_robot = len(params.names)
        self.names = tuple(params.names) + tuple(e[0] for e in extra)
        self.units = tuple(params.units) + tuple(e[1] for e in extra)
        self.scale = np.concatenate([params.scale, [e[2] for e in extra]])

    @staticmethod
    def chosen(estimate: tuple[str, ...], valid: tuple[str, ...], sensor: str) -> tuple[str, ...]:
        """The sensor unknowns to estimate, in ``valid``'s order.

        Raises:
            ValueError: a name this sensor has no such unknown for.
        """
        unknown = set(estimate) - set(valid)
        if unknown:
            raise ValueError(f"{sensor} cannot estimate {sorted(unknown)[0]!r} (valid: {', '.join(valid)})")
        return tuple(e for e in valid if e in estimate)

    @property
    def n_params(self) -> int:
        return len(self.names)

    def robot(self, x: np.ndarray) -> np.ndarray:
        """The robot's deviations within x, shape (n_robot,)."""
        return np.asarray(x, dtype=float)[: self.n_robot]

    def point_jacobian(self, x: np.ndarray, q: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A point fixed in the end frame (shape (3,) or one per pose (n_poses, 3), [m])
        and its derivative with respect to x.

        Returns:
            positions: shape (n_poses, 3), [m], base frame.
            jacobian: shape (n_poses, 3, n_params), [m per unit of each parameter];
                zero in the sensor's columns.
        """
        points, _, jac = self._points_with_jacobians(x, q, point)
        return points, jac

    def _points_with_jacobians(self, x: np.ndarray, q: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`point_jacobian` plus the end-frame rotations, shape (n_poses, 3, 3)
        (the derivative of each position with respect to the point itself)."""
        xr = self.robot(x)
        self._kin.set_perturbation(self.params.deltas(xr))
        points, d_place = self._kin.points(q, point, jacobian=True)
        jac = np.zeros((len(points), 3, self.n_params))
        jac[:, :, : self.n_robot] = d_place @ self.params.delta_jacobian(xr)
        k = 6 * self.chain.n_joints  # the end frame's linear columns are its rotation
        return points, d_place[:, :, k : k + 3], jac


class CableModel(MeasurementModel):
    """Drawstring readings of a chain whose deviations follow a parameter model.

    With ``estimate`` the sensor's anchor P0 (``anchor_x/y/z`` [m], base frame, typical
    error 2 mm) and its zero offset (``offset`` [m], 1 mm) join x after the robot's
    deviations, as corrections to ``sensor``'s values.
    """

    def __init__(self, chain: Chain, params: ParameterModel, sensor: Drawstring, estimate: tuple[str, ...] = ()) -> None:
        self.estimate = self.chosen(estimate, CABLE_EXTRAS, "a drawstring")
        extra = [(f"anchor_{a}", "m", 2e-3) for a in "xyz"] if "anchor" in estimate else []
        extra += [("offset", "m", 1e-3)] if "offset" in estimate else []
        super().__init__(chain, params, extra)
        self.sensor = sensor

    def sensor_at(self, x: np.ndarray | None) -> Drawstring:
        """The sensor geometry x implies (``sensor`` plus the estimated corrections)."""
        if x is None or not self.estimate:
            return self.sensor
        extra = np.asarray(x, dtype=float)[self.n_robot :]
        anchor, offset = self.sensor.anchor, self.sensor.offset
        if "anchor" in self.estimate:
            anchor, extra = anchor + extra[:3], extra[3:]
        if "offset" in self.estimate:
            offset = offset + extra[0]
        return Drawstring(anchor=anchor, hook=self.sensor.hook, offset=offset)

    def hook_positions(self, x: np.ndarray | None, q: np.ndarray) -> np.ndarray:
        """Hook point in the base frame, shape (n_poses, 3), [m]; x None: nominal."""
        self._kin.set_perturbation(None if x is None else self.params.deltas(self.robot(x)))
        return self._kin.points(q, self.sensor.hook)[0]

    def predict(self, x: np.ndarray | None, q: np.ndarray, markers: np.ndarray | None = None) -> np.ndarray:
        """Predicted readings, shape (n_poses,), [m], for joint angles q (n_poses, n) [rad]."""
        sensor = self.sensor_at(x)
        return np.linalg.norm(self.hook_positions(x, q) - sensor.anchor, axis=1) + sensor.offset

    def predict_with_jacobian(
        self, x: np.ndarray, q: np.ndarray, markers: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Predicted readings and their derivative with respect to x.

        Returns:
            readings: shape (n_poses,), [m].
            jacobian: shape (n_poses, n_params), [m per unit of each parameter].
        """
        sensor = self.sensor_at(x)
        points, d_points = self.point_jacobian(x, q, self.sensor.hook)
        cable = points - sensor.anchor
        length = np.linalg.norm(cable, axis=1)
        direction = cable / length[:, None]
        jac = np.einsum("ni,nij->nj", direction, d_points)
        col = self.n_robot
        if "anchor" in self.estimate:
            jac[:, col : col + 3] = -direction
            col += 3
        if "offset" in self.estimate:
            jac[:, col] = 1.0
        return length + sensor.offset, jac


@dataclass
class CalibrationProblem:
    """Measured data and the model that predicts it: the one residual and the one
    Jacobian every estimator uses.

    Attributes:
        model: A :class:`CableModel` or a :class:`calib_pin.position.PositionModel`.
        q: Joint angles of the rows, shape (n_poses, n_joints), [rad].
        readings: Measured values: cable readings, shape (n_poses,), [m]; or positions,
            shape (n_poses, 3), [m] in the measuring device's frame.
        markers: For positions, each row's marker index (n_poses,); else None.
    """

    model: MeasurementModel
    q: np.ndarray
    readings: np.ndarray
    markers: np.ndarray | None = None

    @property
    def n_params(self) -> int:
        return self.model.n_params

    @property
    def n_poses(self) -> int:
        """Data rows."""
        return len(self.readings)

    @property
    def n_values(self) -> int:
        """Length of the residual: rows times values per row."""
        return int(np.size(self.readings))

    def subset(self, rows: np.ndarray) -> CalibrationProblem:
        """The same problem restricted to some rows (row indices)."""
        markers = None if self.markers is None else self.markers[rows]
        return CalibrationProblem(self.model, self.q[rows], self.readings[rows], markers)

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Predicted values, shaped like ``readings``, [m]."""
        return self.model.predict(x, self.q, self.markers)

    def predict_with_jacobian(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predicted values flattened, shape (n_values,), and their Jacobian (n_values, n_params)."""
        values, jac = self.model.predict_with_jacobian(x, self.q, self.markers)
        return values.reshape(-1), jac.reshape(self.n_values, -1)

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Predicted minus measured values, flattened, shape (n_values,), [m]."""
        return (self.predict(x) - self.readings).reshape(-1)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Derivative of :meth:`residual`, shape (n_values, n_params)."""
        return self.predict_with_jacobian(x)[1]

    def row_errors(self, residual: np.ndarray) -> np.ndarray:
        """Size of each row's error, shape (n_poses,), [m]: |reading error| for a
        cable, the Euclidean position error for positions."""
        return np.linalg.norm(np.asarray(residual).reshape(self.n_poses, -1), axis=1)

    def rows_of(self, values: np.ndarray) -> np.ndarray:
        """Rows that hold the given residual entries (indices into the residual)."""
        per_row = self.model.values_per_row
        return np.unique(np.asarray(values, dtype=int) // per_row)

    def cost(self, x: np.ndarray) -> float:
        """Mean squared residual (paper eq. 6), [m^2]."""
        r = self.residual(x)
        return float(r @ r) / len(r)

"""6-D poses (a tracker's 6-DoF probe, motion capture): the third sensor type.

A device with its own frame D records the pose of a body K fixed on the end effector:
its position ``x_mm, y_mm, z_mm`` and its orientation as a Hamilton unit quaternion
``qw, qx, qy, qz``, both in the device frame. At joint angles q it reads

    T_DK = T_DB T_BE(q, x) T_EK,

with T_DB the (unknown) pose of the robot base in the device frame and T_EK the
(unknown) pose of the body in the end frame. Each is parametrised around its starting
value (:func:`fit_rig`, with the nominal robot on the training rows) by a translation
correction [m] and a right rotation vector [rad]: R = R0 exp3(rho), t = t0 + tau
(``device_x/y/z``, ``device_rx/ry/rz``, ``body_x/y/z``, ``body_rx/ry/rz``).

A row's residual has 6 entries: the position error p_pred - p_meas [m], then the
orientation error's rotation vector log3(R_meas^T R_pred) [rad] times
``noise_m / noise_rad`` (the position noise over the orientation noise, both 1 sigma
per axis), so that every entry of a row has the position noise and the rows are
whitened consistently. The two noises come from ``# noise_mm`` and ``# noise_deg`` (or
the caller's ``noise_mm`` / ``--noise-deg``); a part stated nowhere has its sigma
estimated from its own residual when the set is calibrated alone
(:meth:`PoseModel.noise_parts`, :mod:`calib_pin.calibration.noise`, the
variance-component loop of several sets). :meth:`PoseModel.part_errors` gives each part
in its own unit (mm, deg).

The maths is Pinocchio's: ``pin.log3`` / ``pin.Jlog3`` for the error, ``pin.exp3`` /
``pin.Jexp3`` for the parametrisation, the frame kinematic regressor (through
:meth:`~calib_pin.sensors.base.MeasurementModel.points_with_jacobians`) for the robot's
columns. The analytic Jacobian is checked against finite differences in the tests.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements.schema import SCHEMAS, Schema
from ..robot.chain import Chain
from ..robot.deflection import ComplianceSpec
from ..robot.kinematics import cross_matrices
from ..util.arguments import as_optional
from .base import (
    DEFAULT_NOISE_MM,
    MeasurementModel,
    NoisePart,
    chosen,
    fit_rows_name,
    frame_unknowns,
    refuse_too_few,
)
from .misreading import Misreading, Reading, Suspect
from .problem import SetProblem
from .setup import SensorSetup, option

if TYPE_CHECKING:
    from ..measurements import MeasurementSet
    from ..parameters import ParameterModel

#: Orientation noise (1 sigma per axis) assumed when neither ``# noise_deg`` nor the caller give it, [deg].
DEFAULT_NOISE_DEG = 0.01
#: What a pose model estimates with the robot's deviations (both, unless a truth's model).
POSE_EXTRAS = ("device", "body")


def quaternion_matrices(quat: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of Hamilton quaternions (n, 4) ``w, x, y, z`` (normalised first)."""
    quat = np.asarray(quat, dtype=float).reshape(-1, 4)
    w, x, y, z = (quat / np.linalg.norm(quat, axis=1, keepdims=True)).T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=1)


def matrix_quaternions(rot: np.ndarray) -> np.ndarray:
    """Hamilton quaternions (n, 4) ``w, x, y, z`` (w >= 0) of rotation matrices (n, 3, 3)."""
    out = np.empty((len(rot), 4))
    for k, r in enumerate(rot):
        q = pin.Quaternion(r)
        out[k] = (q.w, q.x, q.y, q.z)
    out[out[:, 0] < 0] *= -1.0
    return out


def _project(m: np.ndarray) -> np.ndarray:
    """The rotation nearest to a 3x3 matrix (Frobenius)."""
    u, _, vt = np.linalg.svd(m)
    return u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt


@dataclass(frozen=True)
class PoseRig:
    """Geometry of a 6-D pose set-up.

    Attributes:
        device: T_DB, maps base-frame points to device-frame points (pin.SE3, [m]).
        body: T_EK, the measured body's pose in the end frame (pin.SE3, [m]).
    """

    device: pin.SE3
    body: pin.SE3

    def to_dict(self) -> dict:
        """In mm and degrees (rpy: roll, pitch, yaw about the fixed x, y, z axes)."""
        def frame(t: pin.SE3, meaning: str) -> dict:
            return {"translation_mm": (t.translation * 1e3).tolist(),
                    "rpy_deg": np.rad2deg(pin.rpy.matrixToRpy(t.rotation)).tolist(), "meaning": meaning}

        return {"device_frame": frame(self.device, "p_device = R p_base + t"),
                "body": frame(self.body, "p_end = R p_body + t")}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> PoseRig:
        """Inverse of :meth:`to_dict`."""
        def frame(d: Mapping[str, Any]) -> pin.SE3:
            rot = pin.rpy.rpyToMatrix(*np.deg2rad(np.asarray(d["rpy_deg"], dtype=float)))
            return pin.SE3(rot, np.asarray(d["translation_mm"], dtype=float) * 1e-3)

        return cls(frame(doc["device_frame"]), frame(doc["body"]))


def _positive_deg(text: str) -> float:
    """``--noise-deg``: an angle in (0, 180] deg, the record's range (one message for both ends)."""
    import argparse

    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 < value <= 180.0:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 180] deg, got '{text[:40]}'")
    return value


@dataclass(frozen=True, eq=False)
class PoseSetup(SensorSetup):
    """A 6-D pose set-up's options.

    The device frame and the body start from their best fit on the training rows and are
    always estimated.

    Attributes:
        noise_deg: Orientation noise, 1 sigma per axis, [deg] (None: the file's
            ``# noise_deg``, else :data:`DEFAULT_NOISE_DEG`).

    Raises:
        ArgumentError: naming the field.
    """

    title: ClassVar[str] = "6-D pose"

    noise_deg: Any = option(help="orientation noise of a 6-D pose set, 1 sigma per axis", unit="deg",
                            parser=_positive_deg)

    def __post_init__(self) -> None:
        from ..util.arguments import as_float

        object.__setattr__(self, "noise_deg", as_optional(as_float, self.noise_deg, "noise_deg", 0.0, 180.0,
                                                          low_open=True, unit="deg"))


def noise_of(data: MeasurementSet, options: Mapping[str, Any]) -> tuple[float, float]:
    """The set's position noise [m] and orientation noise [rad], 1 sigma per axis.

    The caller's (``noise_mm`` in the options, ``noise_deg``), else the file's
    (``# noise_mm``, ``# noise_deg``), else the defaults.

    Args:
        data: The pose set.
        options: The caller's sensor options (``noise_mm`` [mm], ``noise_deg`` [deg]).

    Raises:
        DataError: a ``# noise_deg`` that is not a positive number, naming the file.
    """
    noise_m = options.get("noise_mm")
    noise_m = float(noise_m) * 1e-3 if noise_m is not None else (data.noise or DEFAULT_NOISE_MM * 1e-3)
    given = options.get("noise_deg")
    if given is None and "noise_deg" in data.notes:
        text = data.notes["noise_deg"]
        try:
            given = float(text)
        except ValueError:
            given = float("nan")
        if not (np.isfinite(given) and 0 < given < 180):
            raise DataError(data.source, f"'{text[:40]}' is not a positive angle in degrees", None, "noise_deg")
    deg = float(given) if given is not None else DEFAULT_NOISE_DEG
    return noise_m, float(np.deg2rad(deg))


def noise_origins(data: MeasurementSet, options: Mapping[str, Any]) -> tuple[str, str]:
    """Where :func:`noise_of`'s two noises come from: ``caller``, ``file`` or ``default``.

    ``default`` is not stated: each such part's sigma is estimated from the residual when
    the set is calibrated (:mod:`calib_pin.calibration.noise`).
    """
    position = "caller" if options.get("noise_mm") is not None else "file" if data.noise else "default"
    orientation = "caller" if options.get("noise_deg") is not None else "file" if "noise_deg" in data.notes \
        else "default"
    return position, orientation


def _xyzw(s: Suspect) -> Iterator[Reading]:
    """The quaternion columns read in x, y, z, w order (qw the last)."""
    values = np.array(s.data.values, dtype=float)
    values[:, 3:7] = values[:, [6, 3, 4, 5]]
    yield Reading("x, y, z, w order", "qw, qx, qy, qz", None, "read in w, x, y, z order", "with qw the last column",
                  "write the quaternion w, x, y, z (the last column first)", data=replace(s.data, values=values))


#: A 6-D pose set's quaternions written x, y, z, w (as ROS, Eigen's coeffs(), scipy write them).
QUATERNION_XYZW = Misreading("quaternions in x, y, z, w order", _xyzw)


@dataclass
class PoseProblem(SetProblem):
    """A calibration problem of 6-D pose rows: 6 residual entries a row.

    The entries are the position error [m] and the weighted orientation error (see the
    module docstring), from ``readings`` of 7 numbers a row (position [m], quaternion).
    """

    @property
    def n_values(self) -> int:
        return 6 * self.n_rows

    def residual(self, x: np.ndarray | None) -> np.ndarray:
        """Weighted pose errors, flattened, shape (6 n_rows,), [m]."""
        return self.model.residual(x, self.q, self.readings).reshape(-1)

    def predict_with_jacobian(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The residual plus the measured values' own part, and the Jacobian.

        Shapes (6 n_rows,) and (6 n_rows, n_params); residual = values - readings holds
        entrywise for the position; the orientation entries are the errors themselves.
        """
        r, jac = self.model.residual_with_jacobian(x, self.q, self.readings)
        return r.reshape(-1), jac.reshape(self.n_values, -1)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        return self.model.residual_with_jacobian(x, self.q, self.readings)[1].reshape(self.n_values, -1)

    def row_residual_with_jacobian(self, x: np.ndarray, row: int) -> tuple[np.ndarray, np.ndarray]:
        """Row ``row``'s weighted residual (6,) [m] and Jacobian (6, n_params)."""
        rows = slice(row, row + 1)
        r, jac = self.model.residual_with_jacobian(x, self.q[rows], self.readings[rows])
        return r.reshape(-1), jac.reshape(6, -1)

    def subset(self, rows: np.ndarray | slice) -> PoseProblem:
        """The same problem restricted to some rows (row indices)."""
        return replace(self, q=self.q[rows], readings=self.readings[rows])

    def part_errors(self, x: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Each row's position error [mm] and orientation error [deg], shapes (n_rows,)."""
        return self.model.part_errors(x, self.q, self.readings)

    def part_summary(self, x: np.ndarray, splits: Mapping[str, np.ndarray]) -> str:
        """One line for people: each split's RMS position error [mm] and orientation error [deg].

        Nominal -> at x; ``splits``: name -> rows, empty ones left out.
        """
        cells = []
        for name, rows in splits.items():
            if len(rows):
                part = self.subset(np.asarray(rows, dtype=int))
                (mm0, deg0), (mm1, deg1) = (part.part_errors(v) for v in (None, x))
                rms = [float(np.sqrt(np.mean(e**2))) for e in (mm0, mm1, deg0, deg1)]
                cells.append(f"{name} position {rms[0]:.4g} -> {rms[1]:.4g} mm, orientation {rms[2]:.4g} -> "
                             f"{rms[3]:.4g} deg")
        return "per part (RMS, nominal -> calibrated): " + "; ".join(cells)


class PoseModel(MeasurementModel):
    """Device-frame poses of a body on a chain whose deviations follow a parameter model."""

    schema: ClassVar[Schema] = SCHEMAS["pose"]
    #: Residual entries a row holds: position error [m], weighted orientation error.
    values_per_row = 6
    geometry_type = PoseRig
    error_name = "pose error (position mm, orientation scaled by noise_mm/noise_deg)"
    setup_type = PoseSetup
    fits_setup = True
    fitted_setup = "device frame and body"
    misreadings = (*MeasurementModel.misreadings, QUATERNION_XYZW)

    def __init__(self, chain: Chain, params: ParameterModel, rig: PoseRig, noise_m: float = DEFAULT_NOISE_MM * 1e-3,
                 noise_rad: float = float(np.deg2rad(DEFAULT_NOISE_DEG)),
                 compliance: ComplianceSpec | None = None, estimate: Any = POSE_EXTRAS) -> None:
        if not isinstance(rig, PoseRig):
            raise ArgumentError("rig", f"expected a PoseRig (device T_DB, body T_EK), got {type(rig).__name__}")
        if not (noise_m > 0 and noise_rad > 0):
            raise ArgumentError("noise", f"position and orientation noise must be positive, got {noise_m} m, "
                                f"{noise_rad} rad")
        self.estimate = chosen(estimate, POSE_EXTRAS, "a 6-D pose device")
        extra = []
        if "device" in self.estimate:
            extra += frame_unknowns("device", 2e-3, 2e-3)
        if "body" in self.estimate:
            extra += frame_unknowns("body", 1e-3, 2e-3)
        #: Which of the 12 corrections (device translation, rotation, body translation, rotation) x holds.
        self._parts = np.array([6 * k + i for k, name in enumerate(POSE_EXTRAS) if name in self.estimate
                                for i in range(6)], dtype=int)
        super().__init__(chain, params, extra, compliance)
        self.rig = rig
        self.noise_m, self.noise_rad = float(noise_m), float(noise_rad)
        #: Metres of residual per radian of orientation error.
        self.weight = self.noise_m / self.noise_rad
        #: Where the position and the orientation noise came from (:func:`noise_origins`).
        self.noise_from: tuple[str, str] = ("caller", "caller")

    # --- set-up -------------------------------------------------------------------------

    @classmethod
    def setup_of(cls, data: MeasurementSet) -> PoseSetup | None:
        text = data.notes.get("noise_deg")
        try:
            return PoseSetup(noise_deg=float(text)) if text is not None else None
        except (ValueError, CalibPinError):
            return None  # refused, naming the file, when the set is calibrated (noise_of)

    @classmethod
    def problem_for(cls, chain: Chain, params: ParameterModel, data: MeasurementSet,
                    fit_rows: np.ndarray, options: Mapping[str, Any]) -> PoseProblem:
        """The device frame and body start from their best fit with the nominal robot on ``fit_rows`` only.

        See :func:`fit_rig`.
        """
        cls.refuse_foreign(options, data)
        if options.get("estimate"):
            raise ArgumentError("setup", f"estimate {','.join(options['estimate'])} is for drawstring data; with 6-D "
                                f"poses ({data.source}) the device frame and the body are always estimated")
        noise_m, noise_rad = noise_of(data, options)
        fit_rows = np.asarray(fit_rows, dtype=int)
        rig = fit_rig(chain, params, data.q[fit_rows], data.values[fit_rows], noise_m / noise_rad, data.source,
                      fit_rows_name(options))
        model = cls(chain, params, rig, noise_m, noise_rad, options.get("compliance"))
        model.noise_from = noise_origins(data, options)
        return PoseProblem(model, data.q, np.asarray(data.values, dtype=float))

    # --- geometry -------------------------------------------------------------------------

    def _corrections(self, x: np.ndarray | None) -> np.ndarray:
        """All 12 corrections (zero for a part not estimated)."""
        e = np.zeros(12)
        if x is not None:
            e[self._parts] = self.sensor_part(x)
        return e

    def geometry_at(self, x: np.ndarray | None) -> PoseRig:
        """The device frame and body x implies."""
        if x is None or not self.estimate:
            return self.rig
        e = self._corrections(x)
        device = pin.SE3(self.rig.device.rotation @ pin.exp3(e[3:6]), self.rig.device.translation + e[:3])
        body = pin.SE3(self.rig.body.rotation @ pin.exp3(e[9:12]), self.rig.body.translation + e[6:9])
        return PoseRig(device, body)

    def geometry_report(self, x: np.ndarray | None) -> dict:
        return self.geometry_at(x).to_dict()

    def describe(self) -> str:
        return (f"6-D poses of a body, device frame and body estimated (noise {self.noise_m * 1e3:.4g} mm, "
                f"{np.rad2deg(self.noise_rad):.4g} deg)")

    # --- noise and errors by part ---------------------------------------------------------

    def noise_parts(self) -> tuple[NoisePart, ...]:
        """The position (mm) and the orientation (deg), each with its own noise."""
        return (NoisePart("position", "mm", 1e3, self.noise_m, self.noise_from[0]),
                NoisePart("orientation", "deg", float(np.rad2deg(1.0)), self.noise_rad, self.noise_from[1]))

    def part_residuals(self, x: np.ndarray | None, q: np.ndarray, readings: np.ndarray,
                       points: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """The position errors [m] and the orientation errors' rotation vectors [rad].

        Each flattened, shape (3 n_rows,).
        """
        e = self.errors(x, q, readings)
        return e[:, :3].reshape(-1), e[:, 3:].reshape(-1)

    def part_entries(self, n_rows: int) -> tuple[np.ndarray, ...]:
        """The position's and the orientation's entries of the (n_rows, 6) residual, flattened."""
        entries = np.arange(6 * n_rows).reshape(n_rows, 6)
        return entries[:, :3].reshape(-1), entries[:, 3:].reshape(-1)

    def with_part_noise(self, sigmas: tuple[float, ...], origin: str) -> PoseModel:
        """A copy weighted by position noise ``sigmas[0]`` [m] and orientation noise ``sigmas[1]`` [rad].

        The parts whose noise was stated keep their origin.
        """
        noise_m, noise_rad = (float(s) for s in sigmas)
        if not (noise_m > 0 and noise_rad > 0):
            raise ArgumentError("noise", f"position and orientation noise must be positive, got {noise_m} m, "
                                f"{noise_rad} rad")
        out = copy.copy(self)
        out.noise_m, out.noise_rad, out.weight = noise_m, noise_rad, noise_m / noise_rad
        out.noise_from = tuple(o if o != "default" else origin for o in self.noise_from)  # type: ignore[assignment]
        return out

    def errors_by_part(self, x: np.ndarray | None, q: np.ndarray, readings: np.ndarray) -> dict[str, np.ndarray]:
        """Each row's position error [mm] and orientation error angle [deg] (:meth:`part_errors`)."""
        mm, deg = self.part_errors(x, q, readings)
        return {"position_mm": mm, "orientation_deg": deg}

    @property
    def reference_point(self) -> np.ndarray:
        return np.asarray(self.rig.body.translation, dtype=float)

    def measured_points(self, x: np.ndarray | None) -> tuple[tuple[str, np.ndarray], ...]:
        return (("measured body", np.asarray(self.geometry_at(x).body.translation, dtype=float)),)

    # --- predictions ----------------------------------------------------------------------

    def _poses(self, x: np.ndarray | None, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, PoseRig]:
        """Predicted device-frame positions (n, 3) [m] and rotations (n, 3, 3)."""
        rig = self.geometry_at(x)
        rot_be, p_be = self.end_frames(x, q)
        p_bk = p_be + rot_be @ rig.body.translation
        rot_dk = rig.device.rotation @ rot_be @ rig.body.rotation
        return p_bk @ rig.device.rotation.T + rig.device.translation, rot_dk, rig

    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Predicted poses, shape (n_rows, 7): position [m] and quaternion (w, x, y, z; w >= 0)."""
        position, rot, _ = self._poses(x, q)
        return np.column_stack([position, matrix_quaternions(rot)])

    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray,
                              points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Predicted poses (n_rows, 7) and the derivative of the position and weighted rotation.

        The derivative of the pose's position [m] and of its weighted local rotation vector
        [m] (the residual's rows), shape (n_rows, 6, n_params): the identification Jacobian
        a planner scores.
        """
        predicted = self.predict(x, q)
        return predicted, self.residual_with_jacobian(x, q, predicted)[1]

    def errors(self, x: np.ndarray | None, q: np.ndarray, readings: np.ndarray) -> np.ndarray:
        """Unweighted pose errors, shape (n_rows, 6): position [m], rotation vector [rad].

        The rotation vector is log3(R_meas^T R_pred).
        """
        position, rot, _ = self._poses(x, q)
        readings = np.asarray(readings, dtype=float).reshape(len(q), 7)
        measured = quaternion_matrices(readings[:, 3:])
        out = np.empty((len(q), 6))
        out[:, :3] = position - readings[:, :3]
        for k in range(len(q)):
            out[k, 3:] = pin.log3(measured[k].T @ rot[k])
        return out

    def residual(self, x: np.ndarray | None, q: np.ndarray, readings: np.ndarray) -> np.ndarray:
        """Weighted pose errors, shape (n_rows, 6), [m] (orientation times :attr:`weight`)."""
        out = self.errors(x, q, readings)
        out[:, 3:] *= self.weight
        return out

    def part_errors(self, x: np.ndarray | None, q: np.ndarray, readings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each row's position error [mm] and orientation error angle [deg]."""
        e = self.errors(x, q, readings)
        return np.linalg.norm(e[:, :3], axis=1) * 1e3, np.rad2deg(np.linalg.norm(e[:, 3:], axis=1))

    def residual_with_jacobian(self, x: np.ndarray | None, q: np.ndarray,
                               readings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`residual` and its derivative with respect to x, shape (n_rows, 6, n_params)."""
        x = np.zeros(self.n_params) if x is None else np.asarray(x, dtype=float)
        rig = self.geometry_at(x)
        n = len(q)
        t_ek = np.asarray(rig.body.translation, dtype=float)
        # The body's point and the three points one metre along the end frame's axes from
        # it, in one pass: their Jacobians' differences are the end frame's rotation's.
        points = np.concatenate([np.tile(t_ek, (n, 1))] + [np.tile(t_ek + e, (n, 1)) for e in np.eye(3)])
        base, end_rot, d_points = self.points_with_jacobians(x, np.tile(q, (4, 1)), points)
        p_bk, rot_be, d_p = base[:n], end_rot[:n], d_points[:n]
        # R^T d(R e_i) = w x e_i: w_x from axis y's z, w_y from axis z's x, w_z from axis x's y.
        d_axes = np.einsum("nji,knjm->knim", rot_be, d_points.reshape(4, n, 3, -1)[1:] - d_p[None])
        omega_e = np.stack([d_axes[1, :, 2], d_axes[2, :, 0], d_axes[0, :, 1]], axis=1)  # (n, 3, n_params)
        rot_db, rot_ek = rig.device.rotation, rig.body.rotation
        position = p_bk @ rot_db.T + rig.device.translation
        rot_bk = rot_be @ rot_ek
        rot = rot_db @ rot_bk
        readings = np.asarray(readings, dtype=float).reshape(n, 7)
        measured = quaternion_matrices(readings[:, 3:])
        r = np.empty((n, 6))
        r[:, :3] = position - readings[:, :3]
        jlog = np.empty((n, 3, 3))
        for k in range(n):
            err = measured[k].T @ rot[k]
            r[k, 3:] = pin.log3(err)
            jlog[k] = pin.Jlog3(err)
        r[:, 3:] *= self.weight
        jac = np.zeros((n, 6, self.n_params))
        jac[:, :3] = rot_db @ d_p  # the sensor's columns are still zero
        jac[:, 3:] = self.weight * (jlog @ (rot_ek.T @ omega_e))
        e = self._corrections(x)
        jr_device, jr_body = pin.Jexp3(e[3:6]), pin.Jexp3(e[9:12])
        sensor = np.zeros((n, 6, 12))  # every correction's columns; x holds the estimated ones
        sensor[:, :3, 0:3] = np.eye(3)
        sensor[:, :3, 3:6] = rot_db @ cross_matrices(p_bk) @ jr_device
        sensor[:, 3:, 3:6] = self.weight * (jlog @ np.transpose(rot_bk, (0, 2, 1)) @ jr_device)
        sensor[:, :3, 6:9] = rot_db @ rot_be
        sensor[:, 3:, 9:12] = self.weight * (jlog @ jr_body)
        jac[:, :, self.sensor_start :] = sensor[:, :, self._parts]
        return r, jac

    def session_errors(self, x: np.ndarray | None, data: MeasurementSet,
                       correction: Callable[[np.ndarray, np.ndarray | None], np.ndarray] | None = None,
                       ) -> np.ndarray:
        """Each row's weighted pose error [m] predicting a separate session at x.

        As the calibration's rows: position error and orientation error times :attr:`weight`.

        Args:
            x: The unknowns, SI; None: nominal.
            data: The session's poses.
            correction: A learnt correction; must be None.

        Raises:
            CalibPinError: with a learnt correction (it corrects residuals, not poses).
        """
        if correction is not None:
            raise CalibPinError("a learnt correction (rbf, lm-rbf) cannot be scored on a separate 6-D pose session")
        return np.linalg.norm(self.residual(x, data.q, data.values), axis=1)

    def session_frame_shift(self, x: np.ndarray | None, data: MeasurementSet) -> float | None:
        """How far a separate session's own device frame is from the calibration's, [m].

        The RMS distance, over the session's rows, between where the calibration's frame
        and the session's best-fit frame (the rotation by SVD projection, then the
        translation, with the model at x and its body) put the body. None with fewer than
        3 rows.
        """
        if len(data) < 3:
            return None
        rig = self.geometry_at(x)
        rot_be, p_be = self.end_frames(x, data.q)
        p_bk = p_be + rot_be @ rig.body.translation
        values = np.asarray(data.values, dtype=float).reshape(len(data), 7)
        rot_dk = quaternion_matrices(values[:, 3:])
        rot = _project(np.einsum("nij,kj,nlk->il", rot_dk, rig.body.rotation, rot_be))
        trans = np.mean(values[:, :3] - p_bk @ rot.T, axis=0)
        ours = p_bk @ rig.device.rotation.T + rig.device.translation
        theirs = p_bk @ rot.T + trans
        return float(np.sqrt(np.mean(np.sum((theirs - ours) ** 2, axis=1))))

    # --- simulation -----------------------------------------------------------------------

    @classmethod
    def simulate_rows(cls, draw: Any, geometry: PoseRig | None) -> tuple[MeasurementSet, PoseRig]:
        """A simulated 6-D pose session (:meth:`MeasurementModel.simulate_rows`).

        One pose read at each drawn configuration, the position with Gaussian noise
        ``draw.noise_mm`` per axis, the orientation with ``draw.setup["noise_deg"]`` (else
        :data:`DEFAULT_NOISE_DEG`) per axis (stated as ``# noise_deg``);
        ``geometry`` None: :func:`default_rig`.
        """
        from ..measurements import MeasurementSet

        rig = geometry if geometry is not None else default_rig()
        chain, params = draw.chain, draw.params
        model = cls(chain, params, rig, estimate=())
        q = draw.poses()
        nominal = model._poses(None, q)[0]
        draw.deviations(lambda x: np.linalg.norm(model._poses(x, q)[0] - nominal, axis=1))
        true_model = cls(chain, params, rig, estimate=(), compliance=draw.compliance)
        position, rot, _ = true_model._poses(draw.x_model, q)
        position = position + draw.noise((len(q), 3))
        given = draw.setup.get("noise_deg")
        deg = (float(given) if given is not None else DEFAULT_NOISE_DEG) if draw.noise_mm > 0 else 0.0
        noise_rad = np.deg2rad(deg)
        rot = np.stack([r @ pin.exp3(t) for r, t in zip(rot, draw.rng.normal(size=(len(q), 3)) * noise_rad,
                                                         strict=True)])
        data = MeasurementSet(
            q=q, values=np.column_stack([position, matrix_quaternions(rot)]), kind=cls.kind, robot=chain.name,
            end_frame=chain.end_frame, noise=draw.noise_mm * 1e-3 or None,
            notes={**({"noise_deg": f"{deg:g}"} if draw.noise_mm > 0 else {}),
                   "source": f"calib-pin 6-D pose simulator, seed {draw.seed}, noise {draw.noise_mm:g} mm per axis, "
                             f"{deg:g} deg per axis"})
        return data, rig

    def noisy_readings(self, x: np.ndarray | None, q: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Measured poses (n_rows, 7) at x: position [m], quaternion (w >= 0).

        The true poses with Gaussian noise of :attr:`noise_m` per coordinate and
        :attr:`noise_rad` per axis of a right rotation vector (R_meas = R exp3(n)).
        """
        position, rot, _ = self._poses(x, q)
        position = position + rng.normal(size=position.shape) * self.noise_m
        turns = rng.normal(size=(len(q), 3)) * self.noise_rad
        rot = np.stack([r @ pin.exp3(t) for r, t in zip(rot, turns, strict=True)])
        return np.column_stack([position, matrix_quaternions(rot)])


def default_rig() -> PoseRig:
    """The simulator's device frame and body.

    The device frame is 2 m in front of the robot, turned 150 deg about z; the body 80 mm
    out of the flange, off axis, tilted.
    """
    return PoseRig(pin.SE3(pin.rpy.rpyToMatrix(0.02, -0.01, np.deg2rad(150.0)), np.array([2.0, 0.3, -0.4])),
                   pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.2, 0.5), np.array([0.02, -0.01, 0.08])))


#: The unknowns of :func:`fit_rig`: the device frame's and the body's 6 each.
RIG_UNKNOWNS = 12


def fit_rig(chain: Chain, params: ParameterModel, q: np.ndarray, poses: np.ndarray, weight: float,
            source: str = "", rows: str = "training rows") -> PoseRig:
    """Best-fit device frame T_DB and body T_EK for the nominal robot.

    A hand-eye fit, T_DB T_BE(q) T_EK = T_DK.

    The rotations first: alternate R_DB = proj(sum R_DK R_EK^T R_BE^T) and R_EK =
    proj(sum R_BE^T R_DB^T R_DK) (proj: the nearest rotation, by SVD) from four starts
    (R_EK = I and the half turns about x, y, z; the best kept), then both translations
    by one linear least squares, then both frames polished together with scipy's least
    squares on the weighted residual (the nominal robot's end frames stay put).

    Args:
        q: Joint angles, shape (n_rows, n_joints), [rad].
        poses: Measured poses, shape (n_rows, 7): position [m], quaternion (w, x, y, z).
        weight: Metres of residual per radian of orientation error (noise_m / noise_rad).
        source, rows: The data's name and what its rows are called, for a refusal.

    Raises:
        DataError: fewer than 12 values (2 rows), naming ``source``.
    """
    poses = np.asarray(poses, dtype=float).reshape(-1, 7)
    refuse_too_few(source, len(poses), 6 * len(poses), RIG_UNKNOWNS, "the device frame and the body", rows)
    model = PoseModel(chain, params, PoseRig(pin.SE3.Identity(), pin.SE3.Identity()), weight, 1.0)
    rot_be, p_be = model.end_frames(None, q)
    rot_dk, p_dk = quaternion_matrices(poses[:, 3:]), poses[:, :3]
    best: tuple[float, np.ndarray, np.ndarray] | None = None
    for start in (np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])):
        rot_ek = start
        for _ in range(100):
            rot_db = _project(np.einsum("nij,kj,nlk->il", rot_dk, rot_ek, rot_be))
            moved, rot_ek = rot_ek, _project(np.einsum("nji,kj,nkl->il", rot_be, rot_db, rot_dk))
            if np.max(np.abs(rot_ek - moved)) < 1e-14:
                break
        spread = float(np.sum((rot_db @ rot_be @ rot_ek - rot_dk) ** 2))
        if best is None or spread < best[0]:
            best = (spread, rot_db, rot_ek)
    assert best is not None
    _, rot_db, rot_ek = best
    n = len(q)
    a = np.zeros((n, 3, 6))
    a[:, :, :3] = rot_db @ rot_be
    a[:, :, 3:] = np.eye(3)
    b = p_dk - p_be @ rot_db.T
    t = np.linalg.lstsq(a.reshape(3 * n, 6), b.reshape(-1), rcond=None)[0]
    model.rig = PoseRig(pin.SE3(rot_db, t[3:]), pin.SE3(rot_ek, t[:3]))  # this function's own model
    zero = np.zeros(model.n_robot)

    def residual(e: np.ndarray) -> np.ndarray:
        return model.residual(np.concatenate([zero, e]), q, poses).reshape(-1)

    def jacobian(e: np.ndarray) -> np.ndarray:
        return model.residual_with_jacobian(np.concatenate([zero, e]), q, poses)[1][:, :, model.sensor_start:] \
            .reshape(6 * n, -1)

    from scipy.optimize import least_squares  # imported here: scipy.optimize is slow to import

    fit = least_squares(residual, np.zeros(RIG_UNKNOWNS), jac=jacobian, method="lm")
    return model.geometry_at(np.concatenate([zero, fit.x]))


def __getattr__(name: str) -> Any:
    """The old names of what moved elsewhere (the example sessions of calib_pin.simulation), with a DeprecationWarning."""
    from ..util.deprecation import moved_names

    return moved_names(__name__, {
        "simulate_poses": "calib_pin.simulation.pose", "QUATERNION_TOLERANCE": "calib_pin.measurements.schema"})(name)

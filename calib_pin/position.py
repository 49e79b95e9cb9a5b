"""Position measurements (laser tracker, CMM): the second sensor type.

A measuring device with its own frame D records the position of marker points fixed
on the end effector. Marker k sits at m_k in the end frame; at joint angles q the
device reads

    p_D = T_DB p_B(q, x, m_k),

with T_DB the (unknown) pose of the robot base in the device frame. Both T_DB and the
markers are estimated with the robot's deviations: x holds the robot's deviations,
then a right twist of T_DB (``device_x/y/z`` [m], ``device_rx/ry/rz`` [rad]), then a
correction of each marker (``marker<id>_x/y/z`` [m]), all around the starting values
:func:`fit_device` finds with the nominal robot.

Some of these directions overlap: the device frame with the first joint's deviations,
the markers with the last joint's. The estimators work on the identifiable directions
only (:mod:`calib_pin.estimators.search_space`), so the overlap is harmless, and
``--analyze`` lists it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.optimize import least_squares

from .errors import MeasurementModel
from .model import Chain
from .parameters import ParameterModel

#: What a position model can estimate with the robot's deviations.
POSITION_EXTRAS = ("device", "markers")


@dataclass(frozen=True)
class PositionDevice:
    """Geometry of a position-measuring set-up.

    Attributes:
        frame: T_DB, maps base-frame points to device-frame points (pin.SE3, [m]).
        markers: Marker points in the end frame, shape (n_markers, 3), [m].
        labels: The data's ``point_id`` of each marker, shape (n_markers,).
    """

    frame: pin.SE3
    markers: np.ndarray
    labels: tuple[int, ...]


class PositionModel(MeasurementModel):
    """Device-frame positions of markers on a chain whose deviations follow a parameter model."""

    values_per_row = 3

    def __init__(self, chain: Chain, params: ParameterModel, device: PositionDevice,
                 estimate: tuple[str, ...] = POSITION_EXTRAS) -> None:
        self.estimate = self.chosen(estimate, POSITION_EXTRAS, "a position device")
        extra = []
        if "device" in estimate:
            extra += [(f"device_{a}", "m", 2e-3) for a in "xyz"] + [(f"device_r{a}", "rad", 2e-3) for a in "xyz"]
        if "markers" in estimate:
            extra += [(f"marker{label}_{a}", "m", 1e-3) for label in device.labels for a in "xyz"]
        super().__init__(chain, params, extra)
        self.device = device

    def device_at(self, x: np.ndarray | None) -> PositionDevice:
        """The device frame and markers x implies."""
        if x is None or not self.estimate:
            return self.device
        extra = np.asarray(x, dtype=float)[self.n_robot :]
        frame, markers = self.device.frame, self.device.markers
        if "device" in self.estimate:
            frame, extra = frame * pin.exp6(extra[:6]), extra[6:]
        if "markers" in self.estimate:
            markers = markers + extra.reshape(-1, 3)
        return PositionDevice(frame, markers, self.device.labels)

    def predict(self, x: np.ndarray | None, q: np.ndarray, markers: np.ndarray) -> np.ndarray:
        """Device-frame positions, shape (n_poses, 3), [m]; markers: each row's marker index."""
        device = self.device_at(x)
        self._kin.set_perturbation(None if x is None else self.params.deltas(self.robot(x)))
        points = self._kin.points(q, device.markers[markers])[0]
        return points @ device.frame.rotation.T + device.frame.translation

    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray, markers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Device-frame positions (n_poses, 3) [m] and their derivative (n_poses, 3, n_params)."""
        device = self.device_at(x)
        points, end_rot, jac = self._points_with_jacobians(x, q, device.markers[markers])
        rot = device.frame.rotation
        jac = rot @ jac  # the sensor's columns are still zero
        col = self.n_robot
        if "device" in self.estimate:
            twist = np.asarray(x, dtype=float)[col : col + 6]
            lever = np.zeros((len(points), 3, 6))
            lever[:, :, :3] = np.eye(3)
            # T_DB = T0 exp6(twist): a right twist (v, w) of it moves the image of a
            # base point p by R_DB (v + w x p); exp6's right Jacobian maps d twist to it.
            lever[:, :, 3:] = -np.cross(points[:, :, None], np.eye(3)[None], axis=1)
            jac[:, :, col : col + 6] = rot @ (lever @ pin.Jexp6(pin.Motion(twist)))
            col += 6
        if "markers" in self.estimate:
            # Row n's position moves with its own marker's three columns by R_DB R_end.
            cols = col + 3 * np.asarray(markers)[:, None] + np.arange(3)
            jac[np.arange(len(points))[:, None, None], np.arange(3)[None, :, None], cols[:, None, :]] = rot @ end_rot
        return points @ rot.T + device.frame.translation, jac


def _kabsch(source: np.ndarray, target: np.ndarray) -> pin.SE3:
    """Rigid transform T minimising sum |T source - target|^2 (shapes (n, 3))."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    u, _, vt = np.linalg.svd((source - cs).T @ (target - ct))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return pin.SE3(rot, ct - rot @ cs)


def fit_device(chain: Chain, params: ParameterModel, q: np.ndarray, positions: np.ndarray,
               markers: np.ndarray, labels: tuple[int, ...]) -> PositionDevice:
    """Best-fit device frame and marker points for the nominal robot.

    Alternates a rigid (Kabsch) fit of the frame with a linear fit of the markers, then
    polishes both together with scipy's least squares.

    Args:
        q: Joint angles, shape (n_poses, n_joints), [rad].
        positions: Measured positions, shape (n_poses, 3), [m], device frame.
        markers: Each row's marker index into ``labels``, shape (n_poses,).
    """
    n_markers = len(labels)
    model = PositionModel(chain, params, PositionDevice(pin.SE3.Identity(), np.zeros((n_markers, 3)), labels))
    origin, end_rot, _ = model._points_with_jacobians(np.zeros(model.n_params), q, np.zeros(3))
    points = np.zeros((n_markers, 3))
    for _ in range(30):
        base = origin + np.einsum("nij,nj->ni", end_rot, points[markers])
        frame = _kabsch(base, positions)
        in_base = (positions - frame.translation) @ frame.rotation
        local = np.einsum("nji,nj->ni", end_rot, in_base - origin)
        points = np.array([local[markers == k].mean(axis=0) for k in range(n_markers)])
    device = PositionDevice(frame, points, labels)
    model = PositionModel(chain, params, device)
    zero = np.zeros(model.n_robot)

    def residual(e: np.ndarray) -> np.ndarray:
        return (model.predict(np.concatenate([zero, e]), q, markers) - positions).reshape(-1)

    def jacobian(e: np.ndarray) -> np.ndarray:
        jac = model.predict_with_jacobian(np.concatenate([zero, e]), q, markers)[1]
        return jac[:, :, model.n_robot :].reshape(3 * len(q), -1)

    fit = least_squares(residual, np.zeros(model.n_params - model.n_robot), jac=jacobian, method="lm")
    return model.device_at(np.concatenate([zero, fit.x]))

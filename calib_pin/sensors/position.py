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
only (:mod:`calib_pin.estimators.subspace`), so the overlap is harmless, and ``--analyze`` lists it.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements.dataset import PointLabel, point_label
from ..measurements.schema import SCHEMAS, Schema
from ..robot.chain import Chain
from ..robot.deflection import ComplianceSpec
from ..robot.kinematics import cross_matrices
from .base import FIT_ROWS_KEY, MeasurementModel, chosen, fit_rows_name, frame_unknowns, refuse_too_few
from .problem import SetProblem
from .setup import SensorSetup

if TYPE_CHECKING:
    from ..measurements import MeasurementSet
    from ..parameters import ParameterModel

#: A whole-number label, as text.
_WHOLE = re.compile(r"^[-+]?\d{1,15}$")
#: What a position model can estimate with the robot's deviations.
POSITION_EXTRAS = ("device", "markers")

#: Default marker points of simulated position sets, end frame, [mm].
DEFAULT_MARKERS_MM = ((60.0, 0.0, 40.0), (-30.0, 52.0, 40.0), (-30.0, -52.0, 40.0))
#: Spread of the device placements drawn for simulated sessions 2..: a turn about the
#: vertical [deg] and a shift per axis [mm] (a tracker moved to another station).
SESSION_DEVICE_TURN_DEG = 60.0
SESSION_DEVICE_SHIFT_MM = (400.0, 400.0, 100.0)


def default_device_frame() -> pin.SE3:
    """The simulator's default device frame T_DB: 2 m in front of the robot, turned 150 deg about z."""
    return pin.SE3(pin.rpy.rpyToMatrix(0.02, -0.01, np.deg2rad(150.0)), np.array([2.0, 0.3, -0.4]))


@dataclass(frozen=True)
class PositionDevice:
    """Geometry of a position-measuring set-up.

    Attributes:
        frame: T_DB, maps base-frame points to device-frame points (pin.SE3, [m]).
        markers: Marker points in the end frame, shape (n_markers, 3), [m].
        labels: The data's ``point_id`` of each marker, shape (n_markers,): whole numbers
            (``int``) or text labels (``str``, as the file wrote them).
    """

    frame: pin.SE3
    markers: np.ndarray
    labels: tuple[PointLabel, ...]

    def index_of(self, labels: Any, source: str = "", field: str | None = "point_id") -> np.ndarray:
        """Marker indices of labels, shape (n,).

        Args:
            labels: A file's ``point_id`` values, or a caller's: numbers or text; ``2`` and
                ``"2"`` name the same marker.
            source: The file, for messages.
            field: The column named in messages.

        Raises:
            DataError: a label that is not one of :attr:`labels` (the markers are named).
            CalibPinError: a value that is no label.
        """
        known = {label: k for k, label in enumerate(self.labels)}
        index = np.empty(len(labels), dtype=int)
        for r, value in enumerate(labels):
            label = point_label(value)
            other = _other_form(label)
            k = known.get(label, -1 if other is None else known.get(other, -1))
            if k < 0:
                raise DataError(source, f"point_id {label} is not a marker of this calibration "
                                f"(markers: {', '.join(map(str, self.labels))})", None, field)
            index[r] = k
        return index

    def to_dict(self) -> dict:
        """In mm and degrees."""
        return {
            "device_frame": {
                "translation_mm": (self.frame.translation * 1e3).tolist(),
                "rpy_deg": np.rad2deg(pin.rpy.matrixToRpy(self.frame.rotation)).tolist(),
                "meaning": "p_device = R p_base + t",
            },
            "markers_mm": {str(label): (m * 1e3).tolist() for label, m in zip(self.labels, self.markers, strict=True)},
        }

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> PositionDevice:
        """Inverse of :meth:`to_dict`."""
        frame = doc["device_frame"]
        rot = pin.rpy.rpyToMatrix(*np.deg2rad(np.asarray(frame["rpy_deg"], dtype=float)))
        keys = list(doc["markers_mm"])
        labels: tuple[PointLabel, ...] = tuple(int(k) for k in keys) if all(_WHOLE.match(k) for k in keys) else tuple(keys)
        markers = np.array([doc["markers_mm"][k] for k in keys], dtype=float).reshape(-1, 3) * 1e-3
        return cls(pin.SE3(rot, np.asarray(frame["translation_mm"], dtype=float) * 1e-3), markers, labels)


@dataclass(frozen=True, eq=False)
class PositionSetup(SensorSetup):
    """A position device's set-up options: none to give.

    The device frame and the marker points start from their best fit on the training
    rows and are always estimated, so ``estimate`` must stay empty (it is refused, naming
    the data).
    """

    title: ClassVar[str] = "position device"

    estimate: Any = ()

    def __post_init__(self) -> None:
        from ..util.arguments import as_names

        object.__setattr__(self, "estimate", as_names(self.estimate, "estimate"))


class PositionModel(MeasurementModel):
    """Device-frame positions of markers on a chain whose deviations follow a parameter model."""

    schema: ClassVar[Schema] = SCHEMAS["position"]
    values_per_row = 3
    geometry_type = PositionDevice
    error_name = "Euclidean position error in the device frame"
    setup_type = PositionSetup
    fits_setup = True
    fitted_setup = "device frame"

    def __init__(self, chain: Chain, params: ParameterModel, device: PositionDevice,
                 estimate: tuple[str, ...] = POSITION_EXTRAS, compliance: ComplianceSpec | None = None) -> None:
        if not isinstance(device, PositionDevice):
            raise ArgumentError("device", f"expected a PositionDevice (frame T_DB, marker points [m]), got "
                                f"{type(device).__name__}")
        self.estimate = chosen(estimate, POSITION_EXTRAS, "a position device")
        extra = []
        if "device" in self.estimate:
            extra += frame_unknowns("device", 2e-3, 2e-3)
        if "markers" in self.estimate:
            extra += [(f"marker{label}_{a}", "m", 1e-3) for label in device.labels for a in "xyz"]
        super().__init__(chain, params, extra, compliance)
        self.device = device

    @classmethod
    def problem_for(cls, chain: Chain, params: ParameterModel, data: MeasurementSet,
                    fit_rows: np.ndarray, options: Mapping[str, Any]) -> SetProblem:
        """The device frame and markers start from their best fit with the nominal robot on ``fit_rows`` only.

        Every marker must appear there.
        """
        cls.refuse_foreign(options, data)
        if options.get("estimate"):
            raise ArgumentError(
                "setup", f"estimate {','.join(options['estimate'])} is for drawstring data; with positions "
                f"({data.source}) the device frame and the marker points are always estimated")
        assert data.point_ids is not None
        labels, points = marker_labels(data.point_ids, data.source or "the measurement set")
        fit_rows = np.asarray(fit_rows, dtype=int)
        seen = set(points[fit_rows].tolist())
        missing = [label for k, label in enumerate(labels) if k not in seen]
        rows = fit_rows_name(options)
        if missing:
            raise DataError(data.source, f"point_id {missing[0]} is in none of the {rows}: nothing locates it", None,
                            "point_id")
        device = fit_device(chain, params, data.q[fit_rows], data.values[fit_rows], points[fit_rows], labels,
                            data.source, rows)
        model = cls(chain, params, device, compliance=options.get("compliance"))
        return SetProblem(model, data.q, data.values, points)

    @classmethod
    def simulate_rows(cls, draw: Any, geometry: PositionDevice | None) -> tuple[MeasurementSet, PositionDevice]:
        """A simulated position session (:meth:`MeasurementModel.simulate_rows`).

        Every marker measured at each pose (rows pose-major, markers labelled 1..k), each
        coordinate with Gaussian noise ``draw.noise_mm``; ``geometry`` None: the default
        device frame and markers.
        """
        from ..measurements import MeasurementSet

        device = geometry if geometry is not None else PositionDevice(
            default_device_frame(), np.asarray(DEFAULT_MARKERS_MM) * 1e-3, (1, 2, 3))
        chain, params, n_markers = draw.chain, draw.params, len(device.markers)
        model = cls(chain, params, device, estimate=())
        poses = draw.poses()
        q = np.repeat(poses, n_markers, axis=0)
        index = np.tile(np.arange(n_markers), len(poses))
        nominal = model.predict(None, q, index)
        draw.deviations(lambda x: np.linalg.norm(model.predict(x, q, index) - nominal, axis=1))
        true_model = cls(chain, params, device, estimate=(), compliance=draw.compliance)
        positions = true_model.predict(draw.x_model, q, index) + draw.noise((len(q), 3))
        data = MeasurementSet(
            q=q, values=positions, kind=cls.kind, robot=chain.name, end_frame=chain.end_frame,
            notes={"source": f"calib-pin position simulator, seed {draw.seed}, noise {draw.noise_mm:g} mm per axis"},
            pose_ids=np.repeat(np.arange(1, len(poses) + 1), n_markers),
            point_ids=np.array(device.labels)[index],
            noise=draw.noise_mm * 1e-3 or None,  # noise-free: no sensor sigma to state
        )
        return data, device

    @classmethod
    def session_geometry(cls, first: PositionDevice, rng: np.random.Generator) -> PositionDevice:
        """A later session's device, moved from session 1's; the same markers (the one tool's).

        Turned about the vertical within :data:`SESSION_DEVICE_TURN_DEG` and shifted within
        :data:`SESSION_DEVICE_SHIFT_MM`.
        """
        move = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, np.deg2rad(rng.uniform(-1, 1) * SESSION_DEVICE_TURN_DEG)),
                       rng.uniform(-1, 1, 3) * np.asarray(SESSION_DEVICE_SHIFT_MM) * 1e-3)
        return PositionDevice(move * first.frame, first.markers, first.labels)

    @classmethod
    def planning_model(cls, chain: Chain, params: ParameterModel, setup: Any) -> PositionModel:
        """A device with the simulator's markers and frame, its frame and markers estimated.

        The markers are :data:`DEFAULT_MARKERS_MM`, labelled 1..3; a rigid move of the
        device changes no design: the information is the same in any frame.
        """
        if setup is not None and setup.given():
            raise CalibPinError(f"a position device takes no set-up options to plan for (got {', '.join(setup.given())})")
        device = PositionDevice(default_device_frame(), np.array(DEFAULT_MARKERS_MM) * 1e-3,
                                tuple(range(1, len(DEFAULT_MARKERS_MM) + 1)))
        return cls(chain, params, device)

    @classmethod
    def registration_problem(cls, chain: Chain, params: ParameterModel, session: MeasurementSet, rows: np.ndarray,
                             calibrated: MeasurementModel, x: np.ndarray,
                             options: Mapping[str, Any]) -> SetProblem:
        """The problem of a moved device: its frame estimated.

        The markers ride on the tool, not on the device: when the calibration knows every
        marker of the session they are its own (as calibrated) and stay fixed, and the frame
        starts from their rigid (Kabsch) fit on ``rows``; else (new markers) frame and
        markers are estimated, as :meth:`problem_for` does.

        Args:
            chain, params: The robot chain and its parameter model.
            session: The validation session's measurements.
            rows: Its registration rows (0-based).
            calibrated, x: The calibration's model and estimate (SI).
            options: The caller's sensor options.

        Raises:
            DataError: fewer values on ``rows`` than the unknowns to fit.
        """
        assert isinstance(calibrated, PositionModel) and session.point_ids is not None
        source = session.source or "test_data"
        known = calibrated.geometry_at(x)
        labels, points = marker_labels(session.point_ids, source)
        try:
            index = known.index_of(list(labels))
        except DataError:
            index = None
        n_unknowns = 6 if index is not None else 6 + 3 * len(labels)
        if 3 * len(rows) < n_unknowns:
            raise DataError(source, f"{len(rows)} registration rows give {3 * len(rows)} values, fewer than the "
                            f"{n_unknowns} set-up unknowns (the device frame{'' if index is not None else ' and markers'})"
                            ": register on more poses", None, "register")
        if index is None:
            return cls.problem_for(chain, params, session, rows, {"compliance": options.get("compliance"),
                                                                  FIT_ROWS_KEY: options.get(FIT_ROWS_KEY)})
        markers = known.markers[index]
        base = calibrated.points_at(x, session.q[rows], markers[points[rows]])
        device = PositionDevice(_kabsch(base, session.values[rows]), markers, labels)
        model = cls(chain, params, device, ("device",), options.get("compliance"))
        return SetProblem(model, session.q, session.values, points)

    def point_index(self, labels: Any, n_rows: int, source: str = "") -> np.ndarray:
        """Marker indices of ``n_rows`` rows labelled ``labels``.

        Args:
            labels: The file's ``point_id`` values, numbers or text; None: every row
                measures the one marker.
            n_rows: The number of rows.
            source: The file, for messages.

        Raises:
            ArgumentError: no labels with several markers (naming ``point_ids``).
            DataError: a label this calibration has no marker for.
        """
        if labels is None:
            if len(self.device.labels) == 1:
                return np.zeros(n_rows, dtype=int)
            raise ArgumentError("point_ids", f"this calibration has {len(self.device.labels)} markers "
                                f"({', '.join(map(str, self.device.labels))}): give each pose's marker label")
        return self.device.index_of(labels, source or "point_ids", "point_id" if source else None)

    def session_errors(self, x: np.ndarray | None, data: MeasurementSet,
                       correction: Callable[[np.ndarray, np.ndarray | None], np.ndarray] | None = None,
                       ) -> np.ndarray:
        """Position errors [m] of a separate session, with an optional learnt correction.

        A marker this calibration never saw is located from its first row (that row's
        configuration and measured position give the point in the end frame through the
        model at x and its device frame); its other rows are scored, that first row is not.

        Args:
            x: The unknowns, SI; None: nominal.
            data: The session's positions.
            correction: A learnt ``correction(q, points)`` of the positions, or None.

        Raises:
            CalibPinError: a new marker with a correction (it knows the calibration's markers only).
        """
        assert data.point_ids is not None
        device = self.geometry_at(x)
        errors = []
        known = set(device.labels)
        session_labels, session_points = marker_labels(data.point_ids, data.source or "the measurement set")
        for k, label in enumerate(session_labels):
            rows = np.flatnonzero(session_points == k)
            if label in known or _other_form(label) in known:
                index = int(device.index_of([label])[0])
                point = device.markers[index]
            elif correction is not None:
                raise CalibPinError(f"{data.source}: point_id {label} is not a marker of this calibration, "
                                    "and its learnt correction knows only those "
                                    f"({', '.join(map(str, device.labels))})")
            else:
                point = self.locate(x, data.q[rows[0]], data.values[rows[0]])
                rows = rows[1:]
            base = self.points_at(x, data.q[rows], point)
            predicted = base @ device.frame.rotation.T + device.frame.translation
            if correction is not None:
                predicted = predicted + correction(data.q[rows], np.full(len(rows), index)).reshape(predicted.shape)
            errors.append(np.linalg.norm(predicted - data.values[rows], axis=1))
        return np.concatenate(errors) if errors else np.zeros(0)

    def session_frame_shift(self, x: np.ndarray | None, data: MeasurementSet) -> float | None:
        """How far a separate session's own device frame is from the calibration's, [m].

        The RMS distance, over the session's rows of known markers, between where the
        calibration's frame and the session's best-fit (Kabsch) frame put the model's
        points. None with fewer than 3 such rows (nothing to fit a frame to).
        """
        assert data.point_ids is not None
        device = self.geometry_at(x)
        known = set(device.labels)
        session_labels, session_points = marker_labels(data.point_ids, data.source or "the measurement set")
        base, measured = [], []
        for k, label in enumerate(session_labels):
            if label in known or _other_form(label) in known:
                rows = np.flatnonzero(session_points == k)
                base.append(self.points_at(x, data.q[rows], device.markers[int(device.index_of([label])[0])]))
                measured.append(data.values[rows])
        if not base or sum(len(b) for b in base) < 3:
            return None
        points = np.concatenate(base)
        own = _kabsch(points, np.concatenate(measured))
        ours = points @ device.frame.rotation.T + device.frame.translation
        theirs = points @ own.rotation.T + own.translation
        return float(np.sqrt(np.mean(np.sum((theirs - ours) ** 2, axis=1))))

    def locate(self, x: np.ndarray | None, q: np.ndarray, position: np.ndarray) -> np.ndarray:
        """The end-frame point [m] the model at x puts at device-frame ``position`` [m] at q.

        q: the joint angles of one row.
        """
        device = self.geometry_at(x)
        base = device.frame.actInv(np.asarray(position, dtype=float))
        q = self.joint_angles(x, np.atleast_2d(q))
        self.set_robot(x)
        origin = self._kin.points(q, np.zeros(3))[0][0]
        # Row i: the end frame's axis i in the base frame, so this matrix is R^T.
        axes = self._kin.points(np.repeat(q, 3, axis=0), np.eye(3))[0] - origin
        return axes @ (base - origin)

    @property
    def reference_point(self) -> np.ndarray:
        return self.device.markers.mean(axis=0)

    def measured_points(self, x: np.ndarray | None) -> tuple[tuple[str, np.ndarray], ...]:
        device = self.geometry_at(x)
        return tuple((f"marker {label}", np.asarray(m, dtype=float)) for label, m in zip(device.labels, device.markers,
                                                                                          strict=True))

    def grid_points(self, n_poses: int) -> tuple[np.ndarray, np.ndarray | None]:
        k = len(self.device.labels)
        return np.repeat(np.arange(n_poses), k), np.tile(np.arange(k), n_poses)

    def geometry_report(self, x: np.ndarray | None) -> dict:
        return self.geometry_at(x).to_dict()

    def describe(self) -> str:
        return "positions of markers, device frame and marker points estimated"

    def geometry_at(self, x: np.ndarray | None) -> PositionDevice:
        """The device frame and markers x implies."""
        if x is None or not self.estimate:
            return self.device
        extra = self.sensor_part(x)
        frame, markers = self.device.frame, self.device.markers
        if "device" in self.estimate:
            frame, extra = frame * pin.exp6(extra[:6]), extra[6:]
        if "markers" in self.estimate:
            markers = markers + extra.reshape(-1, 3)
        return PositionDevice(frame, markers, self.device.labels)

    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Device-frame positions, shape (n_rows, 3), [m]; points: each row's marker index."""
        device = self.geometry_at(x)
        base = self.points_at(x, q, device.markers[_index(points, len(q))])
        return base @ device.frame.rotation.T + device.frame.translation

    def predict_many(self, xs: list[np.ndarray], q: np.ndarray, points: np.ndarray | None = None) -> list[np.ndarray]:
        """:meth:`predict` at several x, the robot's positions in one batched pass."""
        return list(self.predict_stacked(xs, q, points))

    def predict_stacked(self, xs: list[np.ndarray] | np.ndarray, q: np.ndarray,
                        points: np.ndarray | None = None) -> np.ndarray:
        """:meth:`predict_many` as one array, shape (k, n_rows, 3), [m].

        What a batched residual subtracts the readings from; xs a list of k points or an
        array (k, n_params).
        """
        markers = _index(points, len(q))
        if not len(xs):
            return np.empty((0, len(q), 3))
        stacked = None if any(x is None for x in xs) else np.asarray(xs, dtype=float)  # (k, n_params): one copy
        rotations_t, translations, rows = self._geometries_many(xs if stacked is None else stacked, markers)
        base = self.points_at_many(xs if stacked is None else stacked, q, rows)
        if base is None:
            return np.asarray(super().predict_many(list(xs), q, points))
        # Every point's device frame in one stacked product (each slice the product predict makes).
        device = base @ rotations_t
        device += translations[:, None, :]
        return device

    def _geometries_many(self, xs: list[np.ndarray] | np.ndarray,
                         markers: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any]:
        """:meth:`geometry_at` at each of xs (a list, or an array (k, n_params)), as arrays.

        The device frames' transposed rotations (k, 3, 3) and translations (k, 3) [m] and
        each point's rows' markers (k, n_rows, 3) stacked (or a list of (n_rows, 3)): the
        same exp6 and sums, without a :class:`PositionDevice` per point.
        """
        k = len(xs)
        if not self.estimate or not isinstance(xs, np.ndarray) and any(x is None for x in xs):
            devices = [self.geometry_at(x) for x in xs]
            frames, rows = [d.frame for d in devices], [d.markers[markers] for d in devices]
        else:
            extra = np.asarray(xs, dtype=float)[:, self.sensor_start :]
            frame = self.device.frame
            if "device" in self.estimate:
                frames, extra = [frame * pin.exp6(e) for e in extra[:, :6]], extra[:, 6:]
            else:
                frames = [frame] * k
            if "markers" in self.estimate:
                rows = (self.device.markers + extra.reshape(k, -1, 3))[:, markers]
            else:
                rows = [self.device.markers[markers]] * k
        # The frames' numbers copied out of one array of their matrices (C-ordered, as predict's product reads them).
        homogeneous = np.array([f.homogeneous for f in frames]).reshape(k, 4, 4)
        return homogeneous[:, :3, :3].transpose(0, 2, 1).copy(), homogeneous[:, :3, 3].copy(), rows

    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray,
                              points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Device-frame positions (n_rows, 3) [m] and their derivative (n_rows, 3, n_params)."""
        device = self.geometry_at(x)
        markers = _index(points, len(q))
        points, end_rot, jac = self.points_with_jacobians(x, q, device.markers[markers])
        rot = device.frame.rotation
        jac = rot @ jac  # the sensor's columns are still zero
        jac[:, :, self.sensor_start :] = self.sensor_jacobian(x, device, points, end_rot, markers)
        return points @ rot.T + device.frame.translation, jac

    def sensor_jacobian(self, x: np.ndarray, device: PositionDevice, points: np.ndarray, end_rot: np.ndarray,
                        markers: np.ndarray) -> np.ndarray:
        """Derivative of the device-frame positions by the sensor's part of x.

        The sensor's part is the device twist, then the markers; shape
        (n_rows, 3, n_params - sensor_start).

        Args:
            device: :meth:`geometry_at` x.
            points: The markers' base-frame positions, shape (n_rows, 3), [m].
            end_rot: The end frame's rotations, shape (n_rows, 3, 3), base frame.
            markers: Each row's marker index, shape (n_rows,).
        """
        rot = device.frame.rotation
        jac = np.zeros((len(points), 3, self.n_params - self.sensor_start))
        col = 0
        if "device" in self.estimate:
            twist = np.asarray(x, dtype=float)[self.sensor_start : self.sensor_start + 6]
            lever = np.empty((len(points), 3, 6))
            lever[:, :, :3] = _EYE3
            # T_DB = T0 exp6(twist): a right twist (v, w) of it moves the image of a
            # base point p by R_DB (v + w x p); exp6's right Jacobian maps d twist to it.
            lever[:, :, 3:] = cross_matrices(points)
            jac[:, :, :6] = rot @ (lever @ pin.Jexp6(twist))
            col = 6
        if "markers" in self.estimate:
            # Row n's position moves with its own marker's three columns by R_DB R_end.
            cols = col + 3 * markers[:, None] + np.arange(3)
            jac[np.arange(len(points))[:, None, None], np.arange(3)[None, :, None], cols[:, None, :]] = rot @ end_rot
        return jac


#: The device twist's linear columns of the lever (read only).
_EYE3 = np.eye(3)
_EYE3.setflags(write=False)


def marker_labels(point_ids: np.ndarray, source: str = "") -> tuple[tuple[PointLabel, ...], np.ndarray]:
    """The distinct marker labels of rows labelled ``point_ids`` (sorted) and each row's index into them.

    The indices have shape (n_rows,).

    Args:
        point_ids: Each row's ``point_id`` value (whole numbers or text).
        source: The file, for messages.

    Raises:
        DataError: a value that is no label, or whole numbers mixed with text labels.
    """
    values = [point_label(v) for v in np.asarray(point_ids, dtype=object).reshape(-1)]
    kinds = {type(v) for v in values}
    if len(kinds) > 1:
        number = next(v for v in values if isinstance(v, int))
        text = next(v for v in values if isinstance(v, str))
        raise DataError(source, f"mixes whole numbers ({number}) and text labels ({text}): use one kind",
                        None, "point_id")
    labels: list = sorted(set(values), key=lambda v: v)  # one kind: all int or all str
    index = {label: k for k, label in enumerate(labels)}
    return tuple(labels), np.array([index[v] for v in values], dtype=int)


def _other_form(label: PointLabel) -> PointLabel | None:
    """``"2"`` for 2 and 2 for ``"2"`` (None for text that is no whole number)."""
    if isinstance(label, int):
        return str(label)
    return int(label) if _WHOLE.match(label) else None


def _index(points: np.ndarray | None, n_rows: int) -> np.ndarray:
    """Each row's marker index; rows of a one-marker set may leave it out."""
    return np.zeros(n_rows, dtype=int) if points is None else np.asarray(points, dtype=int)


def _kabsch(source: np.ndarray, target: np.ndarray) -> pin.SE3:
    """Rigid transform T minimising sum |T source - target|^2 (shapes (n, 3))."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    u, _, vt = np.linalg.svd((source - cs).T @ (target - ct))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return pin.SE3(rot, ct - rot @ cs)


def fit_device(chain: Chain, params: ParameterModel, q: np.ndarray, positions: np.ndarray,
               markers: np.ndarray, labels: tuple[PointLabel, ...], source: str = "",
               rows: str = "training rows") -> PositionDevice:
    """Best-fit device frame and marker points for the nominal robot.

    Alternates a rigid (Kabsch) fit of the frame with a linear fit of the markers until
    the markers stop moving, then polishes both together with scipy's least squares
    (the nominal robot's points and end frames stay put: only the sensor's Jacobian
    columns change).

    Args:
        q: Joint angles, shape (n_poses, n_joints), [rad].
        positions: Measured positions, shape (n_poses, 3), [m], device frame.
        markers: Each row's marker index into ``labels``, shape (n_poses,).
        source, rows: The data's name and what its rows are called, for a refusal.

    Raises:
        DataError: fewer values than the frame's 6 and the markers' 3 unknowns each, naming ``source``.
    """
    n_markers = len(labels)
    refuse_too_few(source, len(q), 3 * len(q), 6 + 3 * n_markers, f"the device frame and {n_markers} marker(s)", rows)
    model = PositionModel(chain, params, PositionDevice(pin.SE3.Identity(), np.zeros((n_markers, 3)), labels))
    end_rot, origin = model.end_frames(None, q)
    points = np.zeros((n_markers, 3))
    for _ in range(30):  # converges linearly, to 1e-16 m in about ten iterations
        base = origin + np.einsum("nij,nj->ni", end_rot, points[markers])
        frame = _kabsch(base, positions)
        in_base = (positions - frame.translation) @ frame.rotation
        local = np.einsum("nji,nj->ni", end_rot, in_base - origin)
        moved, points = points, np.array([local[markers == k].mean(axis=0) for k in range(n_markers)])
        if np.max(np.abs(points - moved)) < 1e-13:
            break
    model.device = PositionDevice(frame, points, labels)  # this function's own model: the fit starts here
    zero = np.zeros(model.n_robot)

    def residual(e: np.ndarray) -> np.ndarray:
        return (model.predict(np.concatenate([zero, e]), q, markers) - positions).reshape(-1)

    def jacobian(e: np.ndarray) -> np.ndarray:  # the nominal robot's points and end frames stay
        x = np.concatenate([zero, e])
        device = model.geometry_at(x)
        base = origin + np.einsum("nij,nj->ni", end_rot, device.markers[markers])
        return model.sensor_jacobian(x, device, base, end_rot, markers).reshape(3 * len(q), -1)

    from scipy.optimize import least_squares  # imported here: scipy.optimize is slow to import

    fit = least_squares(residual, np.zeros(model.n_params - model.n_robot), jac=jacobian, method="lm")
    return model.geometry_at(np.concatenate([zero, fit.x]))

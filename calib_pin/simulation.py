"""Simulated sessions with known true deviations: drawstring readings or positions.

The simulator draws true kinematic deviations, random poses within the joint limits
(:func:`calib_pin.robot.poses.random_poses`),
and what the sensor would read on the true robot plus noise. The truth
(:class:`Truth`) is kept so every estimate can be checked against it.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from .arguments import (
    MAX_MM,
    as_angles_rad,
    as_array,
    as_chain,
    as_choice,
    as_float,
    as_instance,
    as_int,
    as_optional,
    as_parameter_model,
    as_xyz_mm,
)
from .atomic import write_text
from .exceptions import ArgumentError, CalibPinError, DataError
from .input_files import check_regular
from .measurements import MeasurementSet
from .parameters import ParameterModel
from .robot import Chain
from .robot.deflection import Compliance, ComplianceSpec, as_compliance
from .robot.poses import random_poses
from .sensors import CableModel, Drawstring, MeasurementModel, PositionDevice, PositionModel, sensor_for
from .units import for_humans, from_humans

#: Default sensor geometry of simulated sessions: the sensor body on the floor in
#: front of the robot, the cable hooked on the tool axis 50 mm out of the flange.
DEFAULT_ANCHOR_MM = (600.0, 200.0, -100.0)
DEFAULT_TOOL_MM = (0.0, 0.0, 50.0)

#: Kinds of reading noise the simulator draws (see :func:`reading_noise`).
NOISE_KINDS = ("gauss", "student", "outliers", "student-outliers")
#: Degrees of freedom of the heavy-tailed Student-t noise.
STUDENT_DOF = 3
#: Share of rows with a gross error, and the range of its size [mm], for ``outliers``.
OUTLIER_FRACTION = 0.05
OUTLIER_MM = (1.0, 3.0)


def reading_noise(
    kind: str, n: int, noise_mm: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Reading noise of ``n`` poses, [m], and the rows given a gross error.

    Kinds:
        ``gauss``: normal, standard deviation ``noise_mm``.
        ``student``: Student-t with 3 degrees of freedom (heavy tails), scaled to the
            same standard deviation ``noise_mm``.
        ``outliers``: normal as ``gauss``, plus on 5 % of the rows (at least one) a
            gross error of 1 to 3 mm with random sign, as a snagged or sagging cable
            would give.
        ``student-outliers``: Student-t as ``student``, plus the gross errors of
            ``outliers``.

    Raises:
        CalibPinError: unknown kind.
    """
    sigma = noise_mm * 1e-3
    outliers = np.zeros(n, dtype=bool)
    if kind not in NOISE_KINDS:
        raise CalibPinError(f"unknown noise kind '{kind}' (valid: {', '.join(NOISE_KINDS)})")
    if kind.startswith("student"):
        dof = STUDENT_DOF
        noise = rng.standard_t(dof, size=n) * sigma * np.sqrt((dof - 2) / dof)
    else:
        noise = rng.normal(scale=sigma, size=n)
    if kind.endswith("outliers"):
        rows = rng.choice(n, size=max(1, int(round(OUTLIER_FRACTION * n))), replace=False)
        outliers[rows] = True
        size = rng.uniform(*OUTLIER_MM, size=len(rows)) * 1e-3
        noise[rows] += size * rng.choice([-1.0, 1.0], size=len(rows))
    return noise, outliers


@dataclass
class Truth:
    """What the simulator knows.

    Attributes:
        x: True robot deviations, shape (n_params,), SI units.
        names: Parameter names.
        units: SI unit of each parameter.
        sensor: True sensor geometry (a :class:`~calib_pin.sensors.Drawstring` or a
            :class:`~calib_pin.sensors.PositionDevice`).
        kind: The data kind (``cable``, ``position``).
        noise: Noise of the values (1 sigma), [m].
        seed: Seed of the draw.
        noise_kind: ``gauss``, ``student`` or ``outliers`` (see :func:`reading_noise`).
        outliers: Data rows (0-based) given a gross error.
        compliance: Compliant joints and loads of the true arm, or None (rigid).
        compliance_values: Their true compliances, shape (n_compliant,), [rad/Nm].
        sessions: With several sessions of the one true robot
            (:func:`simulate_sessions`), each session's true sensor geometry in turn
            (the first is :attr:`sensor`); empty for one session.
    """

    x: np.ndarray
    names: tuple[str, ...]
    units: tuple[str, ...]
    sensor: Any
    kind: str
    noise: float
    seed: int
    noise_kind: str = "gauss"
    outliers: tuple[int, ...] = ()
    compliance: ComplianceSpec | None = None
    compliance_values: np.ndarray | None = None
    sessions: tuple[Any, ...] = ()

    def session(self, k: int) -> Truth:
        """The truth of session ``k`` (0-based): the one robot, that session's sensor."""
        if not self.sessions:
            if k != 0:
                raise ArgumentError("k", f"a truth of one session has no session {k}")
            return self
        as_int(k, "k", 0, len(self.sessions) - 1)
        return dataclasses.replace(self, sensor=self.sessions[k], sessions=())

    def model(self, chain: Chain, params: ParameterModel) -> MeasurementModel:
        """The true sensor's measurement model (nothing of the sensor estimated; the true
        arm's compliant joints, if any): evaluate it at :attr:`x_model`."""
        return sensor_for(self.kind)(chain, params, self.sensor, estimate=(),  # type: ignore[call-arg]
                                     compliance=self.compliance)

    @property
    def x_model(self) -> np.ndarray:
        """The true unknowns of :meth:`model`: deviations, then compliances [rad/Nm]."""
        return np.concatenate([self.x, self.compliance_values if self.compliance_values is not None else []])

    def to_json(self, path: str | Path) -> None:
        """Write the truth with deviations in mm and deg."""
        doc = {
            "seed": self.seed,
            "data_kind": self.kind,
            "noise_mm": self.noise * 1e3,
            "noise_kind": self.noise_kind,
            "outlier_rows": list(self.outliers),
            **self.sensor.to_dict(),
            "deviations": for_humans(self.x, self.names, self.units),
        }
        if self.compliance is not None and self.compliance_values is not None:
            doc["compliance"] = {**self.compliance.to_dict(),
                                 "compliance_rad_per_Nm": np.asarray(self.compliance_values).tolist()}
        if self.sessions:
            doc["sessions"] = [g.to_dict() for g in self.sessions]
        write_text(path, json.dumps(doc, indent=2) + "\n")

    @classmethod
    def from_json(cls, path: str | Path, params: ParameterModel) -> Truth:
        """Read a truth file written by :meth:`to_json` for the parameter model ``params``.

        Raises:
            DataError: unreadable file, or deviations that do not match ``params``.
        """
        try:
            check_regular(path)
            doc = json.loads(Path(path).read_text())
            kind = doc.get("data_kind", "cable")
            x = from_humans(doc["deviations"], params.names, params.units)
            sensor = sensor_for(kind).geometry_type.from_dict(doc)
            soft = doc.get("compliance")
            spec = ComplianceSpec.from_dict(soft) if soft else None
            values = np.asarray(soft["compliance_rad_per_Nm"], dtype=float) if soft else None
            sessions = tuple(sensor_for(kind).geometry_type.from_dict(g) for g in doc.get("sessions", ()))
            return cls(x, tuple(params.names), tuple(params.units), sensor, kind,
                       float(doc["noise_mm"]) * 1e-3, int(doc["seed"]),
                       doc.get("noise_kind", "gauss"), tuple(doc.get("outlier_rows", ())), spec, values, sessions)
        except OSError as e:
            raise DataError(str(path), f"cannot read: {e.strerror or e}") from None
        except (ValueError, KeyError, TypeError) as e:
            raise DataError(str(path), f"not a calib-pin truth file ({type(e).__name__}: {e})") from None


def _poses_above_base(chain: Chain, cable: CableModel, n_poses: int, rng: np.random.Generator) -> np.ndarray:
    """Random poses within the limits with the tool point above the mounting plane."""
    poses = np.empty((0, chain.n_joints))
    for _ in range(50):
        batch = random_poses(chain, 2 * n_poses, rng)
        above = cable.tool_positions(None, batch)[:, 2] > 0.0
        poses = np.vstack([poses, batch[above]])
        if len(poses) >= n_poses:
            break
    else:
        raise CalibPinError(
            f"robot '{chain.name}': only {len(poses)} of {100 * n_poses} random poses put the "
            "tool point above the base's mounting plane (z > 0); check the tool point"
        )
    return poses[:n_poses]


def _true_deviations(params: ParameterModel, rng: np.random.Generator, nominal_rmse_mm: float,
                     gap: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Deviations drawn normal with the model's typical sizes, scaled so that the
    nominal model's errors ``gap(x)`` [m] have RMSE ``nominal_rmse_mm`` (0: all zero)."""
    x = rng.normal(size=len(params.names)) * params.scale
    if nominal_rmse_mm <= 0:
        return np.zeros_like(x)
    return x * (nominal_rmse_mm * 1e-3 / np.sqrt(np.mean(gap(x) ** 2)))


def simulate(
    chain: Chain,
    params: ParameterModel,
    n_poses: int,
    seed: int,
    noise_mm: float = 0.05,
    nominal_rmse_mm: float = 2.0,
    anchor_mm: tuple[float, float, float] = DEFAULT_ANCHOR_MM,
    tool_mm: tuple[float, float, float] = DEFAULT_TOOL_MM,
    length_offset_mm: float = 0.0,
    noise_kind: str = "gauss",
    poses: np.ndarray | None = None,
    compliance: Compliance | ComplianceSpec | str | None = None,
    true_compliance: Any = None,
    *,
    _true_x: np.ndarray | None = None,
) -> tuple[MeasurementSet, Truth]:
    """Simulate a drawstring session.

    True deviations are drawn normal with the parameter model's typical sizes, then
    scaled so that the nominal model's reading error on the drawn poses has RMSE
    ``nominal_rmse_mm`` (the paper's Table I "Before": 2.09 mm). Poses are uniform
    within the joint limits less 5 deg, keeping only those with the tool point above
    the base's mounting plane (z > 0).

    Args:
        chain, params: The robot and how its deviations are parametrised.
        n_poses: Number of poses.
        seed: Seed of every random draw.
        noise_mm: Reading noise, 1 sigma, [mm].
        nominal_rmse_mm: Reading error of the nominal model, [mm]; 0 keeps the robot
            nominal.
        anchor_mm, tool_mm: Sensor point (base frame) and tool point (end frame), [mm].
        length_offset_mm: Sensor zero offset, [mm].
        noise_kind: ``gauss``, ``student`` or ``outliers`` (see :func:`reading_noise`).
        poses: Joint angles to use, shape (n_poses, n_joints) [rad], instead of random
            ones (``n_poses`` is then ignored).
        compliance, true_compliance: The true arm's compliant joints and loads (a
            :class:`~calib_pin.robot.deflection.Compliance`, joint names as shorthand, or
            a resolved ``ComplianceSpec``), and their compliances [rad/Nm]; None: a rigid arm.
        _true_x: Internal (:func:`simulate_sessions`): the true deviations of a robot
            already drawn, used instead of drawing them.

    Raises:
        ArgumentError: a bad argument, named (a chain or parameter model of another
            type, a count, seed or noise out of range, a point not 3 finite numbers [mm],
            poses not within the joint limits in [rad], negative true compliances).
    """
    seed, n_poses, noise_mm, nominal_rmse_mm = _common_arguments(chain, params, n_poses, seed, noise_mm, nominal_rmse_mm,
                                                                 poses is not None)
    noise_kind = as_choice(noise_kind, "noise_kind", NOISE_KINDS)
    anchor, tool = as_xyz_mm(anchor_mm, "anchor_mm"), as_xyz_mm(tool_mm, "tool_mm")
    offset = as_float(length_offset_mm, "length_offset_mm", -MAX_MM, MAX_MM, unit="mm")
    if poses is not None:
        poses = np.atleast_2d(as_angles_rad(poses, "poses", chain))
    rng = np.random.default_rng(seed)
    sensor = Drawstring(anchor * 1e-3, tool * 1e-3, offset * 1e-3)
    cable = CableModel(chain, params, sensor)
    poses = _poses_above_base(chain, cable, n_poses, rng) if poses is None else poses
    n_poses = len(poses)
    nominal = cable.predict(np.zeros(len(params.names)), poses)
    x = _true_deviations(params, rng, nominal_rmse_mm, lambda x: np.abs(cable.predict(x, poses) - nominal)) \
        if _true_x is None else _true_x
    noise, outliers = reading_noise(noise_kind, n_poses, noise_mm, rng)
    compliance, soft = _true_compliance(chain, compliance, true_compliance)
    true_model = CableModel(chain, params, sensor, compliance=compliance)
    readings = true_model.predict(np.concatenate([x, soft]), poses) + noise
    data = MeasurementSet(q=poses, values=readings, kind="cable", anchor=sensor.anchor, tool=sensor.tool,
                          length_offset=sensor.length_offset, robot=chain.name, end_frame=chain.end_frame,
                          notes={"source": f"calib-pin simulator, seed {seed}, noise {noise_mm:g} mm ({noise_kind})"})
    truth = Truth(
        x, tuple(params.names), tuple(params.units), sensor, "cable", noise_mm * 1e-3, seed,
        noise_kind, tuple(int(i) for i in np.flatnonzero(outliers)), compliance, soft if compliance else None,
    )
    return data, truth


def _common_arguments(chain: Any, params: Any, n_poses: Any, seed: Any, noise_mm: Any, nominal_rmse_mm: Any,
                      poses_given: bool = False) -> tuple[int, int, float, float]:
    """The arguments both simulators share, checked: seed, number of poses, noise and
    nominal error [mm] (``n_poses`` is not used when poses are given)."""
    as_parameter_model(params, "params", as_chain(chain, "chain"))
    n = 1 if poses_given else as_int(n_poses, "n_poses", 1, 10**8)
    return (as_int(seed, "seed", 0), n, as_float(noise_mm, "noise_mm", 0.0, 1e3, unit="mm"),
            as_float(nominal_rmse_mm, "nominal_rmse_mm", 0.0, 1e3, unit="mm"))


def _true_compliance(chain: Chain, compliance: Any, values: Any) -> tuple[ComplianceSpec | None, np.ndarray]:
    """The true arm's compliance spec and the true compliances [rad/Nm] of its joints
    (None and empty for a rigid arm).

    Raises:
        CalibPinError: a bad compliance record, values without joints, a count that does
            not match, or a negative value.
    """
    if isinstance(compliance, ComplianceSpec):
        spec: ComplianceSpec | None = compliance
    else:
        record = as_compliance(compliance)
        spec = record.spec(chain) if record is not None else None
    return spec, _true_values(spec, values)


def _true_values(spec: ComplianceSpec | None, values: Any) -> np.ndarray:
    """The true compliances [rad/Nm] of ``spec``'s joints (empty for a rigid arm)."""
    if spec is not None and spec.model != "cad":  # the true arm's torques come from its inertias
        raise ArgumentError("compliance", "a simulated compliant arm needs the CAD compliance model (the URDF's "
                                          "inertias, true compliances in rad/Nm); this robot's model is "
                                          f"'{spec.model}' (a URDF without inertial data)")
    if spec is None:
        if values is not None and np.size(values):
            raise ArgumentError("true_compliance", "true compliances need compliant joints (compliance)")
        return np.zeros(0)
    c = as_array(values if values is not None else [], "true_compliance", (len(spec.joints),), unit="rad/Nm")
    if not np.all(c >= 0):
        raise ArgumentError("true_compliance", f"give {len(spec.joints)} true compliance(s) >= 0 for "
                            f"{', '.join(spec.joints)} [rad/Nm], got {c.tolist()}")
    return c


#: Default marker points of simulated position sets, end frame, [mm].
DEFAULT_MARKERS_MM = ((60.0, 0.0, 40.0), (-30.0, 52.0, 40.0), (-30.0, -52.0, 40.0))


def simulate_positions(
    chain: Chain,
    params: ParameterModel,
    n_poses: int,
    seed: int,
    noise_mm: float = 0.05,
    nominal_rmse_mm: float = 2.0,
    markers_mm=DEFAULT_MARKERS_MM,
    device: pin.SE3 | None = None,
    compliance: Compliance | ComplianceSpec | str | None = None,
    true_compliance: Any = None,
    *,
    _true_x: np.ndarray | None = None,
) -> tuple[MeasurementSet, Truth]:
    """Simulate a position session: every marker measured at each pose by a device.

    True deviations are drawn like :func:`simulate`'s, scaled so the nominal model's
    position error (Euclidean, over all rows) has RMSE ``nominal_rmse_mm``. Each
    coordinate gets Gaussian noise ``noise_mm`` (1 sigma). ``device`` is T_DB (default:
    the device 2 m in front of the robot, turned 150 deg about z).

    Returns:
        The set (rows: pose-major, markers labelled 1..k) and the truth (deviations and
        device geometry).

    Raises:
        ArgumentError: a bad argument, named (as :func:`simulate`; ``markers_mm`` not
            (k, 3) finite numbers [mm], ``device`` not a pinocchio.SE3).
    """
    seed, n_poses, noise_mm, nominal_rmse_mm = _common_arguments(chain, params, n_poses, seed, noise_mm, nominal_rmse_mm)
    markers = as_array(markers_mm, "markers_mm", (None, 3), unit="mm") * 1e-3
    if not len(markers):
        raise ArgumentError("markers_mm", "give at least one marker point (x, y, z in mm)")
    as_optional(as_instance, device, "device", pin.SE3, "the device frame T_DB as a pinocchio.SE3, or None")
    compliance, soft = _true_compliance(chain, compliance, true_compliance)
    rng = np.random.default_rng(seed)
    if device is None:
        device = pin.SE3(pin.rpy.rpyToMatrix(0.02, -0.01, np.deg2rad(150.0)), np.array([2.0, 0.3, -0.4]))
    labels = tuple(range(1, len(markers) + 1))
    truth_device = PositionDevice(device, markers, labels)
    model = PositionModel(chain, params, truth_device, estimate=())
    q = np.repeat(random_poses(chain, n_poses, rng), len(markers), axis=0)
    index = np.tile(np.arange(len(markers)), n_poses)
    nominal = model.predict(None, q, index)
    x = _true_deviations(params, rng, nominal_rmse_mm,
                         lambda x: np.linalg.norm(model.predict(x, q, index) - nominal, axis=1)) \
        if _true_x is None else _true_x
    true_model = PositionModel(chain, params, truth_device, estimate=(), compliance=compliance)
    positions = true_model.predict(np.concatenate([x, soft]), q, index) + rng.normal(size=q.shape[:1] + (3,)) * noise_mm * 1e-3
    data = MeasurementSet(
        q=q, values=positions, kind="position", robot=chain.name, end_frame=chain.end_frame,
        notes={"source": f"calib-pin position simulator, seed {seed}, noise {noise_mm:g} mm per axis"},
        pose_ids=np.repeat(np.arange(1, n_poses + 1), len(markers)),
        point_ids=np.array(labels)[index], noise=noise_mm * 1e-3 or None,  # noise-free: no sensor sigma to state
    )
    truth = Truth(x, tuple(params.names), tuple(params.units), truth_device, "position", noise_mm * 1e-3, seed,
                  compliance=compliance, compliance_values=soft if compliance else None)
    return data, truth


#: Spread of the anchors drawn for sessions 2.. around the first, base frame, per axis, [mm]
#: (a drawstring re-anchored elsewhere on the floor or a fixture).
SESSION_ANCHOR_SPREAD_MM = (400.0, 400.0, 150.0)
#: Spread of the device placements drawn for position sessions 2..: a turn about the
#: vertical [deg] and a shift per axis [mm] (a tracker moved to another station).
SESSION_DEVICE_TURN_DEG = 60.0
SESSION_DEVICE_SHIFT_MM = (400.0, 400.0, 100.0)


def simulate_sessions(
    chain: Chain,
    params: ParameterModel,
    n_poses: int,
    seed: int,
    sessions: int = 3,
    *,
    kind: str = "cable",
    noise_mm: float = 0.05,
    nominal_rmse_mm: float = 2.0,
    anchors_mm: Any = None,
    tool_mm: tuple[float, float, float] = DEFAULT_TOOL_MM,
    length_offset_mm: float = 0.0,
    noise_kind: str = "gauss",
    markers_mm: Any = DEFAULT_MARKERS_MM,
    devices: Any = None,
    poses: np.ndarray | None = None,
    compliance: Compliance | ComplianceSpec | str | None = None,
    true_compliance: Any = None,
) -> tuple[list[MeasurementSet], Truth]:
    """Simulate several sessions of one true robot, each with its own sensor set-up.

    The true deviations (and compliances) are drawn once, in session 1, exactly as
    :func:`simulate` (or :func:`simulate_positions`) of ``seed`` draws them: session 1 is
    that function's set. Session k (k = 1..sessions) has its own poses and noise (seed
    ``seed + k - 1``) and its own set-up: a drawstring its own anchor, a position device
    its own device frame (the markers are the one tool's, shared).

    Args:
        chain, params, n_poses, noise_mm, nominal_rmse_mm, noise_kind, compliance,
            true_compliance: As :func:`simulate` (``noise_kind`` for cables only).
        seed: Seed of session 1 and of the set-ups drawn.
        sessions: Number of sessions, >= 1.
        kind: ``cable`` (a drawstring) or ``position`` (a position device).
        anchors_mm: Cable: one anchor per session, shape (sessions, 3), base frame [mm];
            None: the default anchor for session 1 and, for the others, anchors drawn
            uniformly within :data:`SESSION_ANCHOR_SPREAD_MM` of it.
        tool_mm, length_offset_mm: Cable: the tool point [mm, end frame] and the sensor's
            zero offset [mm], the same in every session.
        markers_mm: Position: marker points, shape (k, 3), end frame [mm].
        devices: Position: one device frame T_DB (pinocchio.SE3) per session; None: the
            default frame for session 1, the others turned about the vertical within
            :data:`SESSION_DEVICE_TURN_DEG` and shifted within
            :data:`SESSION_DEVICE_SHIFT_MM` of it.
        poses: Cable: joint angles [rad], shape (n_poses, n_joints), used in every
            session instead of random ones.

    Returns:
        The sets, one per session (each carrying its own true set-up), and one truth:
        the robot and, in ``sessions``, every session's true sensor geometry.

    Raises:
        ArgumentError: a bad argument, named (as :func:`simulate`; anchors or devices not
            one per session).
    """
    sessions = as_int(sessions, "sessions", 1, 1000)
    kind = as_choice(kind, "kind", ("cable", "position"))
    seed = as_int(seed, "seed", 0)
    rng = np.random.default_rng([seed, sessions, 7])  # the set-ups' own draws
    sets: list[MeasurementSet] = []
    truths: list[Truth] = []
    if kind == "cable":
        if anchors_mm is None:
            first = np.asarray(DEFAULT_ANCHOR_MM)
            spread = np.asarray(SESSION_ANCHOR_SPREAD_MM)
            anchors = np.vstack([first] + [first + rng.uniform(-spread, spread) for _ in range(sessions - 1)])
        else:
            anchors = as_array(anchors_mm, "anchors_mm", (sessions, 3), unit="mm")
        for k in range(sessions):
            data, truth = simulate(chain, params, n_poses, seed + k, noise_mm, nominal_rmse_mm,
                                   anchor_mm=tuple(anchors[k]), tool_mm=tool_mm, length_offset_mm=length_offset_mm,
                                   noise_kind=noise_kind, poses=poses, compliance=compliance,
                                   true_compliance=true_compliance, _true_x=truths[0].x if truths else None)
            sets.append(data)
            truths.append(truth)
    else:
        if poses is not None:
            raise ArgumentError("poses", "given poses are for drawstring sessions (kind 'cable') only")
        if devices is None:
            frames = [None] + [pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, np.deg2rad(rng.uniform(-1, 1) * SESSION_DEVICE_TURN_DEG)),
                                       rng.uniform(-1, 1, 3) * np.asarray(SESSION_DEVICE_SHIFT_MM) * 1e-3)
                               for _ in range(sessions - 1)]
        else:
            if not isinstance(devices, (list, tuple)) or len(devices) != sessions:
                raise ArgumentError("devices", f"give one device frame (pinocchio.SE3) per session ({sessions})")
            frames = list(devices)
        for k in range(sessions):
            frame = frames[k]
            if devices is None and k > 0:  # moved from session 1's placement
                frame = frames[k] * truths[0].sensor.frame
            data, truth = simulate_positions(chain, params, n_poses, seed + k, noise_mm, nominal_rmse_mm,
                                             markers_mm=markers_mm, device=frame, compliance=compliance,
                                             true_compliance=true_compliance,
                                             _true_x=truths[0].x if truths else None)
            sets.append(data)
            truths.append(truth)
    for k, data in enumerate(sets):
        data.notes["source"] = f"{data.notes['source']}, session {k + 1} of {sessions}"
    truth = dataclasses.replace(truths[0], sessions=tuple(t.sensor for t in truths)) if sessions > 1 else truths[0]
    return sets, truth

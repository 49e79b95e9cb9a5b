"""Simulated sessions with known true deviations, of any registered sensor.

The simulator draws what every sensor shares (:class:`SimulationDraw`): true kinematic
deviations, random poses within the joint limits (:func:`calib_pin.robot.poses.random_poses`),
the true compliances and the noise. What the sensor would read on the true robot is the
sensor's own: its ``simulate_rows`` (:meth:`calib_pin.sensors.base.MeasurementModel.simulate_rows`),
so a new sensor simulates by implementing that one method (:func:`simulate_set`). The truth
(:class:`Truth`) is kept so every estimate can be checked against it. :func:`simulate`
(drawstring) and :func:`simulate_positions` (a position device) are the two sensors'
shorthands; :func:`simulate_sessions` writes several sessions, of one kind or several,
of one true robot.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements import MeasurementSet
from ..parameters import ParameterModel
from ..parameters.base import as_parameter_model
from ..robot import Chain
from ..robot.chain import as_angles_rad, as_chain
from ..robot.deflection import Compliance, ComplianceSpec, as_compliance
from ..robot.poses import random_poses
from ..sensors import SENSORS, CableModel, Drawstring, MeasurementModel, PositionDevice, PositionModel, default_kind, sensor_for
from ..sensors.cable import DEFAULT_ANCHOR_MM, DEFAULT_TOOL_MM
from ..sensors.cable import SESSION_ANCHOR_SPREAD_MM as SESSION_ANCHOR_SPREAD_MM  # re-exported
from ..sensors.position import DEFAULT_MARKERS_MM, default_device_frame
from ..sensors.position import SESSION_DEVICE_SHIFT_MM as SESSION_DEVICE_SHIFT_MM  # re-exported
from ..sensors.position import SESSION_DEVICE_TURN_DEG as SESSION_DEVICE_TURN_DEG  # re-exported
from ..util.arguments import MAX_MM, as_array, as_choice, as_float, as_instance, as_int, as_optional, as_point_mm
from ..util.atomic import write_text
from ..util.input_files import check_regular
from ..util.units import for_humans, from_humans

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

    Args:
        kind: The noise kind (below).
        n: Number of poses.
        noise_mm: Standard deviation of the noise, [mm].
        rng: The random generator.

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
        session_kinds, session_noise: Each session's data kind and noise [m] when the
            sessions differ in either (sensors of several kinds); else empty (``kind``
            and ``noise`` are every session's).
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
    session_kinds: tuple[str, ...] = ()
    session_noise: tuple[float, ...] = ()

    def session(self, k: int) -> Truth:
        """The truth of session ``k`` (0-based): the one robot, that session's sensor."""
        if not self.sessions:
            if k != 0:
                raise ArgumentError("k", f"a truth of one session has no session {k}")
            return self
        as_int(k, "k", 0, len(self.sessions) - 1)
        kind = self.session_kinds[k] if self.session_kinds else self.kind
        noise = self.session_noise[k] if self.session_noise else self.noise
        return dataclasses.replace(self, sensor=self.sessions[k], kind=kind, noise=noise, sessions=(),
                                   session_kinds=(), session_noise=())

    def model(self, chain: Chain, params: ParameterModel) -> MeasurementModel:
        """The true sensor's measurement model: evaluate it at :attr:`x_model`.

        Nothing of the sensor is estimated; the true arm's compliant joints, if any.
        """
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
        if self.sessions and self.session_kinds:  # sessions of several kinds or noises: each says its own
            doc["sessions"] = [{"data_kind": kind, "noise_mm": noise * 1e3, **g.to_dict()} for kind, noise, g
                               in zip(self.session_kinds, self.session_noise, self.sessions, strict=True)]
        elif self.sessions:
            doc["sessions"] = [g.to_dict() for g in self.sessions]
        write_text(path, json.dumps(doc, indent=2) + "\n")

    @classmethod
    def from_json(cls, path: str | Path, params: ParameterModel) -> Truth:
        """Read a truth file written by :meth:`to_json` for the parameter model ``params``.

        Args:
            path: The truth file (JSON).
            params: The parameter model its deviations belong to.

        Raises:
            DataError: unreadable file, or deviations that do not match ``params``.
        """
        try:
            check_regular(path)
            doc = json.loads(Path(path).read_text())
            kind = doc.get("data_kind", default_kind())
            x = from_humans(doc["deviations"], params.names, params.units)
            sensor = sensor_for(kind).geometry_type.from_dict(doc)
            soft = doc.get("compliance")
            spec = ComplianceSpec.from_dict(soft) if soft else None
            values = np.asarray(soft["compliance_rad_per_Nm"], dtype=float) if soft else None
            listed = doc.get("sessions", ())
            kinds = tuple(g["data_kind"] for g in listed) if any("data_kind" in g for g in listed) else ()
            noise = tuple(float(g["noise_mm"]) * 1e-3 for g in listed) if kinds else ()
            sessions = tuple(sensor_for(kinds[k] if kinds else kind).geometry_type.from_dict(g)
                             for k, g in enumerate(listed))
            return cls(x, tuple(params.names), tuple(params.units), sensor, kind,
                       float(doc["noise_mm"]) * 1e-3, int(doc["seed"]),
                       doc.get("noise_kind", "gauss"), tuple(doc.get("outlier_rows", ())), spec, values, sessions,
                       kinds, noise)
        except OSError as e:
            raise DataError(str(path), f"cannot read: {e.strerror or e}") from None
        except (ValueError, KeyError, TypeError) as e:
            raise DataError(str(path), f"not a calib-pin truth file ({type(e).__name__}: {e})") from None


@dataclass
class SimulationDraw:
    """What every simulated set shares, handed to its sensor's ``simulate_rows``.

    Its :meth:`~calib_pin.sensors.base.MeasurementModel.simulate_rows` gets the robot, the
    seeded random draws (poses, true deviations, noise, in the order the sensor asks for
    them) and the true compliances.

    Attributes:
        chain, params: The robot and how its deviations are parametrised.
        seed: Seed of the draws (``rng = numpy.random.default_rng(seed)``).
        n_poses: Poses to draw (unused when ``given_poses`` is set).
        noise_mm: Noise of each value, 1 sigma, [mm]; ``noise_kind``: see :func:`reading_noise`.
        nominal_rmse_mm: The nominal model's row-error RMSE the drawn deviations give, [mm].
        compliance, true_compliance: The true arm's compliance spec (or None, rigid) and
            its compliances [rad/Nm].
        given_poses: The caller's joint angles [rad], or None (random ones).
        given_x: The true deviations of a robot already drawn (several sessions), or None.
        x: The true deviations, once :meth:`deviations` ran; ``outliers``: rows given a
            gross error by :meth:`noise`.
    """

    chain: Chain
    params: ParameterModel
    seed: int
    n_poses: int
    noise_mm: float = 0.05
    noise_kind: str = "gauss"
    nominal_rmse_mm: float = 2.0
    compliance: ComplianceSpec | None = None
    true_compliance: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    given_poses: np.ndarray | None = None
    given_x: np.ndarray | None = None
    x: np.ndarray | None = None
    outliers: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=bool))
    #: The caller's sensor set-up options for the simulation (field -> value; a sensor reads its own).
    setup: dict[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)

    def poses(self, keep: Callable[[np.ndarray], np.ndarray] | None = None, why: str = "",
              batches: int = 50) -> np.ndarray:
        """The set's joint angles, shape (n_poses, n_joints), [rad]: the caller's, or random.

        Random ones are within the limits (:func:`calib_pin.robot.poses.random_poses`).

        Args:
            keep: A mask of the usable poses, ``keep(q)``; only those kept when given.
            why: What the kept poses must do, for the refusal.
            batches: At most so many batches of twice the poses are drawn for ``keep``.

        Raises:
            CalibPinError: too few random poses kept.
        """
        if self.given_poses is not None:
            return self.given_poses
        if keep is None:
            return random_poses(self.chain, self.n_poses, self.rng)
        poses = np.empty((0, self.chain.n_joints))
        for _ in range(batches):
            batch = random_poses(self.chain, 2 * self.n_poses, self.rng)
            poses = np.vstack([poses, batch[keep(batch)]])
            if len(poses) >= self.n_poses:
                break
        else:
            raise CalibPinError(f"robot '{self.chain.name}': only {len(poses)} of {2 * batches * self.n_poses} random "
                                f"poses {why}")
        return poses[: self.n_poses]

    def deviations(self, gap: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """The true deviations, shape (n_params,), SI: ``given_x``, or drawn.

        Drawn normal with the model's typical sizes and scaled so the nominal model's row
        errors ``gap(x)`` [m] have RMSE ``nominal_rmse_mm`` (0: all zero).
        """
        self.x = _true_deviations(self.params, self.rng, self.nominal_rmse_mm, gap) \
            if self.given_x is None else self.given_x
        return self.x

    @property
    def x_model(self) -> np.ndarray:
        """The true unknowns of a model with :attr:`compliance`: deviations, then compliances."""
        assert self.x is not None, "deviations() first"
        return np.concatenate([self.x, self.true_compliance])

    def noise(self, shape: int | tuple[int, ...]) -> np.ndarray:
        """Noise of the values [m], of ``noise_kind`` or normal.

        Args:
            shape: An int (one value a row): of ``noise_kind`` (:func:`reading_noise`, its
                gross-error rows kept in :attr:`outliers`); a tuple (rows of several values):
                each value normal, 1 sigma ``noise_mm``.

        Raises:
            ArgumentError: a heavy-tailed or outlier kind for rows of several values.
        """
        if isinstance(shape, int | np.integer):
            noise, self.outliers = reading_noise(self.noise_kind, int(shape), self.noise_mm, self.rng)
            return noise
        if self.noise_kind != "gauss":
            raise ArgumentError("noise_kind", f"'{self.noise_kind}' is drawn for rows of one value; rows of "
                                f"{shape[1:]} values get 'gauss'")
        return self.rng.normal(size=shape) * self.noise_mm * 1e-3


def _true_deviations(params: ParameterModel, rng: np.random.Generator, nominal_rmse_mm: float,
                     gap: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Deviations drawn normal with the model's typical sizes, scaled to the asked nominal error.

    Scaled so that the nominal model's errors ``gap(x)`` [m] have RMSE ``nominal_rmse_mm``
    (0: all zero).
    """
    x = rng.normal(size=len(params.names)) * params.scale
    if nominal_rmse_mm <= 0:
        return np.zeros_like(x)
    return x * (nominal_rmse_mm * 1e-3 / np.sqrt(np.mean(gap(x) ** 2)))



def simulate_set(
    sensor: type[MeasurementModel],
    chain: Chain,
    params: ParameterModel,
    n_poses: int,
    seed: int,
    geometry: Any = None,
    *,
    noise_mm: float = 0.05,
    nominal_rmse_mm: float = 2.0,
    noise_kind: str = "gauss",
    poses: np.ndarray | None = None,
    compliance: Compliance | ComplianceSpec | str | None = None,
    true_compliance: Any = None,
    true_x: np.ndarray | None = None,
    setup: dict[str, Any] | None = None,
) -> tuple[MeasurementSet, Truth]:
    """Simulate a session of any registered sensor.

    The common draws (:class:`SimulationDraw`) and the sensor's own rows (its ``simulate_rows``).

    Args:
        sensor: The sensor's measurement model (``calib_pin.sensors.sensor_for(kind)``).
        chain, params, n_poses, seed, noise_mm, nominal_rmse_mm, noise_kind, poses,
            compliance, true_compliance: As :func:`simulate`.
        geometry: The sensor's true set-up (its ``geometry_type``); None: its default.
        true_x: The true deviations of a robot already drawn, used instead of drawing them.
        setup: Sensor set-up options of the simulation (``noise_deg``; a sensor reads its own).

    Raises:
        ArgumentError: a bad argument, named.
    """
    seed, n_poses, noise_mm, nominal_rmse_mm = _common_arguments(chain, params, n_poses, seed, noise_mm, nominal_rmse_mm,
                                                                 poses is not None)
    noise_kind = as_choice(noise_kind, "noise_kind", NOISE_KINDS)
    if poses is not None:
        poses = np.atleast_2d(as_angles_rad(poses, "poses", chain))
    spec, soft = _true_compliance(chain, compliance, true_compliance)
    draw = SimulationDraw(chain, params, seed, n_poses, noise_mm, noise_kind, nominal_rmse_mm, spec, soft, poses, true_x,
                          setup=dict(setup or {}))
    data, true_geometry = sensor.simulate_rows(draw, geometry)
    assert draw.x is not None, f"{sensor.__name__}.simulate_rows must draw the deviations"
    data.notes.setdefault("source", f"calib-pin simulator ({sensor.data_name}), seed {seed}, noise {noise_mm:g} mm")
    truth = Truth(draw.x, tuple(params.names), tuple(params.units), true_geometry, sensor.kind, noise_mm * 1e-3, seed,
                  noise_kind, tuple(int(i) for i in np.flatnonzero(draw.outliers)), spec, soft if spec else None)
    return data, truth


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
    """Simulate a drawstring session (:func:`simulate_set` of the drawstring).

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
        _true_x: Internal: the true deviations of a robot already drawn, used instead of drawing them.

    Raises:
        ArgumentError: a bad argument, named (a chain or parameter model of another
            type, a count, seed or noise out of range, a point not 3 finite numbers [mm],
            poses not within the joint limits in [rad], negative true compliances).
    """
    _common_arguments(chain, params, n_poses, seed, noise_mm, nominal_rmse_mm, poses is not None)
    as_choice(noise_kind, "noise_kind", NOISE_KINDS)
    return simulate_set(CableModel, chain, params, n_poses, seed, _drawstring(anchor_mm, tool_mm, length_offset_mm),
                        noise_mm=noise_mm, nominal_rmse_mm=nominal_rmse_mm, noise_kind=noise_kind, poses=poses,
                        compliance=compliance, true_compliance=true_compliance, true_x=_true_x)


def _drawstring(anchor_mm: Any, tool_mm: Any, length_offset_mm: Any) -> Drawstring:
    """A drawstring's true geometry from points and offset in mm, checked."""
    anchor, tool = as_point_mm(anchor_mm, "anchor_mm", "base"), as_point_mm(tool_mm, "tool_mm", "end frame")
    offset = as_float(length_offset_mm, "length_offset_mm", -MAX_MM, MAX_MM, unit="mm")
    return Drawstring(anchor * 1e-3, tool * 1e-3, offset * 1e-3)


def _common_arguments(chain: Any, params: Any, n_poses: Any, seed: Any, noise_mm: Any, nominal_rmse_mm: Any,
                      poses_given: bool = False) -> tuple[int, int, float, float]:
    """The arguments both simulators share, checked: seed, poses, noise and nominal error [mm].

    ``n_poses`` is not used when poses are given.
    """
    as_parameter_model(params, "params", as_chain(chain, "chain"))
    n = 1 if poses_given else as_int(n_poses, "n_poses", 1, 10**8)
    return (as_int(seed, "seed", 0), n, as_float(noise_mm, "noise_mm", 0.0, 1e3, unit="mm"),
            as_float(nominal_rmse_mm, "nominal_rmse_mm", 0.0, 1e3, unit="mm"))


def _true_compliance(chain: Chain, compliance: Any, values: Any) -> tuple[ComplianceSpec | None, np.ndarray]:
    """The true arm's compliance spec and the true compliances [rad/Nm] of its joints.

    None and empty for a rigid arm.

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

    :func:`simulate_set` of the position device. True deviations are drawn like
    :func:`simulate`'s, scaled so the nominal model's position error (Euclidean, over all
    rows) has RMSE ``nominal_rmse_mm``. Each coordinate gets Gaussian noise ``noise_mm``
    (1 sigma).

    Args:
        chain, params, n_poses, seed, nominal_rmse_mm, compliance, true_compliance: As
            :func:`simulate` (``nominal_rmse_mm``: the position error's, [mm]).
        noise_mm: Noise of each coordinate, 1 sigma, [mm].
        markers_mm: The marker points in the end frame, shape (k, 3), [mm].
        device: T_DB, the base in the device frame (default: the device 2 m in front of
            the robot, turned 150 deg about z).
        _true_x: Internal: the true deviations of a robot already drawn, used instead of drawing them.

    Returns:
        The set (rows: pose-major, markers labelled 1..k) and the truth (deviations and
        device geometry).

    Raises:
        ArgumentError: a bad argument, named (as :func:`simulate`; ``markers_mm`` not
            (k, 3) finite numbers [mm], ``device`` not a pinocchio.SE3).
    """
    _common_arguments(chain, params, n_poses, seed, noise_mm, nominal_rmse_mm)
    return simulate_set(PositionModel, chain, params, n_poses, seed, _device(markers_mm, device), noise_mm=noise_mm,
                        nominal_rmse_mm=nominal_rmse_mm, compliance=compliance, true_compliance=true_compliance,
                        true_x=_true_x)


def _device(markers_mm: Any, device: Any) -> PositionDevice:
    """A position device's true geometry from its frame T_DB and marker points, checked.

    T_DB None: the default; the marker points are in [mm], labelled 1..k.
    """
    markers = as_array(markers_mm, "markers_mm", (None, 3), unit="mm") * 1e-3
    if not len(markers):
        raise ArgumentError("markers_mm", "give at least one marker point (x, y, z in mm)")
    as_optional(as_instance, device, "device", pin.SE3, "the device frame T_DB as a pinocchio.SE3, or None")
    return PositionDevice(device if device is not None else default_device_frame(), markers,
                          tuple(range(1, len(markers) + 1)))


def _per_session(value: Any, name: str, sessions: int, check: Callable[[Any], Any]) -> list[Any]:
    """One value for every session, or one per session (a list or tuple), each checked."""
    if isinstance(value, list | tuple | np.ndarray) and np.ndim(value) == 1:
        if len(value) != sessions:
            raise ArgumentError(name, f"{len(value)} values for {sessions} sessions (give one, or one per session)")
        return [check(v) for v in value]
    return [check(value)] * sessions


def simulate_sessions(
    chain: Chain,
    params: ParameterModel,
    n_poses: int | Sequence[int],
    seed: int,
    sessions: int | None = None,
    *,
    kind: str | None = None,
    kinds: Sequence[str] | None = None,
    geometries: Sequence[Any] | None = None,
    noise_mm: float | Sequence[float] = 0.05,
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
    setup: dict[str, Any] | None = None,
) -> tuple[list[MeasurementSet], Truth]:
    """Simulate several sessions of one true robot, each with its own sensor and set-up.

    The true deviations (and compliances) are drawn once, in session 1, exactly as
    :func:`simulate_set` of session 1's sensor and ``seed`` draws them: session 1 is that
    function's set (:func:`simulate`'s, or :func:`simulate_positions`'). Session k
    (k = 1..sessions) has its own poses and noise (seed ``seed + k - 1``), its own sensor
    kind (``kinds``) and its own set-up: the caller's, session 1 of a kind the sensor's
    default, a later one of that kind drawn by the sensor's ``session_geometry`` (a
    drawstring re-anchored, a position device moved; the markers are the one tool's).

    Args:
        chain, params, nominal_rmse_mm, noise_kind, compliance, true_compliance: As
            :func:`simulate` (``noise_kind`` other than gauss for one-value rows only).
        n_poses, noise_mm: One for every session, or one per session (a list).
        seed: Seed of session 1 and of the set-ups drawn.
        sessions: Number of sessions, >= 1 (default: one per ``kinds``, else 3).
        kind: Every session's sensor kind (a key of ``calib_pin.sensors.SENSORS``;
            default the registry's first, the drawstring).
        kinds: One kind per session instead (sessions of different sensors of one robot).
        geometries: One true set-up per session (each its sensor's ``geometry_type``, or
            None for the default/drawn one), for any sensor.
        anchors_mm: Drawstring sessions: one anchor per drawstring session, shape (n, 3),
            base frame [mm]; None: the default anchor for the first and, for the others,
            anchors drawn uniformly within ``SESSION_ANCHOR_SPREAD_MM`` of it.
        tool_mm, length_offset_mm: Drawstring sessions: the tool point [mm, end frame] and
            the sensor's zero offset [mm], the same in every session.
        markers_mm: Position sessions: marker points, shape (k, 3), end frame [mm].
        devices: Position sessions: one device frame T_DB (pinocchio.SE3) per position
            session; None: the default frame for the first, the others turned about the
            vertical within ``SESSION_DEVICE_TURN_DEG`` and shifted within
            ``SESSION_DEVICE_SHIFT_MM`` of it.
        poses: Joint angles [rad], shape (n_poses, n_joints), used in every session
            instead of random ones.
        setup: Sensor set-up options of every session (``noise_deg``; a sensor reads its own).

    Returns:
        The sets, one per session (each carrying its own true set-up), and one truth:
        the robot and, in ``sessions``, every session's true sensor geometry (and, when
        they differ, each session's kind and noise).

    Raises:
        ArgumentError: a bad argument, named (as :func:`simulate`; anchors, devices,
            geometries, kinds, poses counts or noises not one per session).
    """
    if kinds is not None:
        if not isinstance(kinds, list | tuple) or not kinds:
            raise ArgumentError("kinds", "give one sensor kind per session (a list, e.g. ['cable', 'position'])")
        kinds = [as_choice(k, "kinds", tuple(SENSORS)) for k in kinds]
        if sessions is not None and as_int(sessions, "sessions", 1, 1000) != len(kinds):
            raise ArgumentError("kinds", f"{len(kinds)} kinds for {sessions} sessions (give one per session)")
        if kind is not None:
            raise ArgumentError("kind", "give kind (every session's) or kinds (one per session), not both")
    sessions = as_int(len(kinds) if kinds is not None else 3 if sessions is None else sessions, "sessions", 1, 1000)
    kind = as_choice(kind if kind is not None else default_kind(), "kind", tuple(SENSORS))
    every = list(kinds) if kinds is not None else [kind] * sessions
    seed = as_int(seed, "seed", 0)
    counts = _per_session(n_poses, "n_poses", sessions, lambda n: n)
    noises = _per_session(noise_mm, "noise_mm", sessions, lambda n: n)
    given = _given_geometries(every, geometries, anchors_mm, tool_mm, length_offset_mm, markers_mm, devices)
    rng = np.random.default_rng([seed, sessions, 7])  # the set-ups' own draws
    sets: list[MeasurementSet] = []
    truths: list[Truth] = []
    first: dict[str, Any] = {}  # each kind's first session's true geometry
    for k, this in enumerate(every):
        sensor = sensor_for(this)
        geometry = given[k]
        if geometry is None and this in first:
            geometry = sensor.session_geometry(first[this], rng)
        data, truth = simulate_set(sensor, chain, params, counts[k], seed + k, geometry, noise_mm=noises[k],
                                   nominal_rmse_mm=nominal_rmse_mm, noise_kind=noise_kind, poses=poses,
                                   compliance=compliance, true_compliance=true_compliance,
                                   true_x=truths[0].x if truths else None, setup=setup)
        first.setdefault(this, truth.sensor)
        sets.append(data)
        truths.append(truth)
    for k, data in enumerate(sets):
        data.notes["source"] = f"{data.notes['source']}, session {k + 1} of {sessions}"
    if sessions == 1:
        return sets, truths[0]
    alike = len(set(every)) == 1 and len({t.noise for t in truths}) == 1
    return sets, dataclasses.replace(truths[0], sessions=tuple(t.sensor for t in truths),
                                     session_kinds=() if alike else tuple(every),
                                     session_noise=() if alike else tuple(t.noise for t in truths))


def _given_geometries(kinds: list[str], geometries: Any, anchors_mm: Any, tool_mm: Any, length_offset_mm: Any,
                      markers_mm: Any, devices: Any) -> list[Any]:
    """Each session's true set-up the caller gave (None: the sensor's default or drawn).

    ``geometries``, else the drawstring sessions' from ``anchors_mm`` and the position
    sessions' from ``devices`` (each one per session of that kind, in turn).
    """
    sessions = len(kinds)
    if geometries is not None:
        if not isinstance(geometries, list | tuple) or len(geometries) != sessions:
            raise ArgumentError("geometries", f"give one true set-up (or None) per session ({sessions})")
        for k, (g, this) in enumerate(zip(geometries, kinds, strict=True)):
            if g is not None and not isinstance(g, sensor_for(this).geometry_type):
                raise ArgumentError("geometries", f"session {k + 1} ({this}): expected a "
                                    f"{sensor_for(this).geometry_type.__name__}, got {type(g).__name__}")
        return list(geometries)
    out: list[Any] = [None] * sessions
    cables = [k for k, this in enumerate(kinds) if this == CableModel.kind]
    stations = [k for k, this in enumerate(kinds) if this == PositionModel.kind]
    if cables:
        tool = _drawstring(DEFAULT_ANCHOR_MM, tool_mm, length_offset_mm)
        if anchors_mm is not None:
            anchors = as_array(anchors_mm, "anchors_mm", (len(cables), 3), unit="mm")
            for k, anchor in zip(cables, anchors, strict=True):
                out[k] = _drawstring(tuple(anchor), tool_mm, length_offset_mm)
        else:
            out[cables[0]] = tool
    elif anchors_mm is not None:
        raise ArgumentError("anchors_mm", "anchors are for drawstring sessions: no session is one")
    if stations:
        if devices is not None:
            if not isinstance(devices, list | tuple) or len(devices) != len(stations):
                raise ArgumentError("devices", f"give one device frame (pinocchio.SE3) per position session "
                                    f"({len(stations)})")
            for k, frame in zip(stations, devices, strict=True):
                out[k] = _device(markers_mm, frame)
        else:
            out[stations[0]] = _device(markers_mm, None)
    return out

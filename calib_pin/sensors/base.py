"""The measurement-model interface every sensor implements.

A measurement model predicts what a sensor reads at joint angles q for an unknown vector
x: the robot's deviations (a parameter model's, :mod:`calib_pin.parameters`) followed by
the sensor's own unknowns. It gives the analytic derivative of that prediction (the
identification Jacobian H of the paper's eq. 5, projected on what the sensor sees), built
from the one FK path (:class:`calib_pin.robot.kinematics.Kinematics`).

Everything the pipeline, the CLI and the reports need to know about a sensor is asked of
its model: nothing outside :mod:`calib_pin.sensors` and the CSV reader asks "is it a cable
or positions?". A new sensor is a subclass registered in :data:`calib_pin.sensors.SENSORS`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from ..measurements.schema import Schema
from ..robot.chain import Chain
from ..robot.deflection import ComplianceSpec, Deflection
from ..robot.kinematics import Kinematics
from .misreading import METRES_IN_MM_COLUMNS, RADIANS_IN_DEGREE_COLUMNS, Misreading
from .registry import SENSORS
from .setup import SensorSetup, given

#: Sensor noise (1 sigma) assumed when neither the data (``# noise_mm``) nor the caller give it, [mm].
DEFAULT_NOISE_MM = 0.05

if TYPE_CHECKING:
    from ..export.urdf import AddedFrame
    from ..measurements import MeasurementSet
    from ..parameters import ParameterModel
    from .problem import SetProblem


@dataclass(frozen=True)
class NoisePart:
    """A part of a row with a noise of its own (:meth:`MeasurementModel.noise_parts`).

    Attributes:
        name: What the part is (``position``, ``orientation``).
        unit: Its unit for people (``mm``, ``deg``); ``per_si``: that unit per SI unit
            (1000 mm per m, 180/pi deg per rad).
        sigma: Its noise, 1 sigma per entry, SI [m or rad].
        origin: Where sigma came from: ``caller``, ``file``, ``default`` (not stated: it
            is estimated from the residual when the set is calibrated) or ``estimate``.
    """

    name: str
    unit: str
    per_si: float
    sigma: float
    origin: str

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready, the unit in the key: ``{"noise_mm": 0.05, "noise_from": "file"}``."""
        return {f"noise_{self.unit}": self.sigma * self.per_si, "noise_from": self.origin}


#: A sensor set-up given by the caller or the file (a drawstring's anchor, tool point and
#: offset; a contact set's tool point) whose values at the nominal robot miss the readings
#: by more than this (median over the rows) [m] is refused: no kinematic deviation within
#: the sanity bounds (:mod:`calib_pin.parameters.sanity`) moves the tool point that far (1.4 mm on
#: the shipped drawstring set, 0.6 mm on the contact example).
SETUP_MISFIT_M = 0.5
#: At most this many rows, evenly spread over a set, check its set-up (:func:`check_rows`):
#: a gross misfit shows on any 1 000.
CHECK_ROWS = 1000


def check_rows(n_rows: int) -> np.ndarray:
    """The rows of a set of ``n_rows`` that check its set-up.

    At most :data:`CHECK_ROWS`, evenly spread, first and last included.
    """
    return np.unique(np.linspace(0, n_rows - 1, min(n_rows, CHECK_ROWS)).astype(int))


#: The key of a set's sensor options that names the rows its set-up is fitted on, in what a
#: refusal says (:func:`fit_rows_name`): a calibration's ``training rows``, a validation
#: session's ``registration rows``, a cross-validation fold's.
FIT_ROWS_KEY = "fit_rows"


def fit_rows_name(options: Mapping[str, Any]) -> str:
    """What the rows a set-up is fitted on are called (``training rows`` unless the options say)."""
    return str(options.get(FIT_ROWS_KEY) or "training rows")


def refuse_too_few(source: str, n_rows: int, n_values: int, n_unknowns: int, what: str, rows: str,
                   field: str | None = None) -> None:
    """Refuse a set-up pre-fit of ``n_unknowns`` (``what`` they are) on ``n_rows`` rows of
    ``n_values`` values (``rows``: what those rows are called): a least-squares fit needs
    at least as many values as unknowns.

    Raises:
        DataError: naming ``source`` and ``field``.
    """
    from ..exceptions import DataError

    if n_values < n_unknowns:
        raise DataError(source or "the measurement set", f"{n_rows} {rows} give {n_values} values, fewer than the "
                        f"{n_unknowns} set-up unknowns ({what}) to fit on them: give more rows", None, field)


def frame_unknowns(prefix: str, metres: float, radians: float) -> list[tuple[str, str, float]]:
    """The six unknowns (name, unit, typical size) of a frame correction.

    ``PREFIX_x/y/z`` [m], typical ``metres``, then ``PREFIX_rx/ry/rz`` [rad], typical ``radians``.
    """
    return [(f"{prefix}_{a}", "m", metres) for a in "xyz"] + [(f"{prefix}_r{a}", "rad", radians) for a in "xyz"]


def chosen(estimate: Any, valid: tuple[str, ...], sensor: str) -> tuple[str, ...]:
    """The sensor unknowns to estimate, in ``valid``'s order.

    Args:
        estimate: The names asked for: a comma-separated str or a sequence of names.
        valid: The unknowns this sensor can estimate.
        sensor: The sensor's name, for messages.

    Raises:
        ArgumentError: not names, or a name this sensor has no such unknown for.
    """
    from ..exceptions import ArgumentError
    from ..util.arguments import as_names

    names = as_names(estimate, "estimate")
    unknown = set(names) - set(valid)
    if unknown:
        raise ArgumentError("estimate", f"{sensor} cannot estimate {sorted(unknown)[0]!r} (valid: {', '.join(valid)})")
    return tuple(e for e in valid if e in names)


@dataclass(frozen=True)
class SetupExports:
    """What a sensor's calibrated set-up adds to a calibration's outputs (:meth:`MeasurementModel.setup_exports`).

    Attributes:
        frames: Frames fixed to the robot that the calibrated URDF gets as links (a camera, a board).
        files: A file's name ending (``hand_eye.yaml``) -> its text; written as ``<robot>_<ending>``.
    """

    frames: tuple[AddedFrame, ...] = ()
    files: Mapping[str, str] = field(default_factory=dict)


class Draw(Protocol):
    """What a sensor's :meth:`MeasurementModel.simulate_rows` asks of a simulation.

    The seeded draws every simulated set shares (:class:`calib_pin.simulation.SimulationDraw`).
    """

    chain: Chain
    params: ParameterModel
    seed: int
    noise_mm: float
    noise_kind: str
    compliance: ComplianceSpec | None
    setup: dict[str, Any]

    def poses(self, keep: Callable[[np.ndarray], np.ndarray] | None = None, why: str = "",
              batches: int = 50) -> np.ndarray: ...

    def deviations(self, gap: Callable[[np.ndarray], np.ndarray]) -> np.ndarray: ...

    def noise(self, shape: int | tuple[int, ...]) -> np.ndarray: ...

    @property
    def x_model(self) -> np.ndarray: ...


class MeasurementModel(ABC):
    """A sensor's predictions for the robot's deviations, joint compliances and sensor unknowns.

    The three come in that order in one vector x; the compliances only when given.
    With a compliance spec (:mod:`calib_pin.robot.deflection`) every forward kinematics
    runs at the deflected joint angles q_eff = q - c tau(q), and x holds
    ``compliance_<joint>`` [rad/Nm] between the robot's deviations and the sensor's unknowns.

    Attributes:
        chain, params: The robot chain and its parameter model.
        names, units, scale: Of every entry of x (robot deviations first, then the
            compliances, then the sensor's), shape (n_params,): the scale is the typical
            size in SI units.
        n_robot: Number of robot deviations; ``sensor_start``: index of the first sensor unknown.
        deflection: The compliance model, or None.
        schema: What a measurement file of this sensor holds (a
            :class:`~calib_pin.measurements.schema.Schema`); ``kind`` (the measurement-set
            kind this sensor reads, ``MeasurementSet.kind``) and ``data_name`` (what a set
            holds, for people: "drawstring readings") are its, set when the subclass is defined.
        values_per_row: Residual entries one row gives (1 reading, 3 coordinates).
        error_name: What a row's error is, for people ("reading error"); ``value_unit``: its unit.
    """

    schema: ClassVar[Schema]
    kind: ClassVar[str]
    data_name: ClassVar[str]
    values_per_row: ClassVar[int] = 1
    error_name: ClassVar[str] = "error"
    #: What one pose's rows are, for people, and what a row is (a report's error per pose).
    pose_name: ClassVar[str] = "pose"
    row_name: ClassVar[str] = "rows"
    #: The unit of a row's error (:meth:`row_errors`, and the ``*_mm`` fields of its
    #: :class:`~calib_pin.analysis.metrics.Metrics`): ``mm`` unless the sensor says
    #: otherwise (``deg`` for a sensor of angles). Several sets' row errors are pooled
    #: only when every set's unit is the same.
    value_unit: ClassVar[str] = "mm"
    #: The sensor's geometry type (with ``to_dict``/``from_dict``).
    geometry_type: ClassVar[Any]
    #: Names ``--estimate`` accepts for this sensor (empty: fixed by the sensor).
    estimable: ClassVar[tuple[str, ...]] = ()
    #: The sensor's set-up options record (a :class:`~calib_pin.sensors.setup.SensorSetup`).
    setup_type: ClassVar[type[SensorSetup]]
    #: The set-up is fitted on the set's own training rows (what: ``fitted_setup``), so a
    #: set of this sensor cannot be all-test.
    fits_setup: ClassVar[bool] = False
    fitted_setup: ClassVar[str] = ""
    #: What a validation session measured from another placement has moved, for the refusal
    #: of a sensor whose model measures it (``session_frame_shift``): its name, and the hint.
    moved_setup: ClassVar[tuple[str, str]] = ("device frame", "the device was moved between the sessions?")
    #: The usual unit and order mistakes of a set of this sensor, each a reading that
    #: undoes it (:mod:`calib_pin.sensors.misreading`), tried by the pre-fit misfit check.
    misreadings: ClassVar[tuple[Misreading, ...]] = (RADIANS_IN_DEGREE_COLUMNS, METRES_IN_MM_COLUMNS)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A sensor that declares its ``schema`` takes its ``kind`` and ``data_name`` from it."""
        super().__init_subclass__(**kwargs)
        schema = cls.__dict__.get("schema")
        if schema is not None:
            cls.kind, cls.data_name = schema.kind, schema.data_name

    def __init__(self, chain: Chain, params: ParameterModel, extra: list[tuple[str, str, float]],
                 compliance: ComplianceSpec | None = None,
                 cable: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        from ..parameters.base import as_parameter_model

        self._kin = Kinematics(chain)  # refuses anything but a chain, naming it
        self.chain = chain
        self.params = as_parameter_model(params, "params", chain)
        self.n_robot = len(params.names)
        self.compliance_spec = compliance
        self.deflection = None if compliance is None else Deflection(chain, compliance, cable)
        soft = self.deflection
        self.sensor_start = self.n_robot + (soft.n if soft else 0)
        self.names = tuple(params.names) + (soft.names if soft else ()) + tuple(e[0] for e in extra)
        self.units = tuple(params.units) + (soft.units if soft else ()) + tuple(e[1] for e in extra)
        self.scale = np.concatenate([params.scale, soft.scale if soft else [], [e[2] for e in extra]])

    # --- what each sensor implements ---------------------------------------------------

    @classmethod
    def setup_of(cls, data: MeasurementSet) -> SensorSetup | None:
        """The set-up record the set's file gave; None for a set without.

        Default: its ``sensor_meta`` as the record's fields, by name.
        """
        names = set(cls.setup_type.field_names())
        given = {k: v for k, v in data.sensor_meta.items() if k in names}
        return cls.setup_type(**given) if given else None

    @classmethod
    def setup_keys(cls) -> tuple[str, ...]:
        """The set-up values a caller or a file gives in mm (``anchor_mm``, ``tool_mm``, ...)."""
        return tuple(f.name for f in fields(cls.setup_type) if f.metadata.get("unit") == "mm")

    @classmethod
    def stated_noise(cls, data: MeasurementSet, options: Mapping[str, Any]) -> tuple[float, str] | None:
        """A noise the set states in the sensor's own unit (a camera's ``noise_px``): (sigma, origin), or None.

        Sigma as the sensor's values are carried (SI); origin ``caller`` or ``file``.
        Default None: the set's noise is ``# noise_mm`` or the caller's ``noise_mm``.
        """
        return None

    @classmethod
    def usable(cls, data: MeasurementSet) -> MeasurementSet:
        """The rows of ``data`` this sensor can use, as loaded; what it leaves out is named in ``dropped``.

        Default: every row (a camera drops its poses of too few corners).

        Raises:
            DataError: a set this sensor cannot use at all, naming its file.
        """
        return data

    @classmethod
    def planning_model(cls, chain: Chain, params: ParameterModel, setup: SensorSetup | None) -> MeasurementModel:
        """The model poses are planned for (``calib-pin plan-poses``), from the caller's set-up.

        Args:
            chain: The robot chain.
            params: Its parameter model.
            setup: The caller's set-up record; None: the sensor's default.

        Raises:
            CalibPinError: a sensor that cannot plan without data.
        """
        from ..exceptions import CalibPinError

        raise CalibPinError(f"poses cannot be planned for {cls.data_name} without data")

    @classmethod
    def check_same_setup(cls, session: MeasurementSet, training: MeasurementSet, options: Mapping[str, Any]) -> None:
        """Refuse a validation ``session`` whose own set-up contradicts the calibration's.

        The calibration's set-up is ``training``'s, or the caller's overrides in ``options``.
        Default: nothing to refuse (a sensor whose set-up is fitted on the data).

        Args:
            session: The validation session's measurements.
            training: The training set whose set-up it shares.
            options: The caller's sensor options for that set.

        Raises:
            DataError: naming the session's file and the key.
        """
        return None

    @classmethod
    def row_targets(cls, data: MeasurementSet) -> np.ndarray | None:
        """What each row of ``data`` measures, shape (n_rows,): its marker (``point_ids``), or
        None when every row measures the same thing; a sensor of other targets (a contact
        set's fixtures) says so. A validation session's ``register=K`` takes its poses from
        each target in turn (:func:`calib_pin.calibration.validation.registration_rows`)."""
        return None if data.point_ids is None else np.asarray(data.point_ids)

    @classmethod
    def registration_problem(cls, chain: Chain, params: ParameterModel, session: MeasurementSet, rows: np.ndarray,
                             calibrated: MeasurementModel, x: np.ndarray,
                             options: Mapping[str, Any]) -> SetProblem:
        """The problem of a validation ``session`` on a new set-up of this sensor.

        See :mod:`calib_pin.calibration.validation`: every row, the unknowns a new placement
        changes after the robot's, started from their fit on ``rows``. ``calibrated`` and
        ``x``: the calibration's model and estimate (a sensor may take from them what the
        session does not say). Default: :meth:`problem_for` with the caller's compliance
        only (a sensor whose set-up is always fitted, e.g. a device frame and markers).
        """
        return cls.problem_for(chain, params, session, rows, {"compliance": options.get("compliance"),
                                                              FIT_ROWS_KEY: options.get(FIT_ROWS_KEY)})

    @classmethod
    def refuse_foreign(cls, options: Mapping[str, Any], data: MeasurementSet) -> None:
        """Refuse a given set-up option another sensor takes and this one does not.

        Args:
            options: The caller's sensor options.
            data: The measurement set they are given for.

        Raises:
            ArgumentError: naming ``setup``, the option and the data.
        """
        from ..exceptions import ArgumentError
        own = set(cls.setup_type.field_names())
        for other in SENSORS.values():
            for name in other.setup_type.field_names():
                if name not in own and given(options.get(name)):
                    takers = [s.data_name.split()[0] for s in SENSORS.values() if name in s.setup_type.field_names()]
                    raise ArgumentError("setup", f"{name} is for {' and '.join(takers)} data; "
                                        f"{data.source or 'the set'} holds {cls.data_name}")

    @classmethod
    @abstractmethod
    def problem_for(cls, chain: Chain, params: ParameterModel, data: MeasurementSet,
                    fit_rows: np.ndarray, options: Mapping[str, Any]) -> SetProblem:
        """The calibration problem of every row of ``data`` with this sensor.

        Args:
            fit_rows: Rows whose values may be used to fix starting values of the sensor's
                geometry (the training rows: nothing is ever fitted on test rows).
            options: The caller's sensor options (``anchor_mm``, ``tool_mm``,
                ``length_offset_mm``, ``estimate``); one this sensor does not take is refused.

        Raises:
            CalibPinError: a missing or refused option, naming it.
        """

    @abstractmethod
    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Predicted values at joint angles q, shape (n_rows,) or (n_rows, values_per_row), [m].

        q: shape (n_rows, n_joints) [rad]; x None: the nominal robot and sensor. ``points``:
        each row's index of the point measured, for sensors that measure several.
        """

    @abstractmethod
    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray,
                              points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Predicted values (as :meth:`predict`) and their derivative with respect to x.

        The derivative has shape (n_rows, [values_per_row,] n_params), [m per unit of each
        parameter].
        """

    @abstractmethod
    def geometry_at(self, x: np.ndarray | None) -> Any:
        """The sensor's geometry x implies; x None: the starting geometry.

        The starting geometry plus the estimated corrections.
        """

    @abstractmethod
    def geometry_report(self, x: np.ndarray | None) -> dict:
        """The geometry at x for report.json, in mm and degrees."""

    @abstractmethod
    def describe(self) -> str:
        """One phrase for people: the sensor and what of it is known or estimated."""

    # --- noise and errors by part (a row whose parts have noises and units of their own) -

    def noise_parts(self) -> tuple[NoisePart, ...]:
        """The parts of a row that carry a noise of their own, with their sigma and its origin.

        For example a 6-D pose's position and orientation, each with the sigma its entries
        are weighted by and where it came from; () (the default): a row is one part,
        weighted by its set's noise.
        """
        return ()

    def part_residuals(self, x: np.ndarray | None, q: np.ndarray, readings: np.ndarray,
                       points: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """Each of :meth:`noise_parts`' unweighted entries over the rows, flattened, SI [m, rad].

        What its sigma is estimated from (default: none); ``points``: each row's point index.
        """
        return ()

    def part_entries(self, n_rows: int) -> tuple[np.ndarray, ...]:
        """Where each of :meth:`noise_parts`' entries sits among the set's residual entries
        (``n_rows`` rows, flattened), in the order of :meth:`part_residuals`' (default: none)."""
        return ()

    def with_part_noise(self, sigmas: tuple[float, ...], origin: str) -> MeasurementModel:
        """A copy of this model whose parts are weighted by ``sigmas``.

        Args:
            sigmas: One sigma per part, SI [m or rad], in the order of :meth:`noise_parts`.
            origin: Where they came from, e.g. ``estimate``.

        Raises:
            CalibPinError: a sensor whose row is one part (the default).
        """
        from ..exceptions import CalibPinError

        raise CalibPinError(f"{self.data_name}: a row is one part, weighted by its set's noise")

    def errors_by_part(self, x: np.ndarray | None, q: np.ndarray, readings: np.ndarray) -> dict[str, np.ndarray]:
        """Each row's error per part in the part's own unit, each shape (n_rows,).

        The key ends with the unit (``position_mm``, ``orientation_deg``); {} (the default):
        a row is one part, its error the row error in mm.
        """
        return {}

    # --- exports -------------------------------------------------------------------------

    def setup_exports(self, x: np.ndarray, links: tuple[str, str], tag: str = "") -> SetupExports:
        """What the calibrated set-up at x adds to the outputs: frames for the URDF, files; default none.

        Args:
            x: This set's unknowns (robot, then sensor).
            links: The URDF's base link and end frame's link (the frames its files name).
            tag: Appended to the added frames' names to tell several sets' apart ("" for one).
        """
        return SetupExports()

    # --- simulation (the one seam calib_pin.simulation asks a sensor for) ----------------------

    @classmethod
    def simulate_rows(cls, draw: Draw, geometry: Any | None) -> tuple[MeasurementSet, Any]:
        """A simulated set of this sensor read on the true robot.

        Its rows, their values with noise and the set-up metadata its file will carry.
        ``draw`` (a :class:`Draw`: :class:`calib_pin.simulation.SimulationDraw`) holds what every simulation
        shares; call it in this order, as the sensor needs:

        1. ``draw.poses(keep, why)``: the joint angles (n, n_joints) [rad], random within
           the limits (``keep(q)`` a mask of usable ones) or the caller's;
        2. ``draw.deviations(gap)``: the true robot's deviations, drawn and scaled so that
           the nominal model's row errors ``gap(x)`` (n_rows,) [m] have the asked RMSE (or
           the one robot of several sessions);
        3. ``draw.noise(shape)``: the values' noise [m] (``draw.noise_kind``; rows of one value).

        Predict the true values with ``cls(chain, params, geometry, estimate=(),
        compliance=draw.compliance)`` at ``draw.x_model`` (deviations, then the true
        compliances): the truth file's model is built so (:meth:`calib_pin.simulation.simulator.Truth.model`),
        so the sensor's model takes ``estimate=()`` for "nothing of the sensor unknown".
        ``draw.chain``, ``draw.params``, ``draw.seed``, ``draw.noise_mm`` and
        ``draw.noise_kind`` describe the run.

        Args:
            geometry: The true set-up (a :attr:`geometry_type`); None: the sensor's default.

        Returns:
            The set (``kind`` this sensor's) and the true geometry used (for the truth file).

        Raises:
            CalibPinError: a sensor that cannot be simulated (the default).
        """
        from ..exceptions import CalibPinError

        raise CalibPinError(f"{cls.data_name} cannot be simulated (the sensor implements no simulate_rows)")

    @classmethod
    def session_geometry(cls, first: Any, rng: np.random.Generator) -> Any:
        """The true set-up of a later simulated session of this sensor, drawn with ``rng``.

        The sensor is re-anchored, the device moved; ``first`` is session 1's set-up.
        Default: ``first`` itself (one set-up for every session).
        """
        return first

    @property
    def reference_point(self) -> np.ndarray:
        """A point of the end frame the sensor measures, shape (3,), [m].

        The planner keeps it above the mounting plane.
        """
        return np.zeros(3)

    def measured_points(self, x: np.ndarray | None) -> tuple[tuple[str, np.ndarray], ...]:
        """The points of the end frame the sensor measured, at x: (name, point (3,) [m]) each."""
        return (("measured point", self.reference_point),)

    def point_index(self, labels: Any, n_rows: int, source: str = "") -> np.ndarray | None:
        """Indices of the measured points for ``n_rows`` rows labelled ``labels``.

        ``labels`` are a file's ``point_id`` values, numbers or text (None: not given), named
        ``source`` in messages. None for a sensor that measures one point.
        """
        return None

    def grid_points(self, n_poses: int) -> tuple[np.ndarray, np.ndarray | None]:
        """Row repetition and point indices that measure every point once per pose.

        For scoring on fresh poses; the rows are pose-major.
        """
        return np.arange(n_poses), None

    def fresh_difference(self, predicted: np.ndarray, true: np.ndarray) -> np.ndarray:
        """Predicted minus noise-free true values at fresh poses, shaped like ``predicted`` [m].

        Fresh poses as :meth:`grid_points`; as far as the sensor's data can tell them apart:
        the plain difference here; a sensor blind to some motion of everything it measures
        (the base placement, for fixtures located in the base frame) removes it first.
        """
        return predicted - true

    def session_errors(self, x: np.ndarray | None, data: MeasurementSet,
                       correction: Callable[[np.ndarray, np.ndarray | None], np.ndarray] | None = None,
                       ) -> np.ndarray:
        """Each row's error [m] predicting a separate session at x (None: nominal).

        With an optional learnt ``correction(q, points)`` of the values; rows of points this
        model does not know are refused (a sensor that can locate new points overrides this).
        """
        points = self.point_index(data.point_ids, len(data), data.source)
        predicted = self.predict(x, data.q, points)
        if correction is not None:
            predicted = predicted + correction(data.q, points).reshape(predicted.shape)
        return np.linalg.norm((predicted - data.values).reshape(len(data), -1), axis=1)

    # --- shared -----------------------------------------------------------------------

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def nonnegative(self) -> tuple[int, ...]:
        """Indices of the unknowns that must be >= 0: the joint compliances.

        A spring gives way along its load, never against it; every estimator keeps them so.
        The gravity basis's coefficients are signed: none.
        """
        if self.deflection is not None and not self.deflection.nonnegative:
            return ()
        return tuple(range(self.n_robot, self.sensor_start))

    def robot(self, x: np.ndarray) -> np.ndarray:
        """The robot's deviations within x, shape (n_robot,)."""
        return np.asarray(x, dtype=float)[: self.n_robot]

    def sensor_part(self, x: np.ndarray | None) -> np.ndarray:
        """The sensor's unknowns within x, shape (n_params - sensor_start,)."""
        if x is None:
            return np.zeros(self.n_params - self.sensor_start)
        return np.asarray(x, dtype=float)[self.sensor_start :]

    def compliance(self, x: np.ndarray | None) -> np.ndarray:
        """The joint compliances within x, shape (n_compliance,), [rad/Nm]; x None: zero."""
        if x is None:
            return np.zeros(self.sensor_start - self.n_robot)
        return np.asarray(x, dtype=float)[self.n_robot : self.sensor_start]

    def joint_angles(self, x: np.ndarray | None, q: np.ndarray) -> np.ndarray:
        """The arm's joint angles, deflected by x's compliances (none: q itself), [rad]."""
        if self.deflection is None or x is None:
            return q
        return self.deflection.joint_angles(q, self.compliance(x))[0]

    def set_robot(self, x: np.ndarray | None) -> None:
        """Put the robot's deviations of x (None: nominal) on the FK path."""
        self._kin.set_perturbation(None if x is None else self.params.delta_matrices(self.robot(x)))

    def points_at(self, x: np.ndarray | None, q: np.ndarray, point: np.ndarray) -> np.ndarray:
        """Base-frame positions [m] of end-frame points (3,) or (n_rows, 3) at q, for x."""
        self.set_robot(x)
        return self._kin.points(self.joint_angles(x, q), point)[0]

    def predict_many(self, xs: list[np.ndarray], q: np.ndarray, points: np.ndarray | None = None) -> list[np.ndarray]:
        """:meth:`predict` at several x (a search's candidate points), the same numbers to the bit.

        A sensor may batch them (see :meth:`points_at_many`).
        """
        return [self.predict(x, q, points) for x in xs]

    def points_at_many(self, xs: list[np.ndarray] | np.ndarray, q: np.ndarray,
                       points: list[np.ndarray] | np.ndarray) -> np.ndarray | None:
        """:meth:`points_at` at several x in one batched pass, shape (k, n_rows, 3), [m].

        x: a list, or an array (k, n_params). None with joint compliances (the deflected
        angles differ per x: no shared pass).
        """
        if self.deflection is not None:
            return None
        many = getattr(self.params, "delta_matrices_many", None)
        if many is not None and len(xs):  # the parameter model stacks them itself (the same matrices)
            robot = xs[:, : self.n_robot] if isinstance(xs, np.ndarray) else [self.robot(x) for x in xs]
            return self._kin.points_many(many(robot), q, points)
        deltas = [self.params.delta_matrices(self.robot(x)) for x in xs]
        return self._kin.points_many(deltas, q, points)

    def end_frames(self, x: np.ndarray | None, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The end frame's rotations (n_rows, 3, 3) and origins (n_rows, 3) [m] in the base frame.

        At q, for x (None: nominal); no derivatives.
        """
        self.set_robot(x)
        rot, trans, _ = self._kin.frames(self.joint_angles(x, q))
        return rot, trans

    def point_jacobian(self, x: np.ndarray, q: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A point fixed in the end frame and its derivative with respect to x.

        Returns:
            positions: shape (n_rows, 3), [m], base frame.
            jacobian: shape (n_rows, 3, n_params); zero in the sensor's columns.
        """
        points, _, jac = self.points_with_jacobians(x, q, point)
        return points, jac

    def points_with_jacobians(self, x: np.ndarray, q: np.ndarray,
                              point: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`point_jacobian` plus the end-frame rotations, shape (n_rows, 3, 3).

        The rotations are the derivative of each position with respect to the point itself.
        """
        xr = self.robot(x)
        self._kin.set_perturbation(self.params.delta_matrices(xr))
        soft = self.deflection
        if soft is None:
            points, d_place = self._kin.points(q, point, jacobian=True)
        else:  # geometry at the deflected angles; d q_eff / d c_i = -tau_i(q)
            q_eff, minus_tau = soft.joint_angles(q, self.compliance(x))
            points, d_place = self._kin.points(q_eff, point, jacobian=True, joints=True)
        assert d_place is not None
        k = 6 * self.chain.n_joints  # the end frame's linear columns are its rotation
        # One product a pose (one for all poses, as (3 n_rows, k + 6), would take another
        # BLAS kernel for some shapes: other last bits).
        d_robot = d_place[:, :, : k + 6] @ self.params.delta_jacobian(xr)
        if self.n_params == self.n_robot:
            jac = d_robot
        else:
            jac = np.zeros((len(points), 3, self.n_params))
            jac[:, :, : self.n_robot] = d_robot
        if soft is not None:
            d_joint = d_place[:, :, k + 6 + soft.columns]
            jac[:, :, self.n_robot : self.sensor_start] = d_joint * minus_tau[:, None, :]
        return points, d_place[:, :, k : k + 3], jac

"""The calibration pipeline: a robot and a measurement set in, a calibrated robot out.

:func:`prepare` loads the robot, its parameter model and the data; the resulting
:class:`CalibrationSetup` splits the rows, builds the sensor's problem on the training
rows only (nothing is ever fitted on a test row) and runs any estimator
(:meth:`CalibrationSetup.run`); :func:`calibrate` does both.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, cast, overload

import numpy as np

from ..analysis.identifiability import support_error
from ..analysis.metrics import Metrics, check_fraction, split_rows
from ..estimators import DEFAULT_METHOD, get_method, run_estimator
from ..estimators.problem import CalibrationProblem, data_row_errors
from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements import MeasurementSet, read_measurements
from ..measurements.checks import check_measurements, check_same_setup
from ..measurements.load import load_data
from ..parameters import MODELS, ParameterModel, parameter_model
from ..robot import Chain, RobotDescription, load_chain, resolve_robot
from ..robot.deflection import Compliance, as_compliance
from ..sensors import DEFAULT_NOISE_MM, SensorSetup, check_estimate, sensor_for, setup_record
from ..util.arguments import (
    MAX_MM,
    as_choice,
    as_float,
    as_instance,
    as_int,
    as_optional,
    as_path,
    as_robot,
)
from .multiset import (
    MAX_FILTER_NOISE_M,
    FitSet,
    StackedSetup,
    check_sets,
    fit_noise_parts,
    fit_sets,
    labelled,
    mixed_setups_warning,
    set_overrides,
    set_sigma,
)
from .result import CalibrationResult
from .validation import TestSet, as_test_set, same_rows, score_registered, score_session


@dataclass
class CalibrationSetup:
    """A robot, a measurement set and a sensor, ready to be calibrated by any method.

    Attributes:
        chain: The robot chain.
        params: Parameter model of the robot's deviations (``params.name``: dh, ...).
        data: The measurement set.
        noise: Sensor noise (1 sigma) the Kalman filters assume, [m].
        options: Sensor options (``anchor_mm``, ``tool_mm``, ``length_offset_mm``,
            ``estimate``) as the caller gave them, and ``compliance`` (a
            :class:`~calib_pin.robot.deflection.ComplianceSpec` or None).
    """

    chain: Chain
    params: ParameterModel
    data: MeasurementSet
    noise: float
    options: dict[str, Any] = field(default_factory=dict)
    noise_stated: bool = True

    def noise_for(self, method: str, training: Any) -> tuple[float, str]:
        """The noise [m] ``method`` is given on ``training`` and where it came from: the
        stated one (``stated``), or for a method that weighs rows by it (a Kalman filter)
        on a set that states none, the residual's of a first LM fit (``estimated: ...``,
        :mod:`calib_pin.analysis.noise`)."""
        if self.noise_stated or not get_method(method).weighs_noise:
            return self.noise, "stated" if self.noise_stated else "default"
        from ..analysis.noise import noise_from_data

        found = noise_from_data(training)
        if found.sigma > MAX_FILTER_NOISE_M:  # a misfit, not a noise: run_estimator would name its argument
            raise DataError(self.data.source or "the measurement set", f"a first LM fit leaves {found.sigma:.4g} m "
                            f"per value (the noise {method} would assume; at most {MAX_FILTER_NOISE_M:g} m): the "
                            "readings do not fit this robot and sensor set-up (a unit or frame mistake?)")
        return found.sigma, found.words()
    #: Unknowns held at their start (``fix``/``free`` of :func:`prepare`), by name.
    fixed: tuple[str, ...] = ()
    #: Where the estimate starts (``nominal`` of :func:`prepare`); None: zero deviations.
    start: Any = None

    def start_on(self, problem: Any, training: Any) -> tuple[np.ndarray, tuple[int, ...]]:
        """Where an estimate on ``training`` (rows of ``problem``) starts, shape (n_params,),
        SI units (zero deviations, or the robot's own kinematics of ``start``), and the
        indices of the unknowns held there (``fixed``)."""
        # the robot's own kinematics (--nominal), the sensor's geometry as seen by it
        x0 = np.zeros(problem.n_params) if self.start is None else self.start.x0(problem, training)
        return x0, tuple(problem.model.names.index(n) for n in self.fixed)

    def problem_on(self, fit_rows: np.ndarray, reuse: bool = True) -> CalibrationProblem:
        """Every row of the data, with the sensor's starting geometry fitted on ``fit_rows``.
        Fitted on every row (``test_fraction`` 0, a separate test session), it is
        :attr:`problem` when that was made from the same chain, parameter model and data
        (the same objects) and options of equal value (an option changed in place since is
        seen): the same fit, not made twice. ``reuse`` False: fitted anew all the same (a
        benchmark timing the whole fit)."""
        made, inputs = self.__dict__.get("problem"), self.__dict__.get("_problem_inputs")
        if (reuse and made is not None and inputs is not None and _same_inputs(inputs, self._inputs())
                and len(fit_rows) == len(self.data) and np.array_equal(fit_rows, np.arange(len(self.data)))):
            return cast(CalibrationProblem, made)
        return sensor_for(self.data.kind).problem_for(self.chain, self.params, self.data, fit_rows, self.options)

    def _inputs(self) -> tuple[list[Any], dict[str, Any]]:
        """What a problem is made from: the chain, parameter model and data (objects), and a
        copy of the options (values)."""
        return [self.chain, self.params, self.data], copy.deepcopy(dict(self.options))

    @cached_property
    def problem(self) -> CalibrationProblem:
        """Every row, the sensor's starting geometry fitted on all of them (for an
        analysis of the whole set; :meth:`run` fits on the training rows only)."""
        self.__dict__["_problem_inputs"] = self._inputs()
        return self.problem_on(np.arange(len(self.data)))

    def split(self, test_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """Seeded train/test rows, whole poses to each side.

        Raises:
            CalibPinError: bad fraction.
        """
        check_fraction(test_fraction)
        groups = self.data.groups
        poses = np.unique(groups)
        train_poses, _ = split_rows(len(poses), test_fraction, seed)
        in_train = np.isin(groups, poses[train_poses])
        train, test = np.flatnonzero(in_train), np.flatnonzero(~in_train)
        return train, test

    def run(self, method: str = DEFAULT_METHOD, *, seed: int = 0, test_fraction: float = 0.2,
            loss: str = "linear", test_data: MeasurementSet | TestSet | None = None) -> CalibrationResult:
        """Estimate with ``method`` (and ``loss``) on the training rows and score both splits.

        With ``test_data`` (a separate session, a set or its CSV) every row of ``data``
        trains and the test metrics come from ``test_data``; a
        :class:`~calib_pin.calibration.validation.TestSet` says whether the session shares the
        training set's sensor set-up or is re-registered first. Both sets are checked against
        the chain first (:func:`~calib_pin.measurements.checks.check_measurements`).

        Raises:
            CalibPinError: a bad argument (naming it) or a bad set.
        """
        spec = get_method(as_instance(method, "method", str, "a method name (calib_pin.ESTIMATORS)"))
        seed = as_int(seed, "seed", 0)
        test_fraction = check_fraction(test_fraction)
        spec.check(as_instance(loss, "loss", str, "a loss name (linear, huber, soft_l1, cauchy)"), self.data.kind)
        check_measurements(self.chain, self.data)
        session = as_test_set(test_data)
        _check_data(None if session is None else session.data, "test_data")
        if session is not None:
            session = _validation(self, session, "")
            if session.register is not None and not spec.kinematic:
                raise CalibPinError(f"method '{method}' learns a correction of the training set-up's values: a "
                                    "re-registered validation session needs a parameter method (lm, ekf-qibas, ...)")
        warnings = [note for note in (self.data.ignored_note(),) if note]  # extra columns, read past
        if session is None:
            train, test = self.split(test_fraction, seed)
            if test_fraction > 0 and not len(test):
                warnings.append(f"test fraction {test_fraction:g} holds out no pose of {len(self.data)}: "
                                "no test metrics")
        else:
            train, test = np.arange(len(self.data)), np.zeros(0, dtype=int)
        problem = self.problem_on(train)
        training = problem.subset(train)
        if training.n_values < problem.n_params:
            raise DataError(self.data.source, f"{len(train)} training rows give {training.n_values} values, "
                            f"fewer than the {problem.n_params} unknowns to estimate")
        unsupported = support_error(training)  # rank deficiency is normal; a set that calibrates nothing is not
        if unsupported:
            raise DataError(self.data.source, unsupported)
        x0, held = self.start_on(problem, training)
        noise, noise_from = self.noise_for(method, training)
        if any(part.origin == "default" for part in problem.model.noise_parts()):  # a part's noise from the data
            problem, estimate, fits = fit_noise_parts(problem, train, lambda t: run_estimator(
                method, t, x0, seed=seed, noise=t.model.noise_parts()[0].sigma, loss=loss, fixed=held))
            parts = problem.model.noise_parts()
            noise, noise_from = parts[0].sigma, ("stated" if parts[0].origin in ("caller", "file") else
                                                 f"estimated per part from the residual ({fits} fit"
                                                 f"{'s' if fits > 1 else ''}; noise_by_part)")
        else:
            estimate = run_estimator(method, training, x0, seed=seed, noise=noise, loss=loss, fixed=held)
        metrics = {}
        for split, rows in (("train", train), ("test", test)):
            if len(rows):
                part = problem.subset(rows)
                metrics[split] = {"before": Metrics.of(data_row_errors(part, part.residual(x0))),
                                  "after": Metrics.of(data_row_errors(part, estimate.residual(part)))}
        mixed = mixed_setups_warning(self.data, train, metrics["train"]["after"].rmse_mm, noise)
        if mixed:  # several set-ups in one file (its session column says so)
            warnings.append(mixed)
        result = CalibrationResult(
            chain=self.chain, params=self.params, method=method, x=estimate.x, estimate=estimate,
            problem=problem, data=self.data, train=train, test=test, metrics=metrics, seed=seed,
            noise=noise, loss=loss, warnings=tuple(warnings), noise_from=noise_from,
            start=self.start)
        if session is None:
            return result
        if session.register is None:
            return score_session(result, cast(MeasurementSet, session.data))
        return score_registered(result, session, self.options)


def _load_robot(robot: str | RobotDescription, data: str | Path | MeasurementSet | None,
                end_frame: str | None) -> Chain:
    robot = as_robot(robot, "robot")
    description = robot if isinstance(robot, RobotDescription) else resolve_robot(robot)
    if end_frame is None and description.end_frame is None and data is not None:
        # No tool0 in the URDF: the data file may name the end frame.
        end_frame = (data if isinstance(data, MeasurementSet) else read_measurements(data)).end_frame
    return load_chain(description, end_frame)


@overload
def prepare(robot: str | RobotDescription, data: str | Path | MeasurementSet | None = None,
            *, end_frame: str | None = None, anchor_mm: Any = None, tool_mm: Any = None,
            length_offset_mm: float | None = None, noise_mm: Any = None, parameters: str | None = None,
            estimate: tuple[str, ...] = (), compliance: Compliance | str | tuple[str, ...] | None = None,
            payload_kg: float | None = None, payload_com_mm: Any = None,
            cable_tension_n: float | None = None, setup: SensorSetup | None = None,
            fix: Any = None, free: Any = None, nominal: Any = None) -> CalibrationSetup: ...


@overload
def prepare(robot: str | RobotDescription, data: list[Any] | tuple[Any, ...],
            *, end_frame: str | None = None, anchor_mm: Any = None, tool_mm: Any = None,
            length_offset_mm: float | None = None, noise_mm: Any = None, parameters: str | None = None,
            estimate: tuple[str, ...] = (), compliance: Compliance | str | tuple[str, ...] | None = None,
            payload_kg: float | None = None, payload_com_mm: Any = None,
            cable_tension_n: float | None = None, setup: SensorSetup | None = None,
            fix: Any = None, free: Any = None, nominal: Any = None) -> CalibrationSetup | StackedSetup: ...


def prepare(
    robot: str | RobotDescription,
    data: Any = None,
    *,
    end_frame: str | None = None,
    anchor_mm: Any = None,
    tool_mm: Any = None,
    length_offset_mm: float | None = None,
    noise_mm: Any = None,
    parameters: str | None = None,
    estimate: tuple[str, ...] = (),
    compliance: Compliance | str | tuple[str, ...] | None = None,
    payload_kg: float | None = None,
    payload_com_mm: Any = None,
    cable_tension_n: float | None = None,
    setup: SensorSetup | None = None,
    fix: Any = None,
    free: Any = None,
    nominal: Any = None,
) -> CalibrationSetup | StackedSetup:
    """Load a robot and a measurement set for calibration (arguments as :func:`calibrate`).

    With several sets (``data`` a list or tuple of paths, MeasurementSets or
    :class:`~calib_pin.calibration.multiset.FitSet`), a :class:`~calib_pin.calibration.multiset.StackedSetup`;
    a list of one set is that set. ``setup`` (a sensor's set-up record,
    :class:`~calib_pin.sensors.CableSetup`) overrides the file's set-up; the loose
    ``anchor_mm``, ``tool_mm``, ``length_offset_mm`` and ``estimate`` are its shorthand.
    ``fix``/``free``: unknowns held at their start (:mod:`calib_pin.calibration.held`);
    ``nominal``: the start, a robot's own kinematics (:mod:`calib_pin.calibration.start`).

    Raises:
        CalibPinError: any bad input (robot, file, option), with a one-line message.
    """
    estimate = check_estimate(estimate)
    record = as_compliance(compliance, payload_kg=payload_kg, payload_com_mm=payload_com_mm,
                           cable_tension_n=cable_tension_n)
    sensor_setup = setup_record(setup, anchor_mm=anchor_mm, tool_mm=tool_mm, length_offset_mm=length_offset_mm,
                                estimate=estimate)
    sensor_options = sensor_setup.options() if sensor_setup is not None else {}
    sets = fit_sets(data)
    if sets is not None and len(sets) == 1:
        data, noise_mm = _single(sets[0], noise_mm)
        if sets[0].setup is not None:  # the set's own set-up wins over the shared one
            sensor_options = {**sensor_options, **setup_record(sets[0].setup).given()}  # type: ignore[union-attr]
    elif sets is not None:  # several sets
        stacked = _prepare_sets(robot, sets, end_frame=end_frame, sensor_options=sensor_options, noise_mm=noise_mm,
                                parameters=parameters, compliance=record)
        _hold(stacked, fix, free, nominal, record)
        return stacked
    _check_data(data, "data")
    end_frame = as_optional(as_instance, end_frame, "end_frame", str, "an end frame's name")
    noise_mm = as_optional(as_float, noise_mm, "noise_mm", 0.0, MAX_MM, low_open=True, unit="mm")
    parameters = as_optional(as_choice, parameters, "parameters", MODELS)
    chain = _load_robot(robot, data, end_frame)
    parameter_model(chain, parameters)  # a robot that cannot be calibrated says so first
    chain, data = load_data(chain, data, str(robot), end_frame)
    noise = noise_mm * 1e-3 if noise_mm is not None else (data.noise or DEFAULT_NOISE_MM * 1e-3)
    soft = record.spec(chain) if record is not None else None
    prepared = CalibrationSetup(chain, parameter_model(chain, parameters), data, noise,
                                {**sensor_options, "compliance": soft,
                                 **({"noise_mm": noise_mm} if noise_mm is not None else {})},
                                noise_stated=noise_mm is not None or data.noise is not None)
    prepared.problem  # noqa: B018 (refuse options the sensor does not take now; the problem is kept for --analyze)
    if fix is not None or free is not None:
        from .held import held_names

        model = prepared.problem.model
        prepared.fixed = held_names(model.names, model.sensor_start, fix, free)
    if nominal is not None:
        from .start import load_start

        prepared.start = load_start(as_path(nominal, "nominal"), chain, prepared.params, soft.joints if soft else ())
    return prepared


def _hold(stacked: StackedSetup, fix: Any, free: Any, nominal: Any, record: Compliance | None) -> None:
    """``fix``/``free``/``nominal`` of several sets: the robot's unknowns are shared, so a
    robot name holds it for every set; a set's sensor unknown is named as the stacked
    problem names it (``s2:anchor_x``)."""
    model = stacked.problem.model
    if fix is not None or free is not None:
        from .held import held_names

        stacked.fixed = held_names(model.names, model.sensor_start, fix, free)
    if nominal is not None:
        from .start import load_start

        soft = record.spec(stacked.chain) if record is not None else None
        stacked.start = load_start(as_path(nominal, "nominal"), stacked.chain, stacked.params,
                                   soft.joints if soft else ())


def _single(given: FitSet, noise_mm: Any) -> tuple[Any, Any]:
    """The data and noise of a list of one set (its role must be ``split``)."""
    if given.role != "split":
        raise ArgumentError("role", f"'{given.role}' for the only set: use test_fraction (0: all train) or test_data")
    return given.data, given.noise_mm if given.noise_mm is not None else noise_mm


def _prepare_sets(robot: str | RobotDescription, sets: list[FitSet], *, end_frame: str | None,
                  sensor_options: dict[str, Any], noise_mm: Any, parameters: str | None,
                  compliance: Compliance | None) -> StackedSetup:
    """:func:`prepare` of several sets (:mod:`calib_pin.calibration.multiset`); of the sensor options
    only ``estimate`` applies to every set (a set-up override would be one for all)."""
    estimate = sensor_options.get("estimate", ())
    check_sets(sets, {k: v for k, v in sensor_options.items() if k != "estimate"})
    for s in sets:
        _check_data(s.data, "data")
    end_frame = as_optional(as_instance, end_frame, "end_frame", str, "an end frame's name")
    if isinstance(noise_mm, list | tuple):
        if len(noise_mm) != len(sets):
            raise ArgumentError("noise_mm", f"{len(noise_mm)} values for {len(sets)} sets (give one, or one per set)")
        sets = [s if s.noise_mm is not None or n is None else dataclasses.replace(s, noise_mm=n)
                for s, n in zip(sets, noise_mm, strict=True)]
        noise_mm = None
    noise_mm = as_optional(as_float, noise_mm, "noise_mm", 0.0, MAX_MM, low_open=True, unit="mm")
    parameters = as_optional(as_choice, parameters, "parameters", MODELS)
    chain = _load_robot(robot, sets[0].data, end_frame)
    parameter_model(chain, parameters)
    chain, first = load_data(chain, sets[0].data, str(robot), end_frame)
    loaded = [first] + [load_data(chain, s.data, str(robot), chain.end_frame)[1] for s in sets[1:]]
    labels = labelled(sets, loaded)
    known = [set_sigma(s, noise_mm, d) for s, d in zip(sets, loaded, strict=True)]
    soft = compliance.spec(chain) if compliance is not None else None
    stacked = StackedSetup(chain, parameter_model(chain, parameters), tuple(loaded), labels,
                           tuple(s.role for s in sets), tuple(k[0] for k in known), tuple(k[1] for k in known),
                           {"estimate": estimate, "compliance": soft}, set_overrides(sets, loaded, labels))
    stacked.problem  # noqa: B018 (refuse options a sensor does not take now)
    return stacked


def calibrate(
    robot: str | RobotDescription,
    data: str | Path | MeasurementSet | list[Any] | tuple[Any, ...] | None = None,
    *,
    method: str = DEFAULT_METHOD,
    seed: int = 0,
    test_fraction: float = 0.2,
    test_data: str | Path | MeasurementSet | TestSet | None = None,
    end_frame: str | None = None,
    anchor_mm: Any = None,
    tool_mm: Any = None,
    length_offset_mm: float | None = None,
    noise_mm: Any = None,
    loss: str = "linear",
    parameters: str | None = None,
    estimate: tuple[str, ...] = (),
    compliance: Compliance | str | tuple[str, ...] | None = None,
    payload_kg: float | None = None,
    payload_com_mm: Any = None,
    cable_tension_n: float | None = None,
    progress: Callable[[Any], object] | None = None,
    setup: SensorSetup | None = None,
    fix: Any = None,
    free: Any = None,
    nominal: Any = None,
) -> CalibrationResult:
    """Calibrate a robot's kinematic deviations from drawstring readings or positions.

    Args:
        robot: Robot name or URDF path (``irb120``).
        data: Measurement CSV or set (cable readings or marker positions); None uses
            the robot's shipped default set. Several sets (a list of paths, sets or
            :class:`~calib_pin.calibration.multiset.FitSet`) are fitted together, one robot and each
            set's own sensor set-up (its file's), split by pose each, weighted by their
            noise (:mod:`calib_pin.calibration.multiset`); ``result.sets`` scores each.
        method: Estimator name (see ``calib_pin.ESTIMATORS``; default ``ekf-qibas``).
        seed: Seed of the train/test split and of the estimator.
        test_fraction: Share of poses held out for the test metrics.
        test_data: A separate validation session: train on all of ``data``, test on it. A
            :class:`~calib_pin.calibration.validation.TestSet` says its set-up: the training set's
            (checked), or a new one re-registered on its first k poses or its rows with
            ``role`` ``register`` (``result.test_registration`` lists the rows). With
            several sets, ``same`` names the training set whose set-up it shares.
        end_frame: End frame; default the file's ``end_frame`` or the robot's.
        anchor_mm, tool_mm: Override the file's sensor point (base frame) and tool
            point (end frame), 3 numbers each, [mm].
        length_offset_mm: Override the file's sensor zero offset, [mm].
        noise_mm: Sensor noise (1 sigma) [mm] for the Kalman filters; default the
            file's ``noise_mm``, else estimated from the residual of a first LM fit on
            the training rows (:mod:`calib_pin.analysis.noise`; ``result.noise_from``
            says which). With several sets: one for all, or one per set;
            default each file's, else estimated from the residual.
        loss: ``linear``, or a robust loss (``huber``, ``soft_l1``, ``cauchy``).
        parameters: Parameter model: ``dh`` (default with a DH table), ``hayati`` or
            ``placement`` (default without one; any URDF).
        estimate: Drawstring geometry to estimate with the robot: ``anchor``,
            ``offset`` (positions always estimate the device frame and markers).
        compliance: The joints whose compliance [rad/Nm] is estimated with the geometry,
            and their loads: a :class:`~calib_pin.robot.deflection.Compliance` (joints, a
            payload [kg] at [mm] in the end frame, the cable's pull [N]), or joint names as
            shorthand (``"joint_2,joint_3"``, ``"all"``); None: a rigid arm.
        payload_kg, payload_com_mm, cable_tension_n: Deprecated aliases of the record's
            fields (a DeprecationWarning; refused beside a record).
        progress: Called with the prepared setup before the estimation starts.
        setup: The sensor's set-up record (:class:`~calib_pin.sensors.CableSetup`):
            overrides of the file's; ``anchor_mm``, ``tool_mm``, ``length_offset_mm`` and
            ``estimate`` are its shorthand, laid over it.
        fix: Unknowns held at their start (names, or a comma-separated str:
            ``"theta_1,d_1"``, a compliance ``compliance_joint_2``, a sensor unknown).
        free: The robot's deviations and compliances to estimate; the others are held.
        nominal: Start from a robot's own kinematics instead of the catalogue URDF: a
            calib-pin calibration file or a UR ``default_kinematics.yaml``
            (:mod:`calib_pin.calibration.start`); ``result.x`` stays relative to the URDF.

    Raises:
        CalibPinError: any bad input (robot, file, option), with a one-line message; a
            bad argument is an :class:`~calib_pin.exceptions.ArgumentError` naming it.
    """
    get_method(as_instance(method, "method", str, "a method name (calib_pin.ESTIMATORS)")).check(
        as_instance(loss, "loss", str, "a loss name (linear, huber, soft_l1, cauchy)"))
    check_fraction(test_fraction)
    as_int(seed, "seed", 0)
    test = as_test_set(test_data)
    _check_data(None if test is None else test.data, "test_data")
    if progress is not None and not callable(progress):
        raise ArgumentError("progress", f"expected a function of the setup, or None, got {type(progress).__name__}")
    record = as_compliance(compliance, payload_kg=payload_kg, payload_com_mm=payload_com_mm,
                           cable_tension_n=cable_tension_n)
    prepared: CalibrationSetup | StackedSetup = prepare(
        robot, cast(Any, data), end_frame=end_frame, anchor_mm=anchor_mm, tool_mm=tool_mm,
        length_offset_mm=length_offset_mm, noise_mm=noise_mm, parameters=parameters, estimate=estimate,
        compliance=record, setup=setup, fix=fix, free=free, nominal=nominal)
    if isinstance(prepared, StackedSetup):
        validation = None if test is None else prepared.validation(test)
        if progress is not None:
            progress(prepared)
        return prepared.run(method, seed=seed, test_fraction=test_fraction, loss=loss, test_data=validation)
    validation = None if test is None else _validation(prepared, test, str(robot))
    if progress is not None:
        progress(prepared)
    return prepared.run(method, seed=seed, test_fraction=test_fraction, loss=loss, test_data=validation)


def _same_inputs(a: tuple[list[Any], dict[str, Any]], b: tuple[list[Any], dict[str, Any]]) -> bool:
    """The same chain, parameter model and data objects (a field replaced is another) and
    options of equal value (:func:`_equal`)."""
    (objects_a, options_a), (objects_b, options_b) = a, b
    return (len(objects_a) == len(objects_b) and all(x is y for x, y in zip(objects_a, objects_b, strict=True))
            and _equal(options_a, options_b))


def _equal(a: Any, b: Any) -> bool:
    """Equal values, arrays element by element and containers item by item (NaN equal to NaN)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and a.dtype == b.dtype and bool(
            np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    try:
        return bool(a == b) or (a is b)
    except (TypeError, ValueError):
        return a is b


def _check_data(data: Any, arg: str) -> None:
    """``data`` is None, a path or a MeasurementSet."""
    if data is not None and not isinstance(data, (str, Path, MeasurementSet)):
        as_path(data, arg)  # os.PathLike passes; anything else is refused naming ``arg``


def _validation(setup: CalibrationSetup, test: TestSet, robot_label: str) -> TestSet:
    """A separate validation session for ``setup``'s robot (``test`` with its data
    loaded), of the same kind of data; on the same set-up (``test.register`` None) its own
    ``anchor_mm``/``tool_mm``/``length_offset_mm`` must agree
    (:func:`~calib_pin.measurements.checks.check_same_setup`) and ``test.same`` name the
    training set."""
    _, validation = load_data(setup.chain, test.data, robot_label, setup.chain.end_frame)
    if validation.kind != setup.data.kind:
        raise DataError(validation.source, f"holds {validation.kind} data, the calibration set {setup.data.kind} data")
    if test.same:
        names = {Path(setup.data.source).stem, Path(setup.data.source).name} if setup.data.source else set()
        if test.same not in names:
            raise ArgumentError("same", f"'{test.same}' is not the training set (its label: "
                                f"{Path(setup.data.source).stem if setup.data.source else 'none, in memory'})")
    if test.register is None:
        check_same_setup(validation, setup.data, setup.options)
    if same_rows(validation, setup.data):  # its score would be the training fit's, shown as a test
        raise DataError(validation.source or "test_data", "holds the training set's own rows: a validation "
                        "session must be another one (or leave it out to hold out a test fraction)")
    return dataclasses.replace(test, data=validation)

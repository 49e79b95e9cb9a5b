"""The one preparation of a calibration: robot, parameter model and measurement sets, checked once.

:func:`prepare` loads the robot and every measurement set (one set is a list of one),
checks each value where it enters, and returns a :class:`Calibration`: what
:func:`calib_pin.calibration.solve.solve` fits with any method and scores on held-out rows.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements import MeasurementSet, read_measurements
from ..measurements.load import load_data
from ..parameters import MODELS, ParameterModel, model_of
from ..parameters.prior import Prior
from ..robot import Chain, RobotDescription, load_chain, resolve_robot
from ..robot.deflection import Compliance, ComplianceSpec, as_compliance
from ..robot.description import MAX_LIMIT_MARGIN_DEG, as_robot
from ..sensors import DEFAULT_NOISE_MM, SENSORS, SensorSetup, sensor_for, setup_record
from ..sensors.base import FIT_ROWS_KEY
from ..util.arguments import MAX_MM, as_choice, as_float, as_instance, as_optional, as_path, as_xyz_mm
from .holdout import TestSet
from .misfit import check_misfits
from .problem import Problem
from .sets import FitSet, PreparedSet, labelled, refuse_repeats, set_overrides, set_sigma
from .start import Start

#: The problems of this many splits (besides every row's) a calibration keeps for reuse.
KEPT_PROBLEMS = 12


@dataclass(frozen=True)
class Calibration:
    """A robot and its measurement sets, checked and ready to be solved by any method.

    Attributes:
        chain: The robot chain.
        params: Parameter model of the robot's deviations (``params.name``: dh, ...).
        sets: The measurement sets, loaded and checked, each with its label, role, noise
            and sensor options (:class:`~calib_pin.calibration.sets.PreparedSet`).
        compliance: The compliant joints and their loads, or None (a rigid arm).
        fixed: Unknowns held at their start (``fix``/``free`` of :func:`prepare`), by name.
        start: Where the estimate starts (``nominal`` of :func:`prepare`); None: zero deviations.
        prior: What the robot's deviations are like before any measurement: the unit in
            which the robot is kept nearest its start along what the data cannot see
            (:mod:`calib_pin.calibration.gauge`), and the bound of that part of the
            predicted accuracy.
        tcp: The points of the end frame the user works with, each shape (3,), [m] (the
            predicted accuracy is given at them); empty: the measured points, the flange
            origin and a tool the data gives.
    """

    chain: Chain
    params: ParameterModel
    sets: tuple[PreparedSet, ...]
    compliance: ComplianceSpec | None = None
    fixed: tuple[str, ...] = ()
    start: Start | None = None
    prior: Prior = Prior()
    tcp: tuple[np.ndarray, ...] = ()
    _cache: dict[Any, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(s.label for s in self.sets)

    @property
    def kinds(self) -> tuple[str, ...]:
        """The sets' data kinds, each once, in the sets' order."""
        return tuple(dict.fromkeys(s.kind for s in self.sets))

    @property
    def noise(self) -> float:
        """The first set's stated noise [m], else the default (until it is estimated)."""
        return self.sets[0].sigma or DEFAULT_NOISE_MM * 1e-3

    @property
    def offsets(self) -> np.ndarray:
        """Where each set's rows start among :attr:`data`'s, shape (n_sets + 1,)."""
        return np.cumsum([0] + [len(s.data) for s in self.sets])

    @property
    def data(self) -> MeasurementSet:
        """Every set's rows in turn, as one set.

        Of one set, the set itself; of several, pose labels ``<label>:<pose>``, and sets of
        several kinds (rows of different sizes) make one of kind ``<kind>+<kind>`` whose
        ``values`` hold each row's values as an object.
        """
        if len(self.sets) == 1:
            return self.sets[0].data
        made = self._cache.get("data")
        if made is None:
            made = self._cache["data"] = _joined(self.sets, self.kinds)
        return made

    def rows(self, k: int, rows: np.ndarray) -> np.ndarray:
        """Set k's own rows among the calibration's rows ``rows`` (0-based into its data)."""
        lo, hi = self.offsets[k], self.offsets[k + 1]
        rows = np.asarray(rows, dtype=int)
        return rows[(rows >= lo) & (rows < hi)] - lo

    def split(self, test_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """Seeded train/test rows of :attr:`data`, each set by pose (or by its role)."""
        pairs = [s.split(test_fraction, seed) for s in self.sets]
        offsets = self.offsets
        train = np.concatenate([offsets[k] + tr for k, (tr, _) in enumerate(pairs)]).astype(int)
        test = np.concatenate([offsets[k] + te for k, (_, te) in enumerate(pairs)]).astype(int)
        return train, test

    def problem_on(self, fit_rows: np.ndarray, reuse: bool = True, rows: str = "training rows") -> Problem:
        """Every row of every set, each set's starting sensor geometry fitted on ``fit_rows``.

        ``fit_rows`` are rows of :attr:`data`: the training rows; nothing is fitted on a
        test row. Made once for the same rows (every method of a split shares it; the
        last :data:`KEPT_PROBLEMS` splits and every row's are kept); ``reuse`` False: fitted
        anew all the same (a benchmark timing the whole fit). ``rows``: what a refusal calls
        ``fit_rows`` (a cross-validation fold's).
        """
        fit_rows = np.asarray(fit_rows, dtype=int)
        made: dict[bytes, Problem] = self._cache.setdefault("problems", {})
        key = fit_rows.tobytes()
        if reuse and key in made:
            return made[key]
        problems = [sensor_for(s.kind).problem_for(self.chain, self.params, s.data, self.rows(k, fit_rows),
                                                   {**s.options, FIT_ROWS_KEY: rows})
                    for k, s in enumerate(self.sets)]
        problem = Problem.of(problems, self.labels, [s.sigma or self.noise for s in self.sets])
        if reuse:
            every = np.arange(self.offsets[-1]).tobytes()
            for old in [k for k in made if k != every][: max(0, len(made) - KEPT_PROBLEMS)]:
                del made[old]  # the oldest split's, not every row's
            made[key] = problem
        return problem

    @property
    def problem(self) -> Problem:
        """Every row, each sensor's starting geometry fitted on all of its rows.

        For an analysis of the whole data; a solve fits on the training rows only.
        """
        return self.problem_on(np.arange(self.offsets[-1]))

    def start_on(self, problem: Problem, training: Problem) -> tuple[np.ndarray, tuple[int, ...]]:
        """Where an estimate on ``training`` starts, shape (n_params,), SI, and the unknowns held there.

        ``training`` are rows of ``problem``. The start is zero deviations, or the robot's own
        kinematics of ``start`` with each sensor's geometry fitted to it; the held unknowns
        are given by their indices.
        """
        x0 = np.zeros(problem.n_params) if self.start is None else self.start.x0(problem, training)
        return x0, tuple(problem.model.names.index(n) for n in self.fixed)

    def validation(self, test: TestSet) -> tuple[TestSet, int]:
        """A validation session with its data loaded, and the index of the set it relates to.

        That set is the one whose set-up the session shares, or whose sensor re-registers it.

        Args:
            test: The validation session and how its set-up relates to the training sets.

        Raises:
            CalibPinError: a set with role ``test`` beside it, a session of a kind no set
                has, no or a wrong ``same``, a set-up that disagrees with the named set's,
                training rows (a training file again, or rows of one repeated:
                :mod:`calib_pin.calibration.repeats`).
        """
        from .repeats import repeat_error
        from .validation import check_same_setup, choose_training_set

        roles = [s.role for s in self.sets]
        if "test" in roles:
            raise ArgumentError("test_data", f"a validation session beside set {self.labels[roles.index('test')]}, "
                                "whose role is 'test': give the validation session one way, not both")
        _, session = load_data(self.chain, test.data, "", self.chain.end_frame)
        if session.kind in SENSORS:
            session = sensor_for(session.kind).usable(session)
        k = choose_training_set(test, session, self.labels, [s.kind for s in self.sets],
                                [s.data.source for s in self.sets])
        if test.register is None:
            check_same_setup(session, self.sets[k].data, self.sets[k].options)
        for s in self.sets:  # its score would be the training fit's, shown as a test
            twice = repeat_error(s.data, s.label, session, "test_data")
            if twice:
                whose = "the training set's" if len(self.sets) == 1 else f"training set {s.label}'s"
                raise DataError(session.source or "test_data", f"holds {whose} own rows: {twice}; scored as "
                                "held out they would be training rows: a validation session must be another one (or "
                                "leave it out to hold out a test fraction)")
        from dataclasses import replace

        return replace(test, data=session, same=self.labels[k] if test.register is None else ""), k


def _joined(sets: Sequence[PreparedSet], kinds: tuple[str, ...]) -> MeasurementSet:
    """Several sets' rows in turn as one measurement set (:attr:`Calibration.data`)."""
    first = sets[0].data
    lines = [s.data.lines for s in sets]
    points = [s.data.point_ids for s in sets]
    if len(kinds) == 1:
        values = np.concatenate([s.data.values for s in sets])
    else:
        values = np.empty(sum(len(s.data) for s in sets), dtype=object)
        values[:] = [row for s in sets for row in s.data.values]
    return MeasurementSet(
        q=np.concatenate([s.data.q for s in sets]), values=values,
        kind="+".join(kinds), robot=first.robot, end_frame=first.end_frame,
        lines=None if any(x is None for x in lines) else np.concatenate(lines),  # type: ignore[arg-type]
        source=", ".join(s.data.source or s.label for s in sets),
        pose_ids=np.concatenate([np.array([f"{s.label}:{g}" for g in s.data.groups], dtype=object) for s in sets]),
        point_ids=None if any(x is None for x in points) else np.concatenate(points))  # type: ignore[arg-type]


#: Keyword arguments of :func:`prepare` kept for one release with a DeprecationWarning:
#: the sensor set-up's fields (give ``setup=``) and the compliance's loads (give ``compliance=``).
DEPRECATED_SETUP = ("anchor_mm", "tool_mm", "length_offset_mm", "estimate")
DEPRECATED_LOADS = ("payload_kg", "payload_com_mm", "cable_tension_n")


def deprecated_records(loose: dict[str, Any], setup: SensorSetup | None,
                compliance: Any) -> tuple[SensorSetup | None, Compliance | None]:
    """The set-up record and the compliance record, with the deprecated loose keywords laid in.

    Args:
        loose: The deprecated keywords given (:data:`DEPRECATED_SETUP`, :data:`DEPRECATED_LOADS`).
        setup: The sensor set-up record given, or None.
        compliance: The compliance given (a record, joint names, or None).

    Raises:
        ArgumentError: an unknown keyword, a bad value (named), a set-up option or a load
            beside its record.
    """
    unknown = sorted(set(loose) - set(DEPRECATED_SETUP) - set(DEPRECATED_LOADS))
    if unknown:
        raise ArgumentError(unknown[0], "is not an argument of calibrate/prepare (see help(calib_pin.calibrate))")
    from ..sensors.setup import given
    from ..util.deprecation import warn_deprecated

    shorthand = {k: loose[k] for k in DEPRECATED_SETUP if k in loose and given(loose[k])}
    if shorthand and setup is not None:
        raise ArgumentError(next(iter(shorthand)), f"given beside setup={type(setup).__name__}(...): give it once, as "
                            "the record's field")
    record = setup_record(setup, **shorthand)  # a bad value is refused before the warning
    if shorthand:
        warn_deprecated(f"{', '.join(shorthand)} as separate keyword(s) are deprecated: pass setup=calib_pin."
                        "CableSetup(...) (or the record of your sensor)")
    return record, as_compliance(compliance, payload_kg=loose.get("payload_kg"),
                                 payload_com_mm=loose.get("payload_com_mm"),
                                 cable_tension_n=loose.get("cable_tension_n"))


def _load_robot(robot: str | RobotDescription, first: Any, end_frame: str | None,
                limit_margin_deg: float | None = None) -> Chain:
    robot = as_robot(robot, "robot")
    description = robot if isinstance(robot, RobotDescription) else resolve_robot(robot)
    if limit_margin_deg is not None:  # the chain's limits, so every check of an angle takes them
        description = replace(description, limit_margin=float(np.radians(limit_margin_deg)))
    if end_frame is None and description.end_frame is None and first is not None:
        # No tool0 in the URDF: the data file may name the end frame.
        end_frame = (first if isinstance(first, MeasurementSet) else read_measurements(first)).end_frame
    return load_chain(description, end_frame)


def _fit_sets(data: Any) -> list[FitSet]:
    """``data`` as FitSets: None (the robot's shipped set), one set, or a list of them."""
    if isinstance(data, list | tuple):
        if not data:
            raise ArgumentError("data", "an empty list of measurement sets")
        items = list(data)
    else:
        items = [data]
    out = []
    for d in items:
        if isinstance(d, FitSet):
            out.append(d)
        elif d is None or isinstance(d, str | Path | MeasurementSet) or hasattr(d, "__fspath__"):
            out.append(FitSet(d))  # type: ignore[arg-type]  # a path is checked by FitSet
        else:
            raise ArgumentError("data", f"expected a measurement CSV path, a MeasurementSet or a FitSet, got "
                                f"{type(d).__name__}")
    return out


def _noise_of_sets(noise_mm: Any, n: int) -> list[float | None]:
    """``noise_mm`` as one value per set [mm] (None: not given).

    Raises:
        ArgumentError: not a number in (0, 1e6) mm, or a list of another length.
    """
    if isinstance(noise_mm, list | tuple):
        if len(noise_mm) != n:
            raise ArgumentError("noise_mm", f"{len(noise_mm)} values for {n} sets (give one, or one per set)")
        return [as_optional(as_float, v, "noise_mm", 0.0, MAX_MM, low_open=True, unit="mm") for v in noise_mm]
    one = as_optional(as_float, noise_mm, "noise_mm", 0.0, MAX_MM, low_open=True, unit="mm")
    return [one] * n


def _tcp_points(tcp_mm: Any) -> tuple[np.ndarray, ...]:
    """``tcp_mm`` (None, one point (x, y, z) [mm], or a list of them) as points in [m].

    Raises:
        ArgumentError: not points of three finite numbers in mm.
    """
    if tcp_mm is None:
        return ()
    array = np.asarray(tcp_mm, dtype=object)
    many = array.ndim == 2 or (array.ndim == 1 and len(array) and isinstance(array[0], list | tuple | np.ndarray))
    points = list(tcp_mm) if many else [tcp_mm]
    return tuple(as_xyz_mm(p, "tcp_mm") * 1e-3 for p in points)


def _refuse_given_twice(given: list[FitSet], shared: dict[str, Any], noises: list[float | None]) -> None:
    """Refuse a set-up value or noise given both for a set (its FitSet) and for every set
    (``setup`` / ``noise_mm``): one of them would be dropped without a word.

    Raises:
        ArgumentError: naming the field, the set and both values.
    """
    for k, s in enumerate(given):
        own = {name: v for name, v in (s.setup.given() if s.setup is not None else {}).items() if name != "estimate"}
        if s.noise_mm is not None:
            own["noise_mm"] = s.noise_mm
        for name, value in own.items():
            other = noises[k] if name == "noise_mm" else shared.get(name)
            if other is not None:
                data = s.data.source if isinstance(s.data, MeasurementSet) else s.data
                where = s.label or (Path(data).name if data else f"{k + 1}")
                raise ArgumentError(name, f"set {where}: given for the set ({_shown(value)}) and for every set "
                                    f"({_shown(other)}): give one")


def _shown(value: Any) -> str:
    """A set-up value for a message (``600,200,-100``)."""
    return ",".join(f"{v:g}" for v in np.atleast_1d(np.asarray(value, dtype=float)))


def prepare(
    robot: str | RobotDescription,
    data: Any = None,
    *,
    end_frame: str | None = None,
    noise_mm: Any = None,
    parameters: str | None = None,
    setup: SensorSetup | None = None,
    compliance: Compliance | str | Sequence[str] | None = None,
    fix: Any = None,
    free: Any = None,
    nominal: str | Path | None = None,
    prior: Prior | None = None,
    tcp_mm: Any = None,
    limit_margin_deg: float | None = None,
    **deprecated: Any,
) -> Calibration:
    """Load and check a robot and its measurement sets for calibration.

    Args:
        robot: Robot name or URDF path (``irb120``).
        data: A measurement CSV or set, or a list of them (or of
            :class:`~calib_pin.calibration.sets.FitSet`); None: the robot's shipped set.
        end_frame, noise_mm, parameters, setup, compliance, fix, free, nominal, prior, tcp_mm, deprecated: As
            :func:`calib_pin.calibrate` (``noise_mm``: 1 sigma [mm]).
        limit_margin_deg: How far beyond its URDF limits each revolute joint's measured angle
            is accepted, [deg] in [0, 30] (a controller whose limits are wider than its URDF's).

    Raises:
        CalibPinError: any bad input (robot, file, option), with a one-line message; a bad
            argument is an :class:`~calib_pin.exceptions.ArgumentError` naming it.
    """
    setup, record = deprecated_records(deprecated, setup, compliance)
    prior = Prior() if prior is None else as_instance(prior, "prior", Prior, "a calib_pin.Prior")
    tcp = _tcp_points(tcp_mm)
    given = _fit_sets(data)
    end_frame = as_optional(as_instance, end_frame, "end_frame", str, "an end frame's name")
    noises = _noise_of_sets(noise_mm, len(given))
    parameters = as_optional(as_choice, parameters, "parameters", MODELS)
    shared = setup.options() if setup is not None else {}
    estimate = tuple(shared.get("estimate") or ())
    one_for_all = {k: v for k, v in shared.items() if k != "estimate" and v is not None}
    if len(given) > 1 and one_for_all:
        name = next(iter(one_for_all))
        raise ArgumentError(name, f"one value for several sets: put each set's in its file ('# {name}: ...') or its "
                            "FitSet's setup")
    _refuse_given_twice(given, one_for_all, noises)
    margin = as_optional(as_float, limit_margin_deg, "limit_margin_deg", 0.0, MAX_LIMIT_MARGIN_DEG, unit="deg")
    chain = _load_robot(robot, given[0].data, end_frame, margin)
    model_of(chain, parameters)  # a robot that cannot be calibrated says so first (a chain made here: not checked)
    chain, first = load_data(chain, given[0].data, str(robot), end_frame)
    params = model_of(chain, parameters)  # of the set's own end frame
    loaded = [first] + [load_data(chain, s.data, str(robot), chain.end_frame)[1] for s in given[1:]]
    loaded = [sensor_for(d.kind).usable(d) for d in loaded]  # rows a sensor cannot use left out, each named
    labels = labelled(given, loaded)
    soft = record.spec(chain) if record is not None else None
    sets = []
    for s, d, label, noise in zip(given, loaded, labels, noises, strict=True):
        sigma, origin = set_sigma(s, noise, d)
        own, overridden = set_overrides(s, d, label)
        stated = sensor_for(d.kind).stated_noise(d, {**one_for_all, **own}) if sigma is None else None
        if stated is not None:  # a noise in the sensor's own unit (a camera's pixels)
            sigma, origin = stated
        options: dict[str, Any] = {**one_for_all, **own, "estimate": estimate, "compliance": soft}
        if sigma is not None and origin == "caller" and stated is None:
            options["noise_mm"] = sigma * 1e3  # a sensor whose rows have parts reads its own
        sets.append(PreparedSet(d, label, s.role, sigma, origin, options, tuple(own), overridden))
    if all(s.role == "test" for s in sets):
        raise CalibPinError("every set has role 'test': nothing to fit")
    refuse_repeats(sets)  # one measurement in two sets: its rows would be fitted twice
    calibration = Calibration(chain, params, tuple(sets), soft, prior=prior, tcp=tcp)
    problem = calibration.problem  # refuse options a sensor does not take now; kept for --analyze and a full fit
    held: tuple[str, ...] = ()
    if fix is not None or free is not None:
        from .held import held_names

        held = held_names(problem.model.names, problem.model.sensor_start, fix, free)
    start = None
    if nominal is not None:
        from .start import load_start

        start = load_start(as_path(nominal, "nominal"), chain, params, soft.joints if soft else ())
    if held or start is not None:
        calibration = replace(calibration, fixed=held, start=start, _cache=calibration._cache)
    check_misfits(calibration)  # a unit or order mistake, named before any fit
    return calibration

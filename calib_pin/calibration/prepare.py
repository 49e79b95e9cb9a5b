"""The one preparation of a calibration: robot, parameter model and measurement sets, checked once.

:func:`prepare` loads the robot and every measurement set (one set is a list of one),
checks each value where it enters, and returns a :class:`Calibration`: what
:func:`calib_pin.calibration.solve.solve` fits with any method and scores on held-out rows.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements import MeasurementSet, read_measurements
from ..measurements.load import load_data
from ..parameters import MODELS, ParameterModel, model_of
from ..robot import Chain, RobotDescription, load_chain, resolve_robot
from ..robot.deflection import Compliance, ComplianceSpec, as_compliance
from ..robot.description import as_robot
from ..sensors import DEFAULT_NOISE_MM, SensorSetup, sensor_for, setup_record
from ..util.arguments import MAX_MM, as_choice, as_float, as_instance, as_optional, as_path
from .holdout import TestSet
from .problem import Problem
from .sets import FitSet, PreparedSet, labelled, set_overrides, set_sigma
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
    """

    chain: Chain
    params: ParameterModel
    sets: tuple[PreparedSet, ...]
    compliance: ComplianceSpec | None = None
    fixed: tuple[str, ...] = ()
    start: Start | None = None
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

    def problem_on(self, fit_rows: np.ndarray, reuse: bool = True) -> Problem:
        """Every row of every set, each set's starting sensor geometry fitted on ``fit_rows``.

        ``fit_rows`` are rows of :attr:`data`: the training rows; nothing is fitted on a
        test row. Made once for the same rows (every method of a split shares it; the
        last :data:`KEPT_PROBLEMS` splits and every row's are kept); ``reuse`` False: fitted
        anew all the same (a benchmark timing the whole fit).
        """
        fit_rows = np.asarray(fit_rows, dtype=int)
        made: dict[bytes, Problem] = self._cache.setdefault("problems", {})
        key = fit_rows.tobytes()
        if reuse and key in made:
            return made[key]
        problems = [sensor_for(s.kind).problem_for(self.chain, self.params, s.data, self.rows(k, fit_rows), s.options)
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
                the training rows themselves.
        """
        from .validation import check_same_setup, choose_training_set, same_rows

        roles = [s.role for s in self.sets]
        if "test" in roles:
            raise ArgumentError("test_data", f"a validation session beside set {self.labels[roles.index('test')]}, "
                                "whose role is 'test': give the validation session one way, not both")
        _, session = load_data(self.chain, test.data, "", self.chain.end_frame)
        k = choose_training_set(test, session, self.labels, [s.kind for s in self.sets],
                                [s.data.source for s in self.sets])
        if test.register is None:
            check_same_setup(session, self.sets[k].data, self.sets[k].options)
        for s in self.sets:
            if same_rows(session, s.data):  # its score would be the training fit's, shown as a test
                whose = "the training set's" if len(self.sets) == 1 else "a training set's"
                raise DataError(session.source or "test_data", f"holds {whose} own rows: a validation session must "
                                "be another one (or leave it out to hold out a test fraction)")
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


def _load_robot(robot: str | RobotDescription, first: Any, end_frame: str | None) -> Chain:
    robot = as_robot(robot, "robot")
    description = robot if isinstance(robot, RobotDescription) else resolve_robot(robot)
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
    **deprecated: Any,
) -> Calibration:
    """Load and check a robot and its measurement sets for calibration.

    Args:
        robot: Robot name or URDF path (``irb120``).
        data: A measurement CSV or set, or a list of them (or of
            :class:`~calib_pin.calibration.sets.FitSet`); None: the robot's shipped set.
        end_frame, noise_mm, parameters, setup, compliance, fix, free, nominal, deprecated: As
            :func:`calib_pin.calibrate` (``noise_mm``: 1 sigma [mm]).

    Raises:
        CalibPinError: any bad input (robot, file, option), with a one-line message; a bad
            argument is an :class:`~calib_pin.exceptions.ArgumentError` naming it.
    """
    setup, record = deprecated_records(deprecated, setup, compliance)
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
    chain = _load_robot(robot, given[0].data, end_frame)
    model_of(chain, parameters)  # a robot that cannot be calibrated says so first (a chain made here: not checked)
    chain, first = load_data(chain, given[0].data, str(robot), end_frame)
    params = model_of(chain, parameters)  # of the set's own end frame
    loaded = [first] + [load_data(chain, s.data, str(robot), chain.end_frame)[1] for s in given[1:]]
    labels = labelled(given, loaded)
    soft = record.spec(chain) if record is not None else None
    sets = []
    for s, d, label, noise in zip(given, loaded, labels, noises, strict=True):
        sigma, origin = set_sigma(s, noise, d)
        own, overridden = set_overrides(s, d, label)
        options: dict[str, Any] = {**one_for_all, **own, "estimate": estimate, "compliance": soft}
        if sigma is not None and origin == "caller":
            options["noise_mm"] = sigma * 1e3  # a sensor whose rows have parts reads its own
        sets.append(PreparedSet(d, label, s.role, sigma, origin, options, tuple(own), overridden))
    if all(s.role == "test" for s in sets):
        raise CalibPinError("every set has role 'test': nothing to fit")
    calibration = Calibration(chain, params, tuple(sets), soft)
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
        from dataclasses import replace

        calibration = replace(calibration, fixed=held, start=start, _cache=calibration._cache)
    return calibration

"""Several measurement sets of one robot in one calibration: the set-up and the run.

Each set keeps its own sensor set-up (its file's anchor, tool point and cable offset, or
a device frame and markers fitted on that set's own training rows), its own split and its
own noise sigma_k. The fit is one :class:`~calib_pin.calibration.problem.StackedProblem` of the
training rows of every set, set k's rows weighted by sigma_0 / sigma_k.

sigma_k comes from the caller (:class:`FitSet`'s ``noise_mm``, or ``noise_mm`` for all
sets), else from the set's file (``# noise_mm``); a set with neither gets it from the
data by variance-component estimation: fit, then

    sigma_k^2 = r_k . r_k / (n_k - p_k),    p_k = rank * n_k / N,

(r_k: set k's training residual, n_k its values, N every set's, rank: the identifiable
directions of the stacked training Jacobian, shared out by each set's share of the
values), refit with the new weights, until no sigma moves by more than 1 % (at most
:data:`MAX_VCE_FITS` fits; :func:`variance_components`, which also estimates the parts of
one set's rows that have noises of their own, :func:`fit_noise_parts`). The report gives
each set's sigma and where it came from.

The split is made per set, by pose, with the same seed and fraction for every set
(``role="split"``); a set may instead be all training (``train``) or all test (``test``:
scored, never fitted; a drawstring set only, its anchor as its file or its FitSet's ``setup`` gives it).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.identifiability import support_error
from ..analysis.metrics import Metrics, check_fraction, pooled_unit, split_rows, units_words
from ..estimators import get_method, run_estimator
from ..estimators.problem import CalibrationProblem, data_row_errors
from ..estimators.subspace import Subspace
from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements import MeasurementSet
from ..measurements.checks import check_measurements
from ..parameters import ParameterModel
from ..report.build import part_report
from ..robot import Chain
from ..sensors import DEFAULT_NOISE_MM, SensorSetup, sensor_for
from ..sensors.setup import given as given_value
from ..util.arguments import MAX_MM, as_choice, as_float, as_instance
from .problem import StackedProblem
from .result import CalibrationResult

#: A set's role: split by pose (default), all training rows, or all test rows.
ROLES = ("split", "train", "test")

#: At most this many fits of the variance-component estimation.
MAX_VCE_FITS = 5

#: The largest noise [m] a Kalman filter takes (``run_estimator``'s ``noise``): an estimate
#: beyond it is a misfit of the data, refused naming the data (not the argument).
MAX_FILTER_NOISE_M = 1.0

#: The estimation stops when no sigma moves by more than this (relative).
VCE_TOLERANCE = 0.01


@dataclass(frozen=True)
class FitSet:
    """One measurement set of a multi-set calibration, with what the caller says of it.

    Attributes:
        data: A measurement CSV or a :class:`~calib_pin.measurements.MeasurementSet`.
        label: Its name in reports and unknowns (``s2:anchor_x``); default the file's stem.
        role: ``split`` (train/test by pose, the default), ``train`` or ``test``.
        noise_mm: Its sensor noise (1 sigma) [mm]; default the file's ``noise_mm``, else
            estimated from the residual (several sets) or 0.05.
        setup: Its sensor set-up overrides, a record of its sensor kind
            (:class:`~calib_pin.sensors.CableSetup`): each field given wins over the file's
            metadata (``estimate`` is one for all sets: give it to ``calibrate``).
    """

    data: str | Path | MeasurementSet
    label: str = ""
    role: str = "split"
    noise_mm: float | None = None
    setup: SensorSetup | None = None


@dataclass(frozen=True)
class SetResult:
    """One set of a multi-set calibration.

    Attributes:
        label, source, kind, role: The set's label, file ("" in memory), data kind and role.
        sigma: The noise (1 sigma) its rows were weighted by, [m]; ``sigma_origin``:
            ``caller``, ``file``, ``estimate`` (from the residual) or ``default``.
        rows: Its rows in the stacked problem (``result.train``/``result.test`` index those).
        train, test: Its own row indices (0-based, into its data) of the two splits.
        metrics: ``metrics[split][stage]`` as ``CalibrationResult.metrics``, in its own units [mm].
        geometry: Its sensor geometry after calibration, for report.json (mm, degrees).
        model: Its measurement model; ``x``: its own unknown vector (robot, then its sensor's).
        overrides: The set-up fields the caller gave for this set (its FitSet's ``setup``),
            each winning over its file's; ``overridden``: those of them the file also had.
    """

    label: str
    source: str
    kind: str
    role: str
    sigma: float
    sigma_origin: str
    rows: np.ndarray
    train: np.ndarray
    test: np.ndarray
    metrics: dict[str, dict[str, Metrics]]
    geometry: dict
    model: Any = field(repr=False)
    x: np.ndarray = field(repr=False)
    overrides: tuple[str, ...] = ()
    overridden: tuple[str, ...] = ()
    #: The unit of its row errors and metrics (its sensor's ``value_unit``).
    unit: str = "mm"

    def predict(self, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """The values this set's sensor would read at joint angles q (n, n_joints) [rad], [m]."""
        return self.model.predict(self.x, np.atleast_2d(np.asarray(q, dtype=float)), points)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: the set's table and set-up."""
        return {
            "label": self.label, "data": self.source, "data_kind": self.kind, "role": self.role,
            "noise_mm": self.sigma * 1e3, "noise_from": self.sigma_origin,
            "train_rows": len(self.train), "test_rows": len(self.test),
            **{split: {stage: m.as_dict() for stage, m in stages.items()} for split, stages in self.metrics.items()},
            "error": self.model.error_name, "error_unit": self.unit, "sensor": self.model.describe(), **self.geometry,
            "setup_from_caller": list(self.overrides), "setup_over_file": list(self.overridden),
        }


def fit_sets(data: Any) -> list[FitSet] | None:
    """``data`` as FitSets when it is a list or tuple of several sets (None otherwise)."""
    if not isinstance(data, list | tuple):
        return None
    if not data:
        raise ArgumentError("data", "an empty list of measurement sets")
    return [d if isinstance(d, FitSet) else FitSet(d) for d in data]


@dataclass
class StackedSetup:
    """A robot and several measurement sets, ready to be calibrated by any parameter method.

    Attributes:
        chain, params: The robot and its parameter model (shared by every set).
        sets: The measurement sets; ``labels``, ``roles``: theirs.
        sigmas: Each set's noise [m] when known (caller or file), else None.
        origins: Where each known sigma came from (``caller``, ``file``), else ``estimate``.
        options: Shared sensor options (``estimate``, ``compliance``).
        setups: Each set's own set-up overrides (field -> value, laid over ``options``
            and over its file's metadata); empty: none for any set.
    """

    chain: Chain
    params: ParameterModel
    sets: tuple[MeasurementSet, ...]
    labels: tuple[str, ...]
    roles: tuple[str, ...]
    sigmas: tuple[float | None, ...]
    origins: tuple[str, ...]
    options: dict[str, Any] = field(default_factory=dict)
    setups: tuple[dict[str, Any], ...] = ()
    #: Unknowns held at their start (``fix``/``free`` of :func:`~calib_pin.calibration.pipeline.prepare`),
    #: by stacked name: the robot's shared ones, a set's sensor ones prefixed ``<label>:``.
    fixed: tuple[str, ...] = ()
    #: Where the estimate starts (``nominal``, :mod:`calib_pin.calibration.start`); None: zero deviations.
    start: Any = None

    @property
    def noise(self) -> float:
        """The first set's sigma (the Kalman filters' noise; the default until estimated) [m]."""
        return self.sigmas[0] or DEFAULT_NOISE_MM * 1e-3

    @property
    def kinds(self) -> tuple[str, ...]:
        """The sets' data kinds, each once, in the sets' order."""
        return tuple(dict.fromkeys(s.kind for s in self.sets))

    @cached_property
    def data(self) -> MeasurementSet:
        """Every set's rows in turn, as one set (pose labels ``<label>:<pose>``). Sets of
        several kinds (rows of different sizes) make one of kind ``<kind>+<kind>`` whose
        ``values`` hold each row's values as an object, shape (n_rows,) (each set's own
        values are in ``sets``)."""
        first = self.sets[0]
        lines = [s.lines for s in self.sets]
        points = [s.point_ids for s in self.sets]
        if len(self.kinds) == 1:
            values = np.concatenate([s.values for s in self.sets])
        else:
            values = np.empty(sum(len(s) for s in self.sets), dtype=object)
            values[:] = [row for s in self.sets for row in s.values]
        return MeasurementSet(
            q=np.concatenate([s.q for s in self.sets]), values=values,
            kind="+".join(self.kinds), robot=first.robot, end_frame=first.end_frame,
            lines=None if any(x is None for x in lines) else np.concatenate(lines),  # type: ignore[arg-type]
            source=", ".join(s.source or label for s, label in zip(self.sets, self.labels, strict=True)),
            pose_ids=np.concatenate([np.array([f"{label}:{g}" for g in s.groups], dtype=object)
                                     for s, label in zip(self.sets, self.labels, strict=True)]),
            point_ids=None if any(x is None for x in points) else np.concatenate(points))  # type: ignore[arg-type]

    def overridden(self, k: int) -> tuple[str, ...]:
        """Set k's overrides that its file's metadata also gave."""
        if not self.setups:
            return ()
        filed = sensor_for(self.sets[k].kind).setup_of(self.sets[k])
        had = {n for n, v in (filed.options() if filed is not None else {}).items() if given_value(v)}
        return tuple(n for n in self.setups[k] if n in had)

    def split(self, test_fraction: float, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each set's (train, test) rows: by pose with the same seed and fraction, or all
        of one side by its role."""
        check_fraction(test_fraction)
        out = []
        for data, role in zip(self.sets, self.roles, strict=True):
            every = np.arange(len(data))
            if role == "train":
                out.append((every, every[:0]))
            elif role == "test":
                out.append((every[:0], every))
            else:
                poses = np.unique(data.groups)
                train_poses, _ = split_rows(len(poses), test_fraction, seed)
                in_train = np.isin(data.groups, poses[train_poses])
                out.append((np.flatnonzero(in_train), np.flatnonzero(~in_train)))
        return out

    def problems_on(self, fits: list[np.ndarray]) -> list[CalibrationProblem]:
        """Each set's problem of every row, its sensor's starting geometry fitted on its ``fits`` rows."""
        own = self.setups or tuple({} for _ in self.sets)
        return [sensor_for(d.kind).problem_for(self.chain, self.params, d, rows, {**self.options, **given})
                for d, rows, given in zip(self.sets, fits, own, strict=True)]

    @cached_property
    def problem(self) -> StackedProblem:
        """Every row of every set, each sensor's start fitted on all its rows (for an analysis)."""
        problems = self.problems_on([np.arange(len(d)) for d in self.sets])
        return StackedProblem.of(problems, self.labels, [s or self.noise for s in self.sigmas])

    def run(self, method: str, *, seed: int = 0, test_fraction: float = 0.2, loss: str = "linear",
            test_data: Any = None) -> CalibrationResult:
        """Estimate with ``method`` on every set's training rows; score each set and all.

        With ``test_data`` (a separate validation session, :meth:`validation`) every row of
        every set trains and the ``test`` metrics are the session's: scored with the named
        set's set-up, or re-registered (:class:`~calib_pin.calibration.validation.TestSet`).

        Raises:
            CalibPinError: a method that learns no kinematics, a bad validation session,
                too few training rows.
        """
        spec = get_method(as_instance(method, "method", str, "a method name (calib_pin.ESTIMATORS)"))
        if not spec.kinematic:
            raise CalibPinError(f"method '{method}' learns a correction of one sensor set-up's readings, not the "
                                "robot: with several sets (each its own set-up) it would be one correction per set, "
                                "valid for none of the others nor for a new one; use a parameter method (lm, "
                                "ekf-qibas, ...), or give it one --data")
        for kind in self.kinds:
            spec.check(loss, kind)
        for d in self.sets:
            check_measurements(self.chain, d)
        session = None if test_data is None else self.validation(test_data)
        if session is None:
            splits = self.split(test_fraction, seed)
        else:  # every row of every set trains; the validation session is the test
            splits = [(np.arange(len(d)), np.zeros(0, dtype=int)) for d in self.sets]
        warnings = [note for note in (d.ignored_note() for d in self.sets) if note]
        problems = self.problems_on([train for train, _ in splits])
        offsets = np.cumsum([0] + [len(d) for d in self.sets])
        train = np.concatenate([offsets[k] + tr for k, (tr, _) in enumerate(splits)]).astype(int)
        test = np.concatenate([offsets[k] + te for k, (_, te) in enumerate(splits)]).astype(int)
        if not len(train):
            raise CalibPinError("every set has role 'test': nothing to fit")
        sigmas = [s if s is not None else self.noise for s in self.sigmas]
        full = StackedProblem.of(problems, self.labels, sigmas)
        training = full.subset(train)
        if training.n_values < full.n_params:
            raise DataError(self.data.source, f"{len(train)} training rows give {training.n_values} values, "
                            f"fewer than the {full.n_params} unknowns to estimate")
        unsupported = support_error(training)
        if unsupported:
            raise DataError(self.data.source, unsupported)
        # the robot's own kinematics (--nominal), shared by every set; each set's geometry as seen by it
        x0 = np.zeros(full.n_params) if self.start is None else self.start.x0(full, full.subset(train))
        held = tuple(full.model.names.index(n) for n in self.fixed)
        estimate, sigmas, fits = self._fit(method, full, train, sigmas, x0, seed, loss, held)
        full = full.with_weights(sigmas)
        if fits > 1:
            guessed = [label for label, o in zip(self.labels, self.origins, strict=True) if o == "estimate"]
            warnings.append(f"noise of {', '.join(guessed)} estimated from the residual ({fits} fits)")
        results: list[SetResult] = []
        pooled: dict[str, dict[str, list[np.ndarray]]] = {}
        for k, ((tr, te), problem) in enumerate(zip(splits, problems, strict=True)):
            xk = full.model.part_x(estimate.x, k)
            zero = full.model.part_x(x0, k)  # the start: zero deviations, or --nominal's
            metrics: dict[str, dict[str, Metrics]] = {}
            for split, rows in (("train", tr), ("test", te)):
                if len(rows):
                    part = problem.subset(rows)
                    before = data_row_errors(part, part.residual(zero))  # touches only, not known distances
                    after = data_row_errors(part, part.residual(xk))
                    metrics[split] = {"before": Metrics.of(before), "after": Metrics.of(after)}
                    pooled.setdefault(split, {"before": [], "after": []})
                    pooled[split]["before"].append(before)
                    pooled[split]["after"].append(after)
            origin = self.origins[k] if self.sigmas[k] is not None else ("estimate" if fits > 1 else "default")
            if "train" in metrics:
                mixed = mixed_setups_warning(self.sets[k], tr, metrics["train"]["after"].rmse_mm, float(sigmas[k]))
                warnings += [mixed] if mixed else []
            results.append(SetResult(
                label=self.labels[k], source=self.sets[k].source, kind=self.sets[k].kind, role=self.roles[k],
                sigma=float(sigmas[k]), sigma_origin=origin, rows=np.arange(offsets[k], offsets[k + 1]),
                train=tr, test=te, metrics=metrics, geometry={**problem.model.geometry_report(xk), **part_report(
                    problem, xk, {"train": tr, "test": te}, noise=False)},
                model=problem.model, x=np.asarray(xk), overrides=tuple(self.setups[k]) if self.setups else (),
                overridden=self.overridden(k), unit=value_unit(problem.model)))
        metrics = {split: {stage: Metrics.of(np.concatenate(v)) for stage, v in stages.items()}
                   for split, stages in pooled.items()}
        if pooled_unit(results) is None:  # errors in mm and in degrees are no one RMSE
            metrics = {}
            warnings.append(f"no all-sets table: {units_words(results)}; each set's table is in its own units")
        result = CalibrationResult(
            chain=self.chain, params=self.params, method=method, x=estimate.x, estimate=estimate,
            problem=full, data=self.data, train=train, test=test, metrics=metrics, seed=seed,
            noise=float(sigmas[0]), loss=loss, warnings=tuple(warnings), sets=tuple(results), start=self.start)
        return result if session is None else self._validated(result, session, problems)

    def validation(self, test_data: Any) -> Any:
        """The validation session of ``test_data`` (a path, a set or a
        :class:`~calib_pin.calibration.validation.TestSet`) with its data loaded and the training set
        whose set-up it shares chosen (:func:`~calib_pin.calibration.validation.choose_training_set`).

        Raises:
            CalibPinError: a set with role ``test`` beside it, a session of a kind no set
                has, no or a wrong ``same``, a set-up that disagrees with the named set's.
        """
        from ..measurements.checks import check_same_setup
        from ..measurements.load import load_data
        from .validation import as_test_set, choose_training_set, same_rows

        test = as_test_set(test_data)
        assert test is not None
        if "test" in self.roles:
            label = self.labels[self.roles.index("test")]
            raise CalibPinError(f"test_data and set {label} with role 'test': give the validation session one way "
                                "(--test-data, or a --data set with role=test)")
        _, session = load_data(self.chain, test.data, "", self.chain.end_frame)
        k = choose_training_set(test, session, self.labels, [d.kind for d in self.sets], [d.source for d in self.sets])
        if test.register is None:
            check_same_setup(session, self.sets[k], {**self.options, **(self.setups[k] if self.setups else {})})
        for d in self.sets:
            if same_rows(session, d):
                raise DataError(session.source or "test_data", "holds a training set's own rows: a validation "
                                "session must be another one")
        return dataclasses.replace(test, data=session, same=self.labels[k] if test.register is None else "")

    def _validated(self, result: CalibrationResult, test: Any, problems: list[CalibrationProblem]) -> CalibrationResult:
        """``result`` with its ``test`` metrics from the validation session ``test``: scored
        with the named set's set-up (its sensor geometry as calibrated), or re-registered on
        its stated rows with the calibrated robot fixed (the first set of its kind lends the
        sensor's model, :func:`~calib_pin.calibration.validation.register_session`)."""
        from .validation import score_registered, score_session

        kinds = [d.kind for d in self.sets]
        k = self.labels.index(test.same) if test.register is None else kinds.index(test.data.kind)
        model: Any = result.problem.model
        view = dataclasses.replace(result, problem=problems[k], x=np.asarray(model.part_x(result.x, k)), sets=())
        if test.register is None:
            scored = score_session(view, test.data)
            info: dict[str, Any] = {"data": test.data.source, "setup": "same", "same_as": test.same}
        else:
            scored = score_registered(view, test, self.options)
            info = {**(scored.test_registration or {}), "sensor_model_of": self.labels[k]}
        return dataclasses.replace(result, metrics={**result.metrics, "test": scored.metrics["test"]},
                                   test_source=scored.test_source, test_registration=info,
                                   warnings=scored.warnings)

    def _fit(self, method: str, full: StackedProblem, train: np.ndarray, sigmas: list[float], x0: np.ndarray,
             seed: int, loss: str, held: tuple[int, ...] = ()) -> tuple[Any, list[float], int]:
        """The estimate, each set's sigma [m] and the fits it took (variance components,
        module docstring, for the sets whose sigma is not known)."""
        unknown = [k for k, s in enumerate(self.sigmas) if s is None] if len(self.sets) > 1 else []

        def fit(now: list[float]) -> tuple[Any, Any]:
            misfit = [k for k in unknown if now[k] > MAX_FILTER_NOISE_M]
            if misfit:  # a misfit, not a noise (run_estimator would name its argument): the worst set named
                k = max(misfit, key=lambda j: now[j])
                others = [self.labels[j] for j in misfit if j != k]
                raise DataError(self.sets[k].source or self.labels[k], f"the fit leaves {now[k]:.4g} m per value "
                                f"(this set's estimated noise; at most {MAX_FILTER_NOISE_M:g} m"
                                + (f"; also {', '.join(others)}" if others else "") + "): its readings do not fit "
                                "this robot and sensor set-up, or not the other sets' (a unit or frame mistake?)")
            training = full.with_weights(now).subset(train)
            return run_estimator(method, training, x0, seed=seed, noise=now[0], loss=loss, fixed=held), training

        def residuals(estimate: Any, training: Any) -> dict[int, np.ndarray]:
            return {k: part.residual(full.model.part_x(estimate.x, k))
                    for part, k in zip(training.parts, training.sets, strict=True)}

        return variance_components(fit, residuals, sigmas, unknown)


def variance_components(fit: Callable[[list[float]], tuple[Any, Any]],
                        residuals: Callable[[Any, Any], Mapping[int, np.ndarray]], sigmas: list[float],
                        unknown: Sequence[int]) -> tuple[Any, list[float], int]:
    """Variance-component estimation (module docstring): ``fit(sigmas)`` -> (estimate, its
    training problem), then each ``unknown`` component's sigma_k^2 = r_k . r_k / (n_k - p_k)
    from ``residuals(estimate, training)`` (component -> its unweighted entries r_k, in its
    own unit), refit, until no sigma moves by more than :data:`VCE_TOLERANCE` (at most
    :data:`MAX_VCE_FITS` fits). The components are a multi-set fit's sets, or one set's
    parts with a noise of their own (:func:`fit_noise_parts`).

    Returns:
        The last estimate, every component's sigma and the fits it took.
    """
    fits = 0
    while True:
        estimate, training = fit(sigmas)
        fits += 1
        if not unknown or fits >= MAX_VCE_FITS:
            return estimate, sigmas, fits
        rank = Subspace.of_problem(training, estimate.x).rank
        n_total = training.n_values
        new = list(sigmas)
        for k, r in residuals(estimate, training).items():
            if k in unknown:
                dof = r.size - rank * r.size / n_total
                if dof > 0 and r @ r > 0:
                    new[k] = float(np.sqrt(r @ r / dof))
        moved = max(abs(new[k] / sigmas[k] - 1.0) for k in unknown)
        sigmas = new
        if moved < VCE_TOLERANCE:
            return estimate, sigmas, fits


def fit_noise_parts(problem: CalibrationProblem, train: np.ndarray,
                    run: Callable[[CalibrationProblem], Any]) -> tuple[CalibrationProblem, Any, int]:
    """Fit one set whose rows have parts with noises of their own (a 6-D pose's position
    and orientation, :meth:`~calib_pin.sensors.base.MeasurementModel.noise_parts`), each
    part's unstated sigma estimated from its residual by :func:`variance_components`
    (``run(training)``: the estimate on a training problem).

    Returns:
        The problem of every row weighted by the sigmas found, the estimate and the fits it took.
    """
    parts = problem.model.noise_parts()
    unknown = [k for k, part in enumerate(parts) if part.origin == "default"]

    def weighted(now: list[float]) -> CalibrationProblem:
        return problem if not unknown else replace(problem, model=problem.model.with_part_noise(tuple(now), "estimate"))

    def fit(now: list[float]) -> tuple[Any, Any]:
        training = weighted(now).subset(train)
        return run(training), training

    def residuals(estimate: Any, training: Any) -> dict[int, np.ndarray]:
        return dict(enumerate(training.model.part_residuals(estimate.x, training.q, training.readings)))

    estimate, sigmas, fits = variance_components(fit, residuals, [part.sigma for part in parts], unknown)
    return weighted(sigmas), estimate, fits


def value_unit(model: Any) -> str:
    """The unit of a measurement model's row errors (its sensor's ``value_unit``, default mm)."""
    return str(getattr(model, "value_unit", "mm"))




#: A set whose training RMSE after the fit exceeds this many noise sigmas, and whose rows a
#: column of :data:`SETUP_COLUMNS` assigns to several set-ups, gets a warning naming them.
SETUP_SIGMAS = 5.0

#: Columns (a file's extra columns) that say which sensor set-up a row was measured with.
SETUP_COLUMNS = ("session", "setup", "station")


def mixed_setups_warning(data: MeasurementSet, train: np.ndarray, after_rmse_mm: float, sigma: float) -> str | None:
    """The warning for a set fitted as one sensor set-up whose own column says its training
    rows come from several (``session`` A, B, C: three anchors in one file), when the fit
    leaves more than SETUP_SIGMAS x its noise ``sigma`` [m]; else None. Cheap: nothing is
    computed unless the set has such a column."""
    for name in SETUP_COLUMNS:
        column = data.extra.get(name)
        if column is None or after_rmse_mm <= SETUP_SIGMAS * sigma * 1e3:
            continue
        setups = sorted({str(v) for v in np.asarray(column, dtype=object)[train]})
        if len(setups) > 1:
            shown = ", ".join(setups[:6]) + (", ..." if len(setups) > 6 else "")
            return (f"{Path(data.source).name if data.source else 'the set'}: its '{name}' column names "
                    f"{len(setups)} set-ups ({shown}) fitted here as one (train RMSE {after_rmse_mm:.3g} mm, "
                    f"{after_rmse_mm / (sigma * 1e3):.0f} x the noise {sigma * 1e3:.3g} mm): give each set-up its "
                    "own file with its own metadata and pass them together (--data a.csv --data b.csv)")
    return None


def set_sigma(given: FitSet, noise_mm: Any, data: MeasurementSet) -> tuple[float | None, str]:
    """A set's sigma [m] and its origin: its FitSet's, the caller's for all, its file's, or None."""
    if given.noise_mm is not None:
        return as_float(given.noise_mm, "noise_mm", 0.0, MAX_MM, low_open=True, unit="mm") * 1e-3, "caller"
    if noise_mm is not None:
        return float(noise_mm) * 1e-3, "caller"
    if data.noise:
        return float(data.noise), "file"
    return None, "estimate"


def check_sets(sets: list[FitSet], options: dict[str, Any]) -> None:
    """Refuse what several sets cannot take: set-up overrides for all, bad roles."""
    for name, value in options.items():  # the sensors' set-up overrides
        if value is not None:
            raise ArgumentError(name, "one value for several sets: put each set's in its file "
                                f"('# {name}: ...') or its MeasurementSet")
    for s in sets:
        as_choice(s.role, "role", ROLES)
        as_instance(s.label, "label", str, "a set's label (text)")


def set_overrides(sets: list[FitSet], loaded: list[MeasurementSet], labels: tuple[str, ...]) -> tuple[dict[str, Any], ...]:
    """Each set's set-up overrides (its FitSet's ``setup``, the fields given), checked against
    its sensor kind; empty when no set has any.

    Raises:
        ArgumentError: a ``setup`` that is no set-up record, or one with ``estimate``.
        DataError: a field the set's sensor has no use for, naming the set's file and the field.
    """
    if all(s.setup is None for s in sets):
        return ()
    out: list[dict[str, Any]] = []
    for s, data, label in zip(sets, loaded, labels, strict=True):
        if s.setup is None:
            out.append({})
            continue
        if not isinstance(s.setup, SensorSetup):
            raise ArgumentError("setup", f"of set {label}: expected a sensor set-up record, got {type(s.setup).__name__}")
        chosen = s.setup.given()
        if "estimate" in chosen:
            raise ArgumentError("estimate", f"of set {label}: it applies to every set, give it to calibrate (--estimate)")
        sensor = sensor_for(data.kind)
        own = set(sensor.setup_type.field_names()) - {"estimate"}
        for name in chosen:
            if name not in own:
                theirs = f"theirs: {', '.join(sorted(own))}" if own else "they take none"
                raise DataError(data.source or label, f"not a set-up option of {sensor.data_name} "
                                f"(set {label}; {theirs})", None, name)
        out.append(chosen)
    return tuple(out)


def labelled(sets: list[FitSet], loaded: list[MeasurementSet]) -> tuple[str, ...]:
    """Each set's label (given, else its file's stem, else ``s<k>``); the same label or the
    same file twice is refused."""
    labels: list[str] = []
    files: dict[str, list[tuple[str, set[int] | None]]] = {}
    for k, (s, data) in enumerate(zip(sets, loaded, strict=True)):
        label = s.label or (Path(data.source).stem if data.source else f"s{k + 1}")
        if data.source:  # rows of one file in two sets (the file twice; subsets of it may share no line)
            lines = None if data.lines is None else {int(n) for n in data.lines}
            seen = files.setdefault(str(Path(data.source).resolve()), [])
            for other, other_lines in seen:
                if lines is None or other_lines is None or lines & other_lines:
                    raise DataError(data.source, f"given twice (sets {other} and {k + 1}): a row is fitted once")
            seen.append((label, lines))
        if label in labels:
            raise CalibPinError(f"two sets are labelled '{label}': give each set its own label (or file name)")
        labels.append(label)
    for s, data, label in zip(sets, loaded, labels, strict=True):
        if s.role == "test" and sensor_for(data.kind).fits_setup:
            raise DataError(data.source or label, f"a {data.kind} set with role 'test' has no training rows to fit "
                            f"its {sensor_for(data.kind).fitted_setup} on: give it role 'split'")
    return tuple(labels)

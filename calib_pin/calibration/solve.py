"""The one fit of a calibration: a method on every set's training rows, scored on the rows held out.

:func:`solve` takes a prepared :class:`~calib_pin.calibration.prepare.Calibration`, a
method and how rows are held out (:mod:`calib_pin.calibration.holdout`), and returns one
:class:`~calib_pin.calibration.result.CalibrationResult` whose per-set part is always
filled. :func:`calibrate` is :func:`~calib_pin.calibration.prepare.prepare` and
:func:`solve` together. Every caller (the command line, ``compare``, cross-validation,
``compare --models``, ``batch``, the benchmarks) fits through :func:`fit`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.identifiability import support_error
from ..analysis.metrics import Metrics, pooled_unit, units_words
from ..estimators import DEFAULT_METHOD, Method, get_method, run_method
from ..estimators.base import EstimateResult
from ..estimators.problem import data_row_errors, data_rows
from ..exceptions import ArgumentError, CalibPinError, DataError, EstimatorError
from ..measurements import MeasurementSet
from ..parameters.prior import Prior
from ..robot import RobotDescription
from ..robot.deflection import Compliance
from ..sensors import SensorSetup, sensor_for
from ..util.arguments import as_bool, as_instance, as_int
from .gauge import resolve_gauge
from .holdout import Folds, Fraction, Holdout, TestSet, as_holdout, fold_of_rows
from .noise import PILOT, Noise, apply, estimate_noise
from .prepare import Calibration, prepare
from .problem import Problem, values_error
from .result import CalibrationResult, SetResult
from .sets import held_out_warning, mixed_setups_warning
from .validation import register_session, score_session, session_notes


@dataclass(frozen=True)
class Fit:
    """One fit of a calibration's training rows.

    Attributes:
        problem: Every row of every set, each sensor's start fitted on its training rows,
            each set weighted by its noise.
        estimate: The method's estimate.
        noise: Each set's noise and where it came from.
        x0: Where the estimate started, SI.
    """

    problem: Problem
    estimate: EstimateResult
    noise: Noise
    x0: np.ndarray


def method_record(method: Any, loss: str, argument: str = "method") -> Method:
    """``method`` (a name or a record) as a record that takes ``loss``.

    Args:
        method: An estimator's name (``calib_pin.ESTIMATORS``) or record.
        loss: ``linear``, or a robust loss (``huber``, ``soft_l1``, ``cauchy``).
        argument: The caller's name of ``method``, for messages.

    Raises:
        ArgumentError: not a method's name (naming ``argument``), or a loss that is no text.
        EstimatorError: an unknown loss, or a loss the method has no robust variant for.
    """
    from ..estimators import ESTIMATORS, unknown_method

    if not isinstance(method, Method) and as_instance(method, argument, str, "a method name (calib_pin.ESTIMATORS)") \
            not in ESTIMATORS:
        raise ArgumentError(argument, unknown_method(method))
    record = method if isinstance(method, Method) else get_method(method)
    record.check(as_instance(loss, "loss", str, "a loss name (linear, huber, soft_l1, cauchy)"))
    return record


def check_method(record: Method, calibration: Calibration) -> None:
    """Refuse a method the calibration's sets cannot take.

    Args:
        record: The method's record.
        calibration: The prepared calibration.

    Raises:
        EstimatorError: a data kind the method does not take, or rows of several sizes for
            a method that needs rows of one size.
        CalibPinError: a method that learns no kinematics with several sets.
    """
    for kind in calibration.kinds:
        sensor = sensor_for(kind)
        why = record.takes(kind, tuple(getattr(sensor, "unsupported_methods", ())))
        if why:
            raise EstimatorError(why.replace(f"{kind} rows", f"{sensor.data_name} rows"))
    if not record.kinematic and len(calibration.sets) > 1:
        raise CalibPinError(f"method '{record.name}' learns a correction of one sensor set-up's readings, not the "
                            "robot: with several sets (each its own set-up) it would be one correction per set, "
                            "valid for none of the others nor for a new one; use a parameter method (lm, "
                            "ekf-qibas, ...), or give it one --data")


def fit(calibration: Calibration, method: Method, train: np.ndarray, *, seed: int, loss: str,
        history: bool = True, reuse: bool = True, rows: str = "training rows") -> Fit:
    """Fit ``method`` on the ``train`` rows (of ``calibration.data``) of every set.

    Each set's sensor start is fitted on its training rows only; the estimate starts at zero
    deviations (or the ``nominal`` start) with the held unknowns fixed there; each set's
    noise is its stated one or estimated from the training rows where it matters
    (:mod:`calib_pin.calibration.noise`).

    Args:
        calibration: The prepared calibration.
        method: The method's record.
        train: The training rows, indices (0-based) into ``calibration.data``.
        seed: Seed of the estimator.
        loss: ``linear``, or a robust loss.
        history: Record the training RMSE after every iteration.
        reuse: Share the problem made for the same rows (False: make it anew).

    Raises:
        DataError: no more training values than the directions they identify, training rows
            that cannot calibrate anything, a noise estimate that is a misfit; ``rows`` is
            what the messages call the training rows (a cross-validation fold's).
    """
    source = calibration.data.source or "the measurement set"
    problem = calibration.problem_on(train, reuse=reuse, rows=rows)
    training = problem.subset(train)
    x0, held = calibration.start_on(problem, training)
    few = values_error(training, x0, held, len(train), rows)  # counted against the identifiable directions
    if few:
        raise DataError(source, few)
    unsupported = support_error(training)  # rank deficiency is normal; a set that calibrates nothing is not
    if unsupported:
        raise DataError(source, unsupported)
    noise = _noise(calibration, problem, train, method, x0, seed, loss, held, history)
    problem = apply(problem, noise)
    if noise.pilot is not None and method.name == PILOT:  # the pilot was this very fit
        estimate = noise.pilot
    else:
        estimate = run_method(method, problem.subset(train), x0, seed=seed, noise=noise.sigma, loss=loss,
                              history=history, fixed=held)
    model = problem.model  # compliances keep the estimate's value: each is bounded at zero (active set)
    free = np.setdiff1d(np.arange(problem.n_params), [*held, *range(model.n_robot, model.sensor_start)])
    inliers = _inliers(problem.subset(train), estimate)
    # the noise the directions are judged against: the stated or estimated one; a robust fit's
    # from its inliers' median; none (a default a method that weighs nothing was given): the residual's
    judged = (_robust_noise(inliers, estimate.x) if loss != "linear" else None if noise.words == "default"
              else noise.sigma)
    x, gauge = resolve_gauge(inliers, estimate.x, x0, free, calibration.prior, judged)
    estimate = replace(estimate, x=x, extras={**estimate.extras, "gauge": gauge})
    return Fit(problem, estimate, noise, x0)


def _inliers(training: Problem, estimate: EstimateResult) -> Problem:
    """The training rows less those a robust fit judged outliers.

    The training rows less those a robust fit judged outliers (the gauge is a least-squares
    question on the rows the fit trusted).
    """
    if not estimate.outliers:
        return training
    out = set(estimate.outliers)
    keep = [k for k, row in enumerate(data_rows(training)) if int(row) not in out]
    return training.subset(np.asarray(keep, dtype=int))


def _robust_noise(training: Problem, x: np.ndarray) -> float:
    """The residual's noise at x from its median absolute value (1.4826 MAD), [m]: what a robust
    fit's gauge is judged against (a noise estimated with the outliers in would call seen
    directions blind)."""
    r = np.abs(training.residual(x))
    return float(1.4826 * np.median(r)) if len(r) and np.median(r) > 0 else float(np.sqrt(np.mean(r**2)) or 1e-12)


def _noise(calibration: Calibration, problem: Problem, train: np.ndarray, method: Method, x0: np.ndarray,
           seed: int, loss: str, held: tuple[int, ...], history: bool) -> Noise:
    """Each set's noise for ``method`` on the ``train`` rows.

    It is estimated once for every method that needs the same (the pilot fit is a
    Levenberg-Marquardt fit, whatever the method).
    """
    key = ("noise", np.asarray(train).tobytes(), loss, method.weighs_noise, x0.tobytes(), held,
           method.name == PILOT and history)
    known = calibration._cache.get(key)
    if known is None:
        known = calibration._cache[key] = estimate_noise(
            problem, train, [s.sigma for s in calibration.sets], [s.origin for s in calibration.sets], method, x0,
            seed=seed, loss=loss, fixed=held, default=calibration.noise, history=history,
            source=calibration.data.source)
    return known  # type: ignore[no-any-return]


def _after(part: Any, xk: np.ndarray | None, estimate: EstimateResult) -> np.ndarray:
    """A set's residual at its calibrated unknowns, with a learnt correction of the values."""
    r = part.residual(xk)
    if estimate.correction is not None:
        r = r + estimate.correction(part.q, part.points).reshape(-1)
    return r


def score(calibration: Calibration, method: Method, done: Fit, train: np.ndarray, test: np.ndarray, *,
          seed: int, loss: str, notes: Sequence[str] = ()) -> CalibrationResult:
    """The calibration's result: each set's errors before and after the fit, and all together.

    Errors before (at the start) and after the fit on each set's training and test rows,
    in its own unit, and every set's together.
    """
    problem, estimate, x0 = done.problem, done.estimate, done.x0
    model = problem.model
    warnings_ = [note for note in (s.data.ignored_note() for s in calibration.sets) if note] + list(notes)
    warnings_ += [note for s in calibration.sets for note in s.data.dropped]  # rows a sensor could not use
    several = len(calibration.sets) > 1
    guessed = [s.label for s, origin in zip(calibration.sets, done.noise.origins, strict=True) if origin[0] == "estimate"]
    if several and done.noise.fits > 1 and guessed:
        warnings_.append(f"noise of {', '.join(guessed)} estimated from the residual ({done.noise.fits} fits)")
    warnings_ += done.noise.notes  # a set too small to estimate its own noise; an estimate that did not settle
    results: list[SetResult] = []
    pooled: dict[str, dict[str, list[np.ndarray]]] = {}
    offsets = calibration.offsets
    for k, s in enumerate(calibration.sets):
        part = problem.parts[problem.sets.index(k)]
        xk, zero = model.part_x(estimate.x, k), model.part_x(x0, k)
        tr, te = calibration.rows(k, train), calibration.rows(k, test)
        metrics: dict[str, dict[str, Metrics]] = {}
        for split, rows in (("train", tr), ("test", te)):
            if len(rows):
                sub = part.subset(rows)
                before = data_row_errors(sub, sub.residual(zero))  # touches only, not known distances
                after = data_row_errors(sub, _after(sub, xk, estimate))
                metrics[split] = {"before": Metrics.of(before), "after": Metrics.of(after)}
                pooled.setdefault(split, {"before": [], "after": []})
                pooled[split]["before"].append(before)
                pooled[split]["after"].append(after)
        sigma, origin = done.noise.sigmas[k][0], done.noise.origins[k][0]
        if "train" in metrics:
            mixed = mixed_setups_warning(s.data, tr, metrics["train"]["after"].rmse_mm, float(sigma))
            warnings_ += [mixed] if mixed else []
            if "test" in metrics:
                unit = str(getattr(part.model, "value_unit", "mm"))
                held = held_out_warning(s.label, metrics["train"]["after"].rmse_mm, metrics["test"]["after"].rmse_mm,
                                        float(sigma) * 1e3, unit)
                warnings_ += [held] if held else []
        results.append(SetResult(
            label=s.label, source=s.data.source, kind=s.kind, role=s.role, sigma=float(sigma), sigma_origin=origin,
            rows=np.arange(offsets[k], offsets[k + 1]), train=tr, test=te, metrics=metrics,
            geometry=part.model.geometry_report(xk), model=part.model, x=np.asarray(xk), estimate=estimate,
            overrides=s.overrides, overridden=s.overridden, unit=str(getattr(part.model, "value_unit", "mm")),
            chain=calibration.chain, problem=part))
    if len(results) == 1:
        metrics = results[0].metrics
    else:
        metrics = {split: {stage: Metrics.of(np.concatenate(v)) for stage, v in stages.items()}
                   for split, stages in pooled.items()}
        if pooled_unit(results) is None:  # errors in mm and in degrees are no one RMSE
            metrics = {}
            warnings_.append(f"no all-sets table: {units_words(results)}; each set's table is in its own units")
    return CalibrationResult(
        chain=calibration.chain, params=calibration.params, method=method.name, x=estimate.x, estimate=estimate,
        problem=problem, data=calibration.data, train=train, test=test, metrics=metrics, seed=seed,
        noise=done.noise.sigma, loss=loss, warnings=tuple(warnings_), sets=tuple(results), start=calibration.start,
        noise_from=done.noise.words, x0=x0, prior=calibration.prior, tcp=calibration.tcp)


def solve(calibration: Calibration, method: str | Method = DEFAULT_METHOD, *, holdout: Holdout | float = 0.2,
          seed: int = 0, loss: str = "linear", history: bool = True) -> CalibrationResult:
    """Estimate with ``method`` (and ``loss``) on every set's training rows; score the rows held out.

    Args:
        calibration: A prepared calibration (:func:`calib_pin.prepare`).
        method: An estimator's name (``calib_pin.ESTIMATORS``) or record.
        holdout: How rows are held out: a :class:`~calib_pin.calibration.holdout.Fraction`
            of each set's poses (a number is one), :class:`~calib_pin.calibration.holdout.Folds`
            (K-fold cross-validation of the training poses besides), or a separate
            validation session (:class:`~calib_pin.calibration.holdout.TestSet`: every row
            trains).
        seed: Seed of the split, the folds and the estimator.
        loss: ``linear``, or a robust loss (``huber``, ``soft_l1``, ``cauchy``).
        history: Record the training RMSE after every iteration (off: the method alone is timed).

    Raises:
        CalibPinError: a bad argument (naming it), a method or loss the sets cannot take,
            too few training rows, a bad validation session.
    """
    as_instance(calibration, "calibration", Calibration, "a prepared calibration (calib_pin.prepare)")
    record = method_record(method, loss)
    seed = as_int(seed, "seed", 0)
    history = as_bool(history, "history")
    rows: Holdout = _fraction(holdout) if isinstance(holdout, int | float) and not isinstance(holdout, bool) else \
        as_instance(holdout, "holdout", (Fraction, Folds, TestSet), "calib_pin.Fraction, Folds or TestSet")
    return _solve(calibration, record, rows, seed, loss, history)


def _fraction(share: float) -> Fraction:
    """``solve``'s ``holdout`` given as a number: the share of each set's poses held out.

    Raises:
        ArgumentError: naming ``holdout``: not in [0, 1) (a whole number of folds is named).
    """
    try:
        return Fraction(share)
    except ArgumentError as e:
        folds = f" (for {share}-fold cross-validation: calib_pin.Folds({share}))" if isinstance(share, int) and \
            share >= 2 else ""
        raise ArgumentError("holdout", f"{e.reason}{folds}") from None


def _solve(calibration: Calibration, record: Method, holdout: Holdout, seed: int, loss: str,
           history: bool) -> CalibrationResult:
    """:func:`solve` of checked arguments."""
    check_method(record, calibration)
    if isinstance(holdout, TestSet):
        return _solve_session(calibration, record, holdout, seed, loss, history)
    train, test = calibration.split(holdout.test_fraction, seed)
    if not len(train):  # prepare refused sets that are all role 'test'; a set this small is split so
        raise DataError(calibration.data.source or "data", f"test fraction {holdout.test_fraction:g} holds out "
                        f"every pose of its {len(calibration.data)} rows: nothing to fit (hold out less, or give more)")
    if isinstance(holdout, Folds):
        _check_folds(calibration, train, holdout.k, "holdout")
    notes = []
    if holdout.test_fraction > 0 and not len(test):
        notes.append(f"test fraction {holdout.test_fraction:g} holds out no pose of {len(calibration.data)}: "
                     "no test metrics")
    result = score(calibration, record, fit(calibration, record, train, seed=seed, loss=loss, history=history),
                   train, test, seed=seed, loss=loss, notes=notes)
    if isinstance(holdout, Folds):
        result = replace(result, cross_validation=_cross_validate(calibration, record, train, holdout.k, seed,
                                                                  loss).as_dict())
    return result


def _solve_session(calibration: Calibration, method: Method, test: TestSet, seed: int, loss: str,
                   history: bool) -> CalibrationResult:
    """Every row of every set trains; the validation session is the test.

    The session is scored with the set-up of the set it names, or re-registered first.
    """
    session, k = calibration.validation(test)
    if session.register is not None and not method.kinematic:
        raise CalibPinError(f"method '{method.name}' learns a correction of the training set-up's values: a "
                            "re-registered validation session needs a parameter method (lm, ekf-qibas, ...)")
    every = np.arange(len(calibration.data))
    result = score(calibration, method, fit(calibration, method, every, seed=seed, loss=loss, history=history),
                   every, every[:0], seed=seed, loss=loss)
    s = result.sets[k]
    data = session.data
    assert isinstance(data, MeasurementSet)
    if session.register is None:
        metrics = score_session(s.model, s.x, result.estimate.correction, data)
        info: dict[str, Any] = {"data": data.source, "setup": "same", "same_as": s.label}
    else:
        metrics, info = register_session(session, s.model, s.x, calibration.sets[k].options)
        info = {**info, "sensor_model_of": s.label}
    return replace(result, metrics={**result.metrics, "test": metrics}, test_source=data.source,
                   test_registration=info, warnings=result.warnings + session_notes(session))


@dataclass(frozen=True)
class CrossValidation:
    """Held-out metrics of each fold, [mm].

    Attributes:
        folds: K.
        seed: Seed of the folds.
        test: Per fold, the held-out rows' metrics [mm].
    """

    folds: int
    seed: int
    test: tuple[Metrics, ...]

    def stat(self, key: str) -> tuple[float, float]:
        """(mean, sd) over the folds of ``rmse_mm``, ``mean_mm`` or ``max_mm``."""
        values = np.array([getattr(m, key) for m in self.test])
        return float(np.mean(values)), float(np.std(values))

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: K, seed, and per metric mean, sd and each fold's value [mm]."""
        return {"folds": self.folds, "seed": self.seed, "split": "by pose, within the training rows",
                **{key: {"mean": self.stat(key)[0], "sd": self.stat(key)[1],
                         "per_fold": [getattr(m, key) for m in self.test]}
                   for key in ("rmse_mm", "mean_mm", "max_mm")}}


def cross_validate(calibration: Calibration, method: str | Method, rows: np.ndarray, folds: int, *, seed: int = 0,
                   loss: str = "linear") -> CrossValidation:
    """K-fold cross-validation by pose of the calibration's model on ``rows``.

    Each fold is held out once while the method is fitted on the others (:func:`fit`: each
    sensor's start, the start and the held unknowns, each set's noise), and its rows scored.

    Args:
        calibration: The prepared calibration.
        method: An estimator's name or record.
        rows: The rows to cross-validate, indices (0-based) into ``calibration.data``.
        folds: K, at least 2 and at most the poses of ``rows``.
        seed: Seed of the folds and the estimator.
        loss: ``linear``, or a robust loss.

    Raises:
        ArgumentError: K out of range for the poses (``folds``).
        EstimatorError: an unknown method or loss.
    """
    record, rows = method_record(method, loss), np.asarray(rows, dtype=int)
    folds = as_int(folds, "folds", 2)
    _check_folds(calibration, rows, folds, "folds")
    return _cross_validate(calibration, record, rows, folds, seed, loss)


def _check_folds(calibration: Calibration, rows: np.ndarray, folds: int, argument: str) -> None:
    """Refuse more folds than ``rows`` have poses, naming ``argument``."""
    poses = len(np.unique(np.asarray(calibration.data.groups)[rows]))
    if folds > poses:
        raise ArgumentError(argument, f"{folds} folds for {poses} training poses: give 2 to {poses} folds")


def _cross_validate(calibration: Calibration, method: Method, rows: np.ndarray, folds: int, seed: int,
                    loss: str) -> CrossValidation:
    """:func:`cross_validate` of checked arguments."""
    fold = fold_of_rows(np.asarray(calibration.data.groups)[rows], folds, seed)
    out = []
    for k in range(folds):
        train, test = rows[fold != k], rows[fold == k]
        done = fit(calibration, method, train, seed=seed, loss=loss, history=False,
                   rows=f"fitting rows of cross-validation fold {k + 1} of {folds} (the other folds')")
        held_out = done.problem.subset(test)
        out.append(Metrics.of(data_row_errors(held_out, _after(held_out, done.estimate.x, done.estimate))))
    return CrossValidation(folds, seed, tuple(out))


def calibrate(
    robot: str | RobotDescription,
    data: Any = None,
    *,
    method: str = DEFAULT_METHOD,
    seed: int = 0,
    test_fraction: float | None = None,
    test_data: str | Path | Any = None,
    end_frame: str | None = None,
    noise_mm: Any = None,
    loss: str = "linear",
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
) -> CalibrationResult:
    """Calibrate a robot's kinematic deviations from one or more measurement sets.

    Args:
        robot: Robot name or URDF path (``irb120``).
        data: A measurement CSV or :class:`~calib_pin.measurements.MeasurementSet`, or a
            list of them (or of :class:`~calib_pin.calibration.sets.FitSet`, with a set's
            label, role, noise and set-up): one robot, each set its own sensor set-up, split
            by pose each, weighted by its noise. None: the robot's shipped set.
        method: Estimator name (``calib_pin.ESTIMATORS``; default ``ekf-qibas``).
        seed: Seed of the train/test split and of the estimator.
        test_fraction: Share of each set's poses held out for the test metrics (default 0.2).
        test_data: A separate validation session (a CSV, a set, or a
            :class:`~calib_pin.calibration.holdout.TestSet` with its set-up): every row of
            ``data`` trains and the session is the test (``test_fraction`` is refused beside it).
        end_frame: End frame; default the file's ``end_frame`` or the robot's.
        noise_mm: Sensor noise (1 sigma) [mm]: one for all sets, or one per set; default each
            file's ``noise_mm``, else estimated from the residual where it matters
            (:mod:`calib_pin.calibration.noise`; ``result.noise_from`` says which).
        loss: ``linear``, or a robust loss (``huber``, ``soft_l1``, ``cauchy``).
        parameters: Parameter model: ``dh`` (default with a DH table), ``hayati`` or
            ``placement`` (default without one; any URDF).
        setup: The sensor's set-up record (:class:`~calib_pin.sensors.CableSetup`, ...):
            overrides of the file's, and the sensor unknowns to ``estimate``; with several
            sets only ``estimate`` (each set's own set-up goes in its FitSet).
        compliance: The joints whose compliance [rad/Nm] is estimated with the geometry,
            and their loads: a :class:`~calib_pin.robot.deflection.Compliance`, or joint
            names as shorthand (``"joint_2,joint_3"``, ``"all"``); None: a rigid arm.
        fix: Unknowns held at their start (names, or a comma-separated str:
            ``"theta_1,d_1"``, a compliance ``compliance_joint_2``, a sensor unknown).
        free: The robot's deviations and compliances to estimate; the others are held.
        nominal: Start from a robot's own kinematics instead of the catalogue URDF: a
            calib-pin calibration file or a UR ``default_kinematics.yaml``; ``result.x``
            stays relative to the URDF.
        prior: What a deviation is before calibration (:class:`~calib_pin.parameters.prior.Prior`,
            default 1 mm and 0.1 deg): the robot stays at its start along what the data does
            not determine, and this bounds the error left there (``result.accuracy``).
        tcp_mm: The points of the end frame you work with, (x, y, z) [mm] or a list of them:
            ``result.accuracy`` is given there (default: the measured points, the end frame's
            origin and a tool the data gives).
        limit_margin_deg: How far beyond its URDF limits each revolute joint's measured angle
            is accepted, [deg] in [0, 30] (a controller whose limits are wider than its URDF's).
        deprecated: ``anchor_mm``, ``tool_mm``, ``length_offset_mm``, ``estimate`` (give
            ``setup``), ``payload_kg``, ``payload_com_mm``, ``cable_tension_n`` (give
            ``compliance``) and ``progress``: accepted for one release with a DeprecationWarning.

    Raises:
        CalibPinError: any bad input (robot, file, option), with a one-line message; a bad
            argument is an :class:`~calib_pin.exceptions.ArgumentError` naming it.
    """
    if "holdout" in deprecated:
        raise ArgumentError("holdout", "is solve's: calibrate holds rows out by test_fraction or test_data (or call "
                            "calib_pin.prepare, then calib_pin.solve(calibration, method, holdout=...))")
    progress = deprecated.pop("progress", None)
    if progress is not None and not callable(progress):
        raise ArgumentError("progress", f"expected a function of the calibration, or None, got {type(progress).__name__}")
    record = method_record(method, loss)
    seed = as_int(seed, "seed", 0)
    holdout = as_holdout(test_fraction, test_data)
    prepared = prepare(robot, data, end_frame=end_frame, noise_mm=noise_mm, parameters=parameters, setup=setup,
                       compliance=compliance, fix=fix, free=free, nominal=nominal, prior=prior, tcp_mm=tcp_mm,
                       limit_margin_deg=limit_margin_deg, **deprecated)
    if progress is not None:
        warnings.warn("calibrate(progress=...) is deprecated: call calib_pin.prepare, then calib_pin.solve",
                      DeprecationWarning, stacklevel=2)
        progress(prepared)
    return _solve(prepared, record, holdout, seed, loss, True)


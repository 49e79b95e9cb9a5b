"""Every estimator on the same data and split: the paper's Table I, with repeated trials.

:func:`compare` runs the chosen methods on one measurement set (or on seeded simulated
sets), each trial on one seeded 80/20 split shared by all methods, and collects per
method the test metrics, the convergence history and the wall time. When the true
deviations are known (a simulated set, or a shipped set with its ``.truth.json``), it
also scores each estimate on 1000 fresh poses against the noise-free truth: the test
residual of a good calibration is mostly sensor noise, the fresh-pose error is not.

:meth:`Comparison.rows` aggregates over trials (mean and standard deviation), and the
writers give ``table1.csv`` and ``table1.md`` (with the paper's numbers beside ours).

With a ``checkpoint`` folder each finished trial is kept there as it finishes
(:mod:`calib_pin.studies.checkpoint`): after Ctrl-C or a worker fault the same comparison runs
only the trials not yet done, with the same results.
"""

from __future__ import annotations

import csv
import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.metrics import Metrics
from ..calibration.holdout import Fraction
from ..calibration.prepare import Calibration, deprecated_records, prepare
from ..calibration.result import CalibrationResult
from ..calibration.solve import check_method, method_record, solve
from ..estimators import PAPER_METHODS, Method
from ..estimators.problem import data_row_errors
from ..exceptions import ArgumentError, CalibPinError
from ..parameters import ParameterModel, parameter_model
from ..parameters.prior import Prior
from ..robot import Chain, load_chain
from ..robot.deflection import Compliance
from ..robot.poses import random_poses
from ..sensors import SensorSetup, sensor_for
from ..simulation import Truth, simulate
from ..util.arguments import as_path
from ..util.progress import progress_bar
from .checkpoint import Checkpoint, file_digest, fingerprint
from .parallel import parallel_map

#: Table I of the paper: test RMSE, "Std" (mean absolute residual) and Max, [mm].
PAPER_TABLE1 = {
    "Before": (2.09, 2.00, 3.36),
    "M1": (0.66, 0.56, 1.71),
    "M2": (0.70, 0.56, 1.76),
    "M3": (0.64, 0.55, 1.51),
    "M4": (0.59, 0.49, 1.28),
    "M5": (0.85, 0.72, 1.91),
    "M6": (0.50, 0.41, 1.16),
    "M7": (0.67, 0.58, 1.59),
    "M8": (0.64, 0.54, 1.49),
    "M9": (0.46, 0.38, 1.10),
}

#: A method's training RMSE counts as converged within this share of its final value.
CONVERGED_TOLERANCE = 0.05

#: Fresh poses drawn to score an estimate against the truth.
FRESH_POSES = 1000


@dataclass
class MethodRun:
    """One method on one trial.

    Attributes:
        method, label: Registry name and the paper's label (``M9``).
        train, test: Reading residual metrics after calibration, [mm].
        fresh_rmse_mm: RMSE on fresh poses against the noise-free truth [mm], or None.
        iterations, evaluations: Work used in all (see :mod:`calib_pin.estimators.base`).
        converged_iterations, converged_evaluations: Work used until the training RMSE
            came within 5 % of its final value.
        time_s: Wall time of the estimate, [s].
        history_mm: Training RMSE [mm] at the start and after each iteration.
        history_evaluations: Evaluations used at each history entry.
        test_residual_mm: Test residuals (predicted - measured), shape (n_test,), [mm].
    """

    method: str
    label: str
    train: Metrics
    test: Metrics
    fresh_rmse_mm: float | None
    iterations: int
    evaluations: float
    converged_iterations: int
    converged_evaluations: float
    time_s: float
    history_mm: list[float]
    history_evaluations: list[float]
    test_residual_mm: np.ndarray


@dataclass
class Trial:
    """All methods on one data set and split.

    Attributes:
        seed: Seed of the split, the estimators and (for simulated sets) the data.
        source: Where the data came from.
        before: Test metrics of the nominal model, [mm].
        before_fresh_rmse_mm: Nominal model's fresh-pose error against the truth, or None.
        before_residual_mm: Nominal test residuals, shape (n_test,), [mm].
        runs: Method name to its run, in the order run.
    """

    seed: int
    source: str
    before: Metrics
    before_fresh_rmse_mm: float | None
    before_residual_mm: np.ndarray
    runs: dict[str, MethodRun]

    def to_json(self) -> dict[str, Any]:
        """The trial as JSON-able values (arrays as lists); :meth:`from_json` gives it back exactly."""
        return _plain(dataclasses.asdict(self))

    @classmethod
    def from_json(cls, value: dict[str, Any]) -> Trial:
        """The trial of :meth:`to_json`."""
        runs = {name: MethodRun(**{**run, "train": Metrics(**run["train"]), "test": Metrics(**run["test"]),
                                   "test_residual_mm": np.array(run["test_residual_mm"], dtype=float)})
                for name, run in value["runs"].items()}
        return cls(seed=value["seed"], source=value["source"], before=Metrics(**value["before"]),
                   before_fresh_rmse_mm=value["before_fresh_rmse_mm"],
                   before_residual_mm=np.array(value["before_residual_mm"], dtype=float), runs=runs)


def _plain(value: Any) -> Any:
    """``value`` with numpy arrays and scalars as lists and Python numbers (exact)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


@dataclass
class Comparison:
    """Trials of a comparison and their summary.

    Attributes:
        robot: Robot name.
        methods: Method names compared.
        trials: One entry per trial.
        data: What the trials ran on, in words.
    """

    robot: str
    methods: list[str]
    trials: list[Trial]
    data: str

    def rows(self) -> list[dict]:
        """Table I rows (Before, then each method), each value as (mean, sd) over trials.

        Keys: ``item`` (Before / M1..M9), ``method``, ``rmse_mm``, ``mean_mm``,
        ``max_mm``, ``fresh_rmse_mm`` (None when the truth is unknown),
        ``converged_iterations``, ``converged_evaluations``, ``time_s`` (None for Before).
        """

        def stat(values) -> tuple[float, float] | None:
            if any(v is None for v in values):
                return None
            return float(np.mean(values)), float(np.std(values))

        rows = [{
            "item": "Before", "method": "nominal",
            "rmse_mm": stat([t.before.rmse_mm for t in self.trials]),
            "mean_mm": stat([t.before.mean_mm for t in self.trials]),
            "max_mm": stat([t.before.max_mm for t in self.trials]),
            "fresh_rmse_mm": stat([t.before_fresh_rmse_mm for t in self.trials]),
            "converged_iterations": None, "converged_evaluations": None, "time_s": None,
        }]
        for m in self.methods:
            runs = [t.runs[m] for t in self.trials]
            rows.append({
                "item": runs[0].label, "method": m,
                "rmse_mm": stat([r.test.rmse_mm for r in runs]),
                "mean_mm": stat([r.test.mean_mm for r in runs]),
                "max_mm": stat([r.test.max_mm for r in runs]),
                "fresh_rmse_mm": stat([r.fresh_rmse_mm for r in runs]),
                "converged_iterations": stat([r.converged_iterations for r in runs]),
                "converged_evaluations": stat([r.converged_evaluations for r in runs]),
                "time_s": stat([r.time_s for r in runs]),
            })
        return rows

    def format_table(self) -> str:
        """Table I as fixed-width text (mean, and +- sd when there are several trials)."""
        header = ["item", "method", "RMSE mm", "mean mm", "max mm", "fresh mm",
                  "iters", "evals", "time s"]
        lines = [self.data, _fixed(header)]
        for row in self.rows():
            lines.append(_fixed([row["item"], row["method"], *self._cells(row)]))
        return "\n".join(lines)

    def _cells(self, row: dict) -> list[str]:
        many = len(self.trials) > 1
        formats = (("rmse_mm", ".3f"), ("mean_mm", ".3f"), ("max_mm", ".3f"),
                   ("fresh_rmse_mm", ".3f"), ("converged_iterations", ".0f"),
                   ("converged_evaluations", ".1f"), ("time_s", ".3f"))
        out = []
        for key, fmt in formats:
            value = row[key]
            if value is None:
                out.append("-")
            elif many:
                out.append(f"{value[0]:{fmt}} ± {value[1]:{fmt}}")
            else:
                out.append(f"{value[0]:{fmt}}")
        return out

    def write_csv(self, path: str | Path) -> Path:
        """Write ``table1.csv``: one row per item, ``<key>_mean`` and ``<key>_sd`` columns."""
        keys = ("rmse_mm", "mean_mm", "max_mm", "fresh_rmse_mm", "converged_iterations",
                "converged_evaluations", "time_s")
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["item", "method", "trials"]
                            + [f"{k}_{s}" for k in keys for s in ("mean", "sd")]
                            + ["paper_rmse_mm", "paper_std_mm", "paper_max_mm"])
            for row in self.rows():
                values = []
                for k in keys:
                    values += ["", ""] if row[k] is None else [f"{row[k][0]:.6g}", f"{row[k][1]:.6g}"]
                paper = PAPER_TABLE1.get(row["item"], ("", "", ""))
                writer.writerow([row["item"], row["method"], len(self.trials), *values, *paper])
        return path

    def write_markdown(self, path: str | Path, command: str = "") -> Path:
        """Write ``table1.md``: our Table I with the paper's numbers beside it."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        many = len(self.trials) > 1
        lines = [
            f"Table I, {self.robot}: {self.data}.",
            "Test-set reading residuals in mm; 'mean' is the paper's \"Std\" (mean absolute "
            "residual); 'fresh' is the error on 1000 fresh poses against the noise-free truth "
            "(- when the truth is unknown); iterations and evaluations until the training RMSE "
            f"was within {CONVERGED_TOLERANCE:.0%} of its final value; wall time of the estimate."
            + (f" Mean ± sd over {len(self.trials)} trials." if many else ""),
            "",
        ]
        if command:
            lines[1:1] = [f"Command: `{command}`"]
        header = ["Item", "Method", "RMSE", "Mean (Std)", "Max", "Fresh", "Iterations",
                  "Evaluations", "Time s", "Paper RMSE", "Paper Std", "Paper Max"]
        lines.append("| " + " | ".join(header) + " |")
        lines.append("|" + "|".join(["---"] * 2 + ["---:"] * (len(header) - 2)) + "|")
        for row in self.rows():
            paper = PAPER_TABLE1.get(row["item"])
            paper_cells = [f"{p:.2f}" for p in paper] if paper else ["", "", ""]
            cells = [row["item"], row["method"], *self._cells(row), *paper_cells]
            lines.append("| " + " | ".join(cells) + " |")
        path.write_text("\n".join(lines) + "\n")
        return path


def _fixed(cells: list[str]) -> str:
    widths = [6, 10, 15, 15, 15, 15, 10, 16, 15]
    return " ".join(f"{c:<{w}s}" if i < 2 else f"{c:>{w}s}" for i, (c, w) in enumerate(zip(cells, widths, strict=False)))


def truths_of(calibration: Calibration) -> list[Truth] | None:
    """Each set's truth, when every set has one and they are of one true robot; else None.

    A set's own ``FILE.truth.json``, or session k of ``BASE.truth.json`` for ``BASE_k.csv``
    (the files ``simulate --sessions K`` writes); None otherwise, or for another parameter
    model than the robot's default (the truth's).
    """
    if calibration.params.name != parameter_model(calibration.chain).name:
        return None
    out: list[Truth] = []
    for s in calibration.sets:
        if not s.data.source:
            return None
        path = Path(s.data.source)
        stem = path.name.removesuffix(".csv")
        base, _, k = stem.rpartition("_")
        own, shared = path.with_name(stem + ".truth.json"), path.with_name(base + ".truth.json")
        if own.is_file():
            truth = Truth.from_json(own, calibration.params)
            if truth.sessions:
                return None
        elif base and k.isdigit() and shared.is_file():
            truth = Truth.from_json(shared, calibration.params)
            if not 1 <= int(k) <= max(1, len(truth.sessions)):
                return None
            truth = truth.session(int(k) - 1)
        else:
            return None
        out.append(truth)
    first = out[0]
    for truth in out[1:]:  # one true robot, or no score
        if not np.array_equal(truth.x, first.x) or not np.array_equal(truth.x_model, first.x_model):
            return None
    return out


def fresh_scorer(calibration: Calibration, truths: list[Truth] | None,
                 seed: int) -> Callable[[CalibrationResult, bool], float | None]:
    """score(result, before) -> RMSE [mm] of ``result``'s predictions at fresh poses against the truth.

    What ``result`` predicts (at its start with ``before``) at the same fresh poses for
    every set's sensor (each at its own points), against each set's noise-free truth, the
    sets' values pooled; None without every set's truth, or when the sets' errors are in
    different units.
    """
    if truths is None:
        def unknown(result: CalibrationResult, before: bool = False) -> float | None:
            return None

        return unknown
    poses = random_poses(calibration.chain, FRESH_POSES, np.random.default_rng(seed + 10_000))
    cases = []
    for truth in truths:
        model = truth.model(calibration.chain, calibration.params)
        rows, points = model.grid_points(len(poses))
        q = poses[rows]
        cases.append((q, points, model.predict(truth.x_model, q, points)))

    def score(result: CalibrationResult, before: bool = False) -> float | None:
        if len({s.unit for s in result.sets}) > 1:
            return None
        errors = []
        for s, (q, points, true) in zip(result.sets, cases, strict=True):
            x = result.problem.model.part_x(result.x0, result.sets.index(s)) if before else s.x
            predicted = s.model.predict(x, q, points)
            correction = None if before else result.estimate.correction
            if correction is not None:
                predicted = predicted + correction(q, points).reshape(predicted.shape)
            errors.append(s.model.fresh_difference(predicted, true).ravel())
        error = errors[0] if len(errors) == 1 else np.concatenate(errors)
        return float(np.sqrt(np.mean(error**2)) * 1e3)

    return score


def run_trial(calibration: Calibration, truths: list[Truth] | None, methods: list[Method], seed: int,
           test_fraction: float, tick: Callable[[], Any] | None = None) -> Trial:
    """One trial: every method (a checked record) fitted on the split of seed ``seed`` and scored on the held-out rows.

    Each method is fitted as :func:`calib_pin.solve` fits it (every set split by pose),
    scored on the held-out rows of every set (each row's error in its own set's unit) and,
    with ``truths``, on fresh poses against them.
    """
    if not len(calibration.split(test_fraction, seed)[1]):
        raise CalibPinError(f"a comparison needs held-out rows: {len(calibration.data)} rows at test fraction "
                            f"{test_fraction:g} hold out none (use more poses or a larger test fraction)")
    runs = {}
    before: np.ndarray | None = None
    fresh = fresh_scorer(calibration, truths, seed)
    before_fresh = None
    for m in methods:
        result = solve(calibration, m, holdout=Fraction(test_fraction), seed=seed)  # the record: no lookup
        est, problem = result.estimate, result.problem
        train_problem, test_problem = problem.subset(result.train), problem.subset(result.test)
        k, evals = est.converged(CONVERGED_TOLERANCE)
        residual = data_row_errors(test_problem, est.residual(test_problem))
        runs[m.name] = MethodRun(
            method=m.name, label=m.label,
            train=Metrics.of(data_row_errors(train_problem, est.residual(train_problem))), test=Metrics.of(residual),
            fresh_rmse_mm=fresh(result, False), iterations=est.iterations, evaluations=est.nfev,
            converged_iterations=k, converged_evaluations=evals, time_s=est.time_s,
            history_mm=[h * 1e3 for h in est.history], history_evaluations=list(est.evaluations),
            test_residual_mm=residual * 1e3,
        )
        if before is None:  # every method starts from the same sensor geometry, fitted on the same rows
            before = data_row_errors(test_problem, test_problem.residual(result.x0))
            before_fresh = fresh(result, True)
        if tick is not None:
            tick()
    assert before is not None  # methods is not empty
    return Trial(seed=seed, source=calibration.data.source or "simulated", before=Metrics.of(before),
                 before_fresh_rmse_mm=before_fresh, before_residual_mm=before * 1e3, runs=runs)


def _simulated_trial(robot: str, chain: Chain, params: ParameterModel, methods: list[Method], test_fraction: float,
                     poses: int, noise_mm: float, noise_kind: str, options: dict[str, Any], seed: int,
                     tick: Callable[[], Any] | None = None) -> Trial:
    """One trial on a fresh simulated set of seed ``seed`` (a picklable unit of work)."""
    sim, truth = simulate(chain, params, poses, seed, noise_mm=noise_mm, noise_kind=noise_kind)
    return run_trial(prepare(robot, sim, **options), [truth], methods, seed, test_fraction, tick)


def compare(
    robot: str,
    data: Any = None,
    *,
    methods: list[str] | None = None,
    trials: int = 1,
    seed: int = 0,
    test_fraction: float = 0.2,
    simulate_noise: str | None = None,
    noise_mm: float = 0.05,
    poses: int = 120,
    compliance: Compliance | str | tuple[str, ...] | None = None,
    parameters: str | None = None,
    setup: SensorSetup | None = None,
    fix: Any = None,
    free: Any = None,
    nominal: str | Path | None = None,
    prior: Prior | None = None,
    jobs: int = 1,
    scheduler: str | None = None,
    checkpoint: str | Path | None = None,
    notify: Callable[[str], Any] | None = None,
    **deprecated: Any,
) -> Comparison:
    """Run estimators side by side, each fitted as :func:`calib_pin.calibrate` fits it.

    Args:
        robot: Robot name or URDF path.
        data: Measurement sets as :func:`calib_pin.calibrate` takes them (a CSV, a set, a
            list of them or of FitSets: one robot, each set its own sensor set-up); None uses
            the robot's shipped set. Each trial splits every set by pose with the trial's
            seed. Ignored when ``simulate_noise`` is given.
        methods: Method names (default: the paper's nine, M1..M9, less those the data's
            sensors cannot take).
        trials: Number of trials. On measured data, trial i uses the split of seed
            ``seed + i``; with ``simulate_noise``, trial i also simulates a new set of
            seed ``seed + i``.
        seed: First seed.
        test_fraction: Share of each set's poses held out (the paper's 0.2).
        simulate_noise: ``gauss``, ``student`` or ``outliers``: run on simulated sets of
            ``poses`` poses with that noise of size ``noise_mm`` [mm] (1 sigma).
        compliance, parameters, setup, fix, free, nominal, prior: As :func:`calib_pin.calibrate`'s
            (``nominal``: measured data only).
        jobs, scheduler: Run the trials in ``jobs`` local processes, or on the Dask
            cluster at ``scheduler`` (see :func:`calib_pin.studies.parallel.parallel_map`); the
            results do not depend on it (each trial is seeded), only the time does.
        checkpoint: Folder in which each finished trial is kept as it finishes
            (``<checkpoint>/.calib-pin-checkpoint``), and from which a comparison of the
            same data and settings takes the trials already done; None keeps nothing.
            The caller removes it (:meth:`calib_pin.studies.checkpoint.Checkpoint.clear`) once
            the outputs are written.
        notify: Called with one line when kept trials are reused, or default methods left out.
        deprecated: ``estimate`` (give ``setup``) and ``payload_kg``, ``payload_com_mm``,
            ``cable_tension_n`` (give ``compliance``), with a DeprecationWarning.

    Raises:
        CalibPinError: bad method, robot, data or settings.
        calib_pin.studies.parallel.ParallelFault: a worker or the scheduler failed (the finished
            trials are kept when ``checkpoint`` is given).
        calib_pin.studies.checkpoint.Interrupted: Ctrl-C with a ``checkpoint``; the finished trials are kept.
    """
    default = methods is None
    methods = list(PAPER_METHODS) if methods is None else list(methods)
    records = [method_record(m, "linear", "methods") for m in methods]  # each looked up and checked once
    if trials < 1:
        raise CalibPinError(f"trials must be at least 1, got {trials}")
    setup, record = deprecated_records(deprecated, setup, compliance)
    options: dict[str, Any] = {"compliance": record}
    for key, value in (("parameters", parameters), ("setup", setup), ("fix", fix), ("free", free), ("prior", prior)):
        if value is not None:  # only when given: the checkpoints of earlier runs stay valid
            options[key] = value
    if nominal is not None:
        if simulate_noise is not None:
            raise ArgumentError("nominal", "starts from a robot's own calibration: compare on its measured data "
                                "(not simulated sets, whose true robot is drawn anew)")
        options["nominal"] = str(as_path(nominal, "nominal"))
    calibration = None if simulate_noise is not None else prepare(robot, data, **options)
    if calibration is not None:
        records = _methods_for_data(calibration, records, default, notify)
    with progress_bar(trials * len(records), "trials x methods") as bar:
        local = jobs == 1 and scheduler is None  # a bar follows only the trials run here
        tick = bar.update if bar is not None and local else None
        out, what = _trials(robot, calibration, records, trials, seed, test_fraction, simulate_noise, noise_mm,
                            poses, options, (jobs, scheduler), tick, (checkpoint, notify))
    start = f", started from {Path(nominal).name}" if nominal is not None else ""
    return Comparison(robot=robot, methods=[r.name for r in records], trials=out, data=what + _compliance_words(record) + start)


def _methods_for_data(calibration: Calibration, methods: list[Method], default: bool,
                      notify: Callable[[str], Any] | None) -> list[Method]:
    """``methods`` less, when they are the default, those the data's sensors refuse.

    Refused: rows of several sizes, ``unsupported_methods``; said through ``notify``.
    Asked-for methods are never dropped, but refused as :func:`calib_pin.solve` refuses them.
    """
    kinds = set(calibration.kinds)
    unsupported = {m for k in kinds for m in getattr(sensor_for(k), "unsupported_methods", ())}
    if len(calibration.sets) > 1:
        unsupported |= {m.name for m in methods if not m.kinematic}
    refused = [m.name for m in methods if m.name in unsupported] if default else []
    if refused and notify is not None:
        names = ", ".join(sorted({sensor_for(k).data_name for k in kinds
                                  if set(refused) & set(getattr(sensor_for(k), "unsupported_methods", ()))}))
        why = (f"they need rows of one size, and {names} rows differ in size" if names
               else "they learn one set-up's values, and several sets are fitted as one robot")
        notify(f"left out {', '.join(refused)}: {why} (--methods chooses)")
    kept = [m for m in methods if m.name not in refused]
    for m in kept:
        check_method(m, calibration)
    return kept


def _trials(robot: str, calibration: Calibration | None, methods: list[Method], trials: int, seed: int,
            test_fraction: float, simulate_noise: str | None, noise_mm: float, poses: int, options: dict[str, Any],
            where: tuple[int, str | None], tick: Callable[[], Any] | None,
            keep: tuple[str | Path | None, Callable[[str], Any] | None] = (None, None)) -> tuple[list[Trial], str]:
    """The trials of :func:`compare` and what they ran on.

    Run in ``where`` = (jobs, scheduler), kept in ``keep`` = (checkpoint folder, notify).
    """
    seeds = range(seed, seed + trials)
    settings: list[Any] = [robot, file_digest(robot), [m.name for m in methods], test_fraction, _plain_options(options)]
    if "nominal" in options:  # the start's content, not only its name
        settings += ["nominal", file_digest(options["nominal"])]
    split = f", {trials} split(s) of seeds {seed}..{seed + trials - 1}" if trials > 1 else f", split seed {seed}"
    if calibration is not None:
        truths = truths_of(calibration)
        one = partial(run_trial, calibration, truths, methods, test_fraction=test_fraction, tick=tick)
        sets = calibration.sets
        if len(sets) == 1:
            what = f"{sets[0].data.describe_rows()} from {Path(sets[0].data.source).name}"
        else:
            names = [Path(s.data.source).name if s.data.source else s.label for s in sets]
            what = f"{len(calibration.data)} rows of {len(sets)} sets stacked ({', '.join(names)})"
        settings += ["data", [[s.data.source, file_digest(s.data.source)] for s in sets],
                     "truths", None if truths is None else [file_digest(_truth_file(s.data.source)) for s in sets]]
        return _run_trials(one, seeds, settings, where, keep), what + split
    chain = load_chain(robot)
    params = parameter_model(chain, options.get("parameters"))
    one = partial(_simulated_trial, robot, chain, params, methods, test_fraction, poses, noise_mm, str(simulate_noise),
                  options, tick=tick)
    what = f"simulated sets of {poses} poses, {simulate_noise} noise {noise_mm:g} mm, seed(s) {seed}..{seed + trials - 1}"
    settings += ["simulated", poses, noise_mm, simulate_noise]
    return _run_trials(one, seeds, settings, where, keep), what


def _truth_file(source: str) -> str:
    """The truth file a measured set's fresh-pose score reads (its own, or its sessions')."""
    path = Path(source)
    stem = path.name.removesuffix(".csv")
    own = path.with_name(stem + ".truth.json")
    return str(own if own.is_file() else path.with_name(stem.rpartition("_")[0] + ".truth.json"))


def _plain_options(options: dict[str, Any]) -> dict[str, Any]:
    """The options as a checkpoint's fingerprint reads them (records as their fields)."""
    import dataclasses

    return {k: dataclasses.asdict(v) if dataclasses.is_dataclass(v) and not isinstance(v, type) else v
            for k, v in options.items()}


def _run_trials(one: Callable[[int], Trial], seeds: range, settings: list, where: tuple[int, str | None],
                keep: tuple[str | Path | None, Callable[[str], Any] | None]) -> list[Trial]:
    """``one(seed)`` for each seed; with a checkpoint folder, each trial kept as it finishes.

    Kept under the fingerprint of ``settings`` (what a trial depends on) and its seed.
    """
    folder, notify = keep
    if folder is None:
        return parallel_map(one, seeds, *where)
    keys = [fingerprint("compare-trial", *settings, s) for s in seeds]
    return Checkpoint(folder, "trial").map(one, list(seeds), keys, encode=Trial.to_json, decode=Trial.from_json,
                                           jobs=where[0], scheduler=where[1], notify=notify)


def _compliance_words(compliance: Compliance | None) -> str:
    """What the comparison estimates beyond geometry, in words (empty for geometry only)."""
    if not compliance:
        return ""
    return f"; with the compliance of {compliance.words()}"


def __getattr__(name: str) -> Any:
    """The old names of two renamed functions, with a DeprecationWarning."""
    from ..util.deprecation import moved_names

    return moved_names(__name__, {
        "session_truths": "calib_pin.studies.comparison:truths_of",
        "stacked_fresh_scorer": "calib_pin.studies.comparison:fresh_scorer"})(name)

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
from ..calibration.multiset import StackedSetup
from ..calibration.pipeline import CalibrationSetup, prepare
from ..estimators import PAPER_LABELS, PAPER_METHODS, get_method, run_estimator
from ..estimators.problem import CalibrationProblem, data_row_errors
from ..exceptions import ArgumentError, CalibPinError
from ..parameters import ParameterModel, parameter_model
from ..robot import Chain, load_chain
from ..robot.deflection import Compliance, as_compliance
from ..robot.poses import random_poses
from ..sensors import sensor_for
from ..simulation.simulate import Truth, simulate
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


def fresh_scorer(setup: CalibrationSetup, truth: Truth | None, seed: int) -> Callable:
    """score(predict) -> RMSE [mm] of ``predict(q, points)`` [m] on fresh poses (every
    point the sensor measures, at each) against the noise-free truth, or None when the
    truth is unknown."""
    if truth is None:
        return lambda predict: None
    poses = random_poses(setup.chain, FRESH_POSES, np.random.default_rng(seed + 10_000))
    model = truth.model(setup.chain, setup.params)
    rows, points = model.grid_points(len(poses))
    q = poses[rows]
    true_values = model.predict(truth.x_model, q, points)
    return lambda predict: float(np.sqrt(np.mean(model.fresh_difference(predict(q, points), true_values) ** 2)) * 1e3)


def start_x(start: Any, problem: Any, training: Any) -> np.ndarray:
    """Where every method starts: zero deviations, or ``start``'s (``nominal``,
    :class:`~calib_pin.calibration.start.Start`) with the sensor's geometry refitted on the
    ``training`` rows to it, as :func:`calib_pin.calibrate` starts."""
    x0 = np.zeros(problem.n_params)
    if start is None:
        return x0
    model = problem.model
    x0[:model.n_robot] = start.robot_x
    if start.compliance is not None:
        x0[model.n_robot:model.sensor_start] = start.compliance
    return start.sensor_fit(training, x0)


def _trial(setup: CalibrationSetup, truth: Truth | None, methods: list[str], seed: int,
           test_fraction: float, tick: Callable[[], Any] | None = None) -> Trial:
    train, test = setup.split(test_fraction, seed)
    if not len(test):
        raise CalibPinError(f"a comparison needs held-out rows: {len(setup.data)} rows at test fraction "
                            f"{test_fraction:g} hold out none (use more poses or a larger test fraction)")
    problem: CalibrationProblem = setup.problem_on(train)  # nothing fitted on test rows
    train_problem, test_problem = problem.subset(train), problem.subset(test)
    model = problem.model
    x0 = start_x(setup.start, problem, train_problem)
    fresh = fresh_scorer(setup, truth, seed)
    runs = {}
    for m in methods:
        est = run_estimator(m, train_problem, x0, seed=seed, noise=setup.noise)
        k, evals = est.converged(CONVERGED_TOLERANCE)
        residual = data_row_errors(test_problem, est.residual(test_problem))
        runs[m] = MethodRun(
            method=m, label=PAPER_LABELS[m],
            train=Metrics.of(data_row_errors(train_problem, est.residual(train_problem))), test=Metrics.of(residual),
            fresh_rmse_mm=fresh(lambda q, points, est=est: est.predict(model, q, points)),
            iterations=est.iterations, evaluations=est.nfev,
            converged_iterations=k, converged_evaluations=evals, time_s=est.time_s,
            history_mm=[h * 1e3 for h in est.history], history_evaluations=list(est.evaluations),
            test_residual_mm=residual * 1e3,
        )
        if tick is not None:
            tick()
    before = data_row_errors(test_problem, test_problem.residual(x0))
    return Trial(
        seed=seed, source=setup.data.source or "simulated", before=Metrics.of(before),
        before_fresh_rmse_mm=fresh(lambda q, points: model.predict(x0, q, points)),
        before_residual_mm=before * 1e3, runs=runs,
    )


def session_truths(setup: StackedSetup) -> list[Truth] | None:
    """Each set's truth, when every set has one and they are of one true robot: a set's own
    ``FILE.truth.json``, or session k of ``BASE.truth.json`` for ``BASE_k.csv`` (the files
    ``simulate --sessions K`` writes); None otherwise, or for another parameter model than
    the robot's default (the truth's)."""
    if setup.params.name != parameter_model(setup.chain).name:
        return None
    out: list[Truth] = []
    for data in setup.sets:
        if not data.source:
            return None
        path = Path(data.source)
        stem = path.name.removesuffix(".csv")
        base, _, k = stem.rpartition("_")
        own, shared = path.with_name(stem + ".truth.json"), path.with_name(base + ".truth.json")
        if own.is_file():
            truth = Truth.from_json(own, setup.params)
            if truth.sessions:
                return None
        elif base and k.isdigit() and shared.is_file():
            truth = Truth.from_json(shared, setup.params)
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


def stacked_fresh_scorer(setup: StackedSetup, truths: list[Truth] | None, seed: int) -> Callable:
    """score(model, x) -> RMSE [mm] over every set's sensor at the same fresh poses (each at
    its own points) of ``model`` (a :class:`~calib_pin.calibration.problem.StackedModel`) at the stacked
    ``x`` against each set's noise-free truth, the sets' values pooled as one set's are;
    None without every set's truth, or when the sets' errors are in different units."""
    from ..calibration.multiset import value_unit

    if truths is None:
        return lambda model, x: None
    poses = random_poses(setup.chain, FRESH_POSES, np.random.default_rng(seed + 10_000))
    cases = []
    for truth in truths:
        model = truth.model(setup.chain, setup.params)
        rows, points = model.grid_points(len(poses))
        q = poses[rows]
        cases.append((q, points, model.predict(truth.x_model, q, points)))

    def score(model: Any, x: np.ndarray) -> float | None:
        if len({value_unit(part) for part in model.parts}) > 1:
            return None
        error = np.concatenate([model.parts[k].fresh_difference(model.parts[k].predict(model.part_x(x, k), q, points),
                                                                true).ravel()
                                for k, (q, points, true) in enumerate(cases)])
        return float(np.sqrt(np.mean(error**2)) * 1e3)

    return score


def _stacked_trial(setup: StackedSetup, methods: list[str], seed: int, test_fraction: float,
                   tick: Callable[[], Any] | None = None, truths: list[Truth] | None = None) -> Trial:
    """One trial on several measurement sets fitted together: every set split by pose with
    the trial's seed (:meth:`~calib_pin.calibration.multiset.StackedSetup.split`), each method fitted as
    :func:`calib_pin.calibrate` of the sets fits it (each set weighted by its noise), and
    scored on the held-out rows of every set, each row's error in its own set's unit [mm],
    and with ``truths`` (:func:`session_truths`) on fresh poses against them
    (:func:`stacked_fresh_scorer`)."""
    runs = {}
    before: np.ndarray | None = None
    fresh = stacked_fresh_scorer(setup, truths, seed)
    before_fresh = None
    for m in methods:
        result = setup.run(m, seed=seed, test_fraction=test_fraction)
        if not len(result.test):
            raise CalibPinError(f"a comparison needs held-out rows: {len(setup.data)} rows at test fraction "
                                f"{test_fraction:g} hold out none (use more poses or a larger test fraction)")
        est, problem = result.estimate, result.problem
        train_problem, test_problem = problem.subset(result.train), problem.subset(result.test)
        k, evals = est.converged(CONVERGED_TOLERANCE)
        residual = data_row_errors(test_problem, est.residual(test_problem))
        runs[m] = MethodRun(
            method=m, label=PAPER_LABELS[m],
            train=Metrics.of(data_row_errors(train_problem, est.residual(train_problem))), test=Metrics.of(residual),
            fresh_rmse_mm=fresh(problem.model, est.x), iterations=est.iterations, evaluations=est.nfev,
            converged_iterations=k, converged_evaluations=evals, time_s=est.time_s,
            history_mm=[h * 1e3 for h in est.history], history_evaluations=list(est.evaluations),
            test_residual_mm=residual * 1e3,
        )
        if before is None:  # every method starts from the same sensor geometry, fitted on the same rows
            x0 = start_x(setup.start, problem, train_problem)  # zero, or the start's (setup.run's)
            before = data_row_errors(test_problem, test_problem.residual(x0))
            before_fresh = fresh(problem.model, x0)
        if tick is not None:
            tick()
    assert before is not None  # methods is not empty
    return Trial(seed=seed, source=setup.data.source or "stacked", before=Metrics.of(before),
                 before_fresh_rmse_mm=before_fresh, before_residual_mm=before * 1e3, runs=runs)


def _simulated_trial(robot: str, chain: Chain, params: ParameterModel, methods: list[str], test_fraction: float,
                     poses: int, noise_mm: float, noise_kind: str, soft: dict[str, Any], seed: int,
                     tick: Callable[[], Any] | None = None) -> Trial:
    """One trial on a fresh simulated set of seed ``seed`` (a picklable unit of work)."""
    sim, truth = simulate(chain, params, poses, seed, noise_mm=noise_mm, noise_kind=noise_kind)
    return _trial(prepare(robot, sim, **soft), truth, methods, seed, test_fraction, tick)


def compare(
    robot: str,
    data: str | Path | list[str | Path] | tuple[str | Path, ...] | None = None,
    *,
    methods: list[str] | None = None,
    trials: int = 1,
    seed: int = 0,
    test_fraction: float = 0.2,
    simulate_noise: str | None = None,
    noise_mm: float = 0.05,
    poses: int = 120,
    compliance: Compliance | str | tuple[str, ...] | None = None,
    payload_kg: float | None = None,
    payload_com_mm: Any = None,
    cable_tension_n: float | None = None,
    parameters: str | None = None,
    estimate: tuple[str, ...] | str = (),
    jobs: int = 1,
    scheduler: str | None = None,
    checkpoint: str | Path | None = None,
    notify: Callable[[str], Any] | None = None,
    nominal: str | Path | None = None,
) -> Comparison:
    """Run estimators side by side.

    Args:
        robot: Robot name or URDF path.
        data: Measurement CSV; None uses the robot's shipped set. Several CSVs (a list):
            the comparison runs on those sets stacked, one robot and each set its own
            sensor set-up (as :func:`calib_pin.calibrate` of a list); each trial splits
            every set by pose with the trial's seed. Ignored when ``simulate_noise`` is given.
        methods: Method names (default: the paper's nine, M1..M9).
        trials: Number of trials. On a measurement set, trial i uses the split of seed
            ``seed + i``; with ``simulate_noise``, trial i also simulates a new set of
            seed ``seed + i``.
        seed: First seed.
        test_fraction: Share of rows held out (the paper's 0.2).
        simulate_noise: ``gauss``, ``student`` or ``outliers``: run on simulated sets of
            ``poses`` poses with that noise of size ``noise_mm`` [mm] (1 sigma).
        compliance: Joint compliances to estimate with the geometry, and their loads: a
            :class:`~calib_pin.robot.deflection.Compliance` or joint names (as
            :func:`calib_pin.calibrate`); payload_kg, payload_com_mm, cable_tension_n: its
            deprecated loose aliases.
        parameters: Parameter model (``dh``, ``hayati``, ``placement``; default as
            :func:`calib_pin.calibrate`).
        estimate: Sensor geometry to estimate (``anchor``, ``offset``; as
            :func:`calib_pin.calibrate`).
        jobs, scheduler: Run the trials in ``jobs`` local processes, or on the Dask
            cluster at ``scheduler`` (see :func:`calib_pin.studies.parallel.parallel_map`); the
            results do not depend on it (each trial is seeded), only the time does.
        checkpoint: Folder in which each finished trial is kept as it finishes
            (``<checkpoint>/.calib-pin-checkpoint``), and from which a comparison of the
            same data and settings takes the trials already done; None keeps nothing.
            The caller removes it (:meth:`calib_pin.studies.checkpoint.Checkpoint.clear`) once
            the outputs are written.
        notify: Called with one line when kept trials are reused.
        nominal: Start every method from a robot's own kinematics instead of the catalogue
            URDF (as :func:`calib_pin.calibrate`'s ``nominal``); measured data only.

    Raises:
        CalibPinError: bad method, robot, data or settings.
        calib_pin.studies.parallel.ParallelFault: a worker or the scheduler failed (the finished
            trials are kept when ``checkpoint`` is given).
        calib_pin.studies.checkpoint.Interrupted: Ctrl-C with a ``checkpoint``; the finished trials are kept.
    """
    default = methods is None
    methods = list(PAPER_METHODS) if methods is None else list(methods)
    for m in methods:
        get_method(m)
    if trials < 1:
        raise CalibPinError(f"trials must be at least 1, got {trials}")
    record = as_compliance(compliance, payload_kg=payload_kg, payload_com_mm=payload_com_mm,
                           cable_tension_n=cable_tension_n)
    soft: dict[str, Any] = {"compliance": record}
    if parameters is not None:  # only when given: the checkpoints of earlier runs stay valid
        soft["parameters"] = parameters
    if estimate:
        soft["estimate"] = estimate
    if nominal is not None:  # only when given, as parameters
        if simulate_noise is not None:
            raise ArgumentError("nominal", "starts from a robot's own calibration: compare on its measured data "
                                "(not simulated sets, whose true robot is drawn anew)")
        soft["nominal"] = str(as_path(nominal, "nominal"))
    if default and simulate_noise is None:
        methods = _methods_for_data(robot, data, soft, methods, notify)
    with progress_bar(trials * len(methods), "trials x methods") as bar:
        local = jobs == 1 and scheduler is None  # a bar follows only the trials run here
        tick = bar.update if bar is not None and local else None
        out, what = _trials(robot, data, methods, trials, seed, test_fraction, simulate_noise, noise_mm, poses,
                            soft, (jobs, scheduler), tick, (checkpoint, notify))
    start = f", started from {Path(nominal).name}" if nominal is not None else ""
    return Comparison(robot=robot, methods=methods, trials=out, data=what + _compliance_words(record) + start)


def _methods_for_data(robot: str, data: Any, soft: dict[str, Any], methods: list[str],
                      notify: Callable[[str], Any] | None) -> list[str]:
    """The default ``methods`` less those the data's sensors refuse (rows of several sizes:
    ``unsupported_methods``), said through ``notify``; asked-for methods are never dropped."""
    sets = list(data) if isinstance(data, list | tuple) else [data]
    setup = prepare(robot, [str(d) for d in sets] if len(sets) > 1 else sets[0], **soft)
    kinds = {d.kind for d in setup.sets} if isinstance(setup, StackedSetup) else {setup.data.kind}
    refused = [m for m in methods if any(m in getattr(sensor_for(k), "unsupported_methods", ()) for k in kinds)]
    if refused and notify is not None:
        names = ", ".join(sorted({sensor_for(k).data_name for k in kinds
                                  if set(refused) & set(getattr(sensor_for(k), "unsupported_methods", ()))}))
        notify(f"left out {', '.join(refused)}: they need rows of one size, and {names} rows differ in size "
               "(--methods chooses)")
    return [m for m in methods if m not in refused]


def _trials(robot: str, data: Any, methods: list[str], trials: int, seed: int, test_fraction: float,
            simulate_noise: str | None, noise_mm: float, poses: int, soft: dict[str, Any],
            where: tuple[int, str | None], tick: Callable[[], Any] | None,
            keep: tuple[str | Path | None, Callable[[str], Any] | None] = (None, None)) -> tuple[list[Trial], str]:
    """The trials of :func:`compare` (in ``where`` = (jobs, scheduler), kept in
    ``keep`` = (checkpoint folder, notify)) and what they ran on."""
    seeds = range(seed, seed + trials)
    settings = [robot, file_digest(robot), methods, test_fraction, soft]
    if "nominal" in soft:  # the start's content, not only its name
        settings += ["nominal", file_digest(soft["nominal"])]
    if simulate_noise is None and isinstance(data, list | tuple) and len(data) > 1:
        return _stacked_trials(robot, list(data), methods, trials, seed, test_fraction, soft, settings, where, tick,
                               keep)
    if simulate_noise is None and isinstance(data, list | tuple):
        data = data[0] if data else None
    if simulate_noise is None:
        setup = prepare(robot, data, **soft)
        for m in methods:
            get_method(m).check(kind=setup.data.kind)
        truth_file = Path(setup.data.source).with_name(
            Path(setup.data.source).name.removesuffix(".csv") + ".truth.json")
        # a shipped truth is in the robot's default parameter model: another one has no fresh-pose score
        default = setup.params.name == parameter_model(setup.chain).name
        truth = Truth.from_json(truth_file, setup.params) if setup.data.source and truth_file.is_file() and default \
            else None
        one = partial(_trial, setup, truth, methods, test_fraction=test_fraction, tick=tick)
        what = f"{setup.data.describe_rows()} from {Path(setup.data.source).name}"
        what += f", {trials} split(s) of seeds {seed}..{seed + trials - 1}" if trials > 1 else f", split seed {seed}"
        settings += ["data", setup.data.source, file_digest(setup.data.source), file_digest(truth_file)]
        return _run_trials(one, seeds, settings, where, keep), what
    chain = load_chain(robot)
    params = parameter_model(chain, soft.get("parameters"))
    one = partial(_simulated_trial, robot, chain, params, methods, test_fraction, poses, noise_mm, simulate_noise,
                  soft, tick=tick)
    what = f"simulated sets of {poses} poses, {simulate_noise} noise {noise_mm:g} mm, seed(s) {seed}..{seed + trials - 1}"
    settings += ["simulated", poses, noise_mm, simulate_noise]
    return _run_trials(one, seeds, settings, where, keep), what


def _stacked_trials(robot: str, data: list[Any], methods: list[str], trials: int, seed: int, test_fraction: float,
                    soft: dict[str, Any], settings: list, where: tuple[int, str | None], tick: Callable[[], Any] | None,
                    keep: tuple[str | Path | None, Callable[[str], Any] | None]) -> tuple[list[Trial], str]:
    """The trials of :func:`compare` on several sets stacked, and what they ran on."""
    for d in data:
        if not isinstance(d, str | Path):
            raise ArgumentError("data", f"expected measurement CSV paths, got {type(d).__name__} in the list")
    setup = prepare(robot, [str(d) for d in data], **soft)
    assert isinstance(setup, StackedSetup)
    for m in methods:
        spec = get_method(m)
        spec.check(kind=setup.sets[0].kind)
        if not spec.kinematic:
            raise CalibPinError(f"method '{m}' learns a correction of one sensor's values: with several sets "
                                "compare parameter methods (lm, ekf-qibas, ...)")
    truths = session_truths(setup)
    one = partial(_stacked_trial, setup, methods, test_fraction=test_fraction, tick=tick, truths=truths)
    names = [Path(s.source).name if s.source else label for s, label in zip(setup.sets, setup.labels, strict=True)]
    what = f"{len(setup.data)} rows of {len(setup.sets)} sets stacked ({', '.join(names)})"
    what += f", {trials} split(s) of seeds {seed}..{seed + trials - 1}" if trials > 1 else f", split seed {seed}"
    settings += ["sets", [[s.source, file_digest(s.source)] for s in setup.sets], "truths", truths is not None]
    return _run_trials(one, range(seed, seed + trials), settings, where, keep), what


def _run_trials(one: Callable[[int], Trial], seeds: range, settings: list, where: tuple[int, str | None],
                keep: tuple[str | Path | None, Callable[[str], Any] | None]) -> list[Trial]:
    """``one(seed)`` for each seed; with a checkpoint folder, each trial kept as it finishes,
    under the fingerprint of ``settings`` (what a trial depends on) and its seed."""
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

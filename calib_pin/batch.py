"""Many calibrations at once: local processes (joblib) or an existing Dask cluster.

A :class:`BatchTask` is one calibration of one measurement set. :func:`run_batch` runs
many of them with :func:`parallel_map` and writes, per set, ``<out>/<set stem>/report.json``
and the corrected URDF, plus one ``summary.csv`` row per set. A set that fails (a bad
file, a runaway estimate) gets ``status=failed`` and its one-line error in the summary;
the other sets go on.

Where a task runs never changes its result: every task carries its own seed, and each
runs with one BLAS thread (:mod:`threadpoolctl`), so the floating-point work is the same
in a worker process, a Dask worker or this process. One BLAS thread per task is also
what a full machine wants: N tasks on N cores, no oversubscription.

The measurement files must be readable at the same path by every worker (a shared
filesystem, as for any Dask file input); the outputs are written by the calling process.
"""

from __future__ import annotations

import csv
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from .exceptions import CalibPinError
from .optional import require
from .report import build_report

T = TypeVar("T")
R = TypeVar("R")

#: Columns of ``summary.csv``; errors in [mm], time in [s].
SUMMARY_COLUMNS = (
    "set", "status", "error", "method", "seed", "rows",
    *(f"{split}_{stat}_{stage}_mm" for split in ("train", "test") for stat in ("rmse", "mean", "max")
      for stage in ("before", "after")),
    "time_s",
)


@dataclass(frozen=True)
class BatchTask:
    """One calibration of one measurement set.

    Attributes:
        robot: Robot name or URDF path (``irb120``); None takes the file's
            ``# robot:`` line.
        data: Measurement CSV, readable at this path where the task runs.
        method: Estimator name.
        seed: Seed of the split and the estimator: the task's result depends on it only.
        options: Further keyword arguments of :func:`calib_pin.pipeline.calibrate`
            (``test_fraction``, ``loss``, ``parameters``, ``noise_mm``, ...).
    """

    robot: str | None
    data: str
    method: str = "lm"
    seed: int = 0
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        """The set's name: the data file's stem (``session_03``)."""
        return Path(self.data).name.removesuffix(".csv")


@dataclass
class TaskOutcome:
    """What one task returns to the calling process.

    Attributes:
        name: The set's name.
        status: ``ok`` or ``failed``.
        error: One-line error of a failed set, else empty.
        row: Its ``summary.csv`` row (keys of :data:`SUMMARY_COLUMNS`).
        report: The calibration report (``report.json``), or None if it did not run.
        urdf_name, urdf_text: File name and text of the corrected URDF, or None.
    """

    name: str
    status: str
    error: str
    row: dict[str, Any]
    report: dict | None = None
    urdf_name: str | None = None
    urdf_text: str | None = None


def _one_line(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    first = text[0] if text else ""
    if isinstance(error, CalibPinError):
        return first or type(error).__name__
    return f"{type(error).__name__}: {first}" if first else type(error).__name__


def _limited(fn: Callable[[T], R]) -> Callable[[T], R]:
    return _Limited(fn)


class _Limited:
    """``fn`` run with one BLAS/OpenMP thread (picklable, unlike a closure)."""

    def __init__(self, fn: Callable) -> None:
        self.fn = fn

    def __call__(self, item):
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1):
            return self.fn(item)


def parallel_map(
    fn: Callable[[T], R], items: Sequence[T], jobs: int = 1, scheduler: str | None = None
) -> list[R]:
    """``[fn(item) for item in items]``, in order, here or on workers.

    Args:
        fn: A picklable function (module level) of one item.
        items: Its arguments (picklable).
        jobs: Local worker processes (joblib, ``loky``); 1 runs in this process as a
            plain loop, with the BLAS threads left as they are.
        scheduler: Address of a running Dask scheduler (``tcp://host:8786``); when
            given, ``jobs`` is ignored and the items run on the cluster's workers.

    Workers run ``fn`` with one BLAS thread. An exception in ``fn`` propagates; catch it
    inside ``fn`` to keep the other items going (as :func:`run_task` does).

    Raises:
        CalibPinError: jobs below 1, or the scheduler cannot be reached.
    """
    items = list(items)
    if jobs < 1:
        raise CalibPinError(f"jobs must be at least 1, got {jobs}")
    if scheduler:
        return _dask_map(_limited(fn), items, scheduler)
    if jobs == 1 or len(items) <= 1:
        return [fn(item) for item in items]
    joblib = require("joblib")
    limited = _limited(fn)
    return list(joblib.Parallel(n_jobs=min(jobs, len(items)), backend="loky")(joblib.delayed(limited)(i) for i in items))


def _dask_map(fn: Callable, items: list, scheduler: str) -> list:
    distributed = require("distributed")
    from distributed.comm.addressing import get_address_host_port

    try:  # a malformed address would otherwise fail inside Client and leave it hanging 20 s
        get_address_host_port(scheduler)
    except ValueError as e:
        raise CalibPinError(f"'{scheduler}' is not a Dask scheduler address ({e}); give tcp://host:port") from None
    try:
        client = distributed.Client(scheduler, timeout="10s", set_as_default=False)
    except (OSError, TimeoutError) as e:
        raise CalibPinError(f"cannot reach the Dask scheduler at {scheduler}: {_one_line(e)}") from None
    with client:
        try:
            return client.gather(client.map(fn, items, pure=False))
        except Exception as e:  # noqa: BLE001 - a cluster's failure is one line, not a traceback
            raise CalibPinError(
                f"the Dask cluster at {scheduler} could not run the tasks ({_one_line(e)}): the "
                "scheduler and every worker must import the same calib-pin as this process"
            ) from None


def run_task(task: BatchTask) -> TaskOutcome:
    """Calibrate one set and return its report, URDF text and summary row.

    Never raises for a bad set: the error becomes ``status=failed`` and one line.
    """
    from .pipeline import calibrate

    start = time.perf_counter()
    row: dict[str, Any] = {"set": task.name, "method": task.method, "seed": task.seed}
    try:
        result = calibrate(_robot(task), task.data, method=task.method, seed=task.seed, **task.options)
        report = build_report(result)
        row["rows"] = len(result.data)
        for split, stages in result.metrics.items():
            for stage, m in stages.items():
                for stat, value in m.as_dict().items():
                    row[f"{split}_{stat.removesuffix('_mm')}_{stage}_mm"] = f"{value:.6f}"
        urdf_name, urdf_text, error = _urdf(result)
    except Exception as e:  # noqa: BLE001 - a failing set must not stop the others
        report, urdf_name, urdf_text, error = None, None, None, _one_line(e)
    row["time_s"] = f"{time.perf_counter() - start:.3f}"
    status = "failed" if error else "ok"
    row.update(status=status, error=error)
    return TaskOutcome(task.name, status, error, row, report, urdf_name, urdf_text)


def _robot(task: BatchTask) -> str:
    if task.robot is not None:
        return task.robot
    from .measurements import read_measurements

    robot = read_measurements(task.data).robot
    if robot is None:
        raise CalibPinError(f"{task.data}: no robot named: add '# robot: NAME' to the file or pass --robot")
    return robot


def _urdf(result) -> tuple[str | None, str | None, str]:
    """(file name, text, error) of the corrected URDF; no URDF for ``rbf``, an error
    line for a deviation beyond the sanity bound."""
    if not result.kinematic:
        return None, None, ""
    refused = result.sanity_error()
    if refused:
        return None, None, refused
    name = f"{result.chain.name}_calibrated.urdf"
    with tempfile.TemporaryDirectory() as tmp:
        return name, result.to_urdf(Path(tmp) / name).read_text(encoding="utf-8"), ""


def write_outcome(outcome: TaskOutcome, out: Path) -> None:
    """Write a set's ``report.json`` (even when its URDF was refused) and URDF under ``out/<set>/``."""
    import json

    from .cli.outputs import Outputs

    if outcome.report is None:
        return
    files = Outputs(out / outcome.name)
    report = dict(outcome.report)
    report["urdf"] = str(files.folder / outcome.urdf_name) if outcome.urdf_name else None
    text = json.dumps(report, indent=2, allow_nan=False) + "\n"
    files.add(files.folder / "report.json", lambda tmp: tmp.write_text(text, encoding="utf-8"))
    if outcome.urdf_name and outcome.urdf_text is not None:
        urdf = outcome.urdf_text
        files.add(files.folder / outcome.urdf_name, lambda tmp: tmp.write_text(urdf, encoding="utf-8"))
    files.commit()


def write_summary(outcomes: Sequence[TaskOutcome], path: Path) -> Path:
    """Write ``summary.csv``: one row per set in :data:`SUMMARY_COLUMNS` order."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=SUMMARY_COLUMNS, restval="")
        writer.writeheader()
        for outcome in outcomes:
            writer.writerow(outcome.row)
    return path


def _check_names(tasks: Sequence[BatchTask]) -> None:
    seen: dict[str, str] = {}
    for task in tasks:
        if task.name in seen:
            raise CalibPinError(
                f"two sets share the name '{task.name}' ({seen[task.name]}, {task.data}): "
                "their outputs would overwrite each other under the same folder"
            )
        seen[task.name] = task.data


def run_batch(
    tasks: Sequence[BatchTask], *, out: str | Path = "out/batch", jobs: int = 1, scheduler: str | None = None
) -> list[TaskOutcome]:
    """Calibrate many sets; write their outputs and ``<out>/summary.csv``.

    Args:
        tasks: One task per measurement set (set names, the file stems, must differ).
        out: Output folder: ``<out>/<set>/report.json``, ``<out>/<set>/<robot>_calibrated.urdf``
            and ``<out>/summary.csv``.
        jobs: Local worker processes (1: this process).
        scheduler: Address of a running Dask scheduler, instead of local processes.

    Returns:
        One outcome per task, in the tasks' order.

    Raises:
        CalibPinError: duplicate set names, jobs below 1, an unreachable scheduler.
    """
    tasks = list(tasks)
    _check_names(tasks)
    outcomes = parallel_map(_limited(run_task), tasks, jobs=jobs, scheduler=scheduler)
    out = Path(out)
    for outcome in outcomes:
        write_outcome(outcome, out)
    write_summary(outcomes, out / "summary.csv")
    return outcomes

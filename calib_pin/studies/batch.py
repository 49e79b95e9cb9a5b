"""Many calibrations at once: local processes (joblib) or an existing Dask cluster.

A :class:`BatchTask` is one calibration of one measurement set. :func:`run_batch` runs
many of them with :func:`parallel_map` and writes, per set, ``<out>/<set stem>/``: the
corrected URDF, the calibration file and ``report.json``, as ``calibrate`` does
(:mod:`calib_pin.report.bundle`: a fit beyond the sanity bound gets report.json only),
plus one ``summary.csv`` row per set. A set that fails (a bad
file, a runaway estimate) gets ``status=failed`` and its one-line error in the summary;
the other sets go on.

Where a task runs never changes its result: every task carries its own seed, and each
runs with one BLAS thread (:mod:`threadpoolctl`), so the floating-point work is the same
in a worker process, a Dask worker or this process. One BLAS thread per task is also
what a full machine wants: N tasks on N cores, no oversubscription.

The measurement files must be readable at the same path by every worker (a shared
filesystem, as for any Dask file input); the outputs are written by the calling process.

Nothing finished is lost: each set's outcome is kept in ``<out>/.calib-pin-checkpoint``
as soon as it is done (:mod:`calib_pin.studies.checkpoint`), so after Ctrl-C, a killed worker or
a lost scheduler the same command runs only the sets not yet done. The outputs are
written at the end, all together (:class:`calib_pin.util.outputs.Outputs`), and no file
of an earlier run is left beside a set that fails in this one.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..exceptions import CalibPinError
from ..util.outputs import Outputs
from .checkpoint import Checkpoint, Interrupted, file_digest, fingerprint
from .parallel import ParallelFault, error_line, limited, parallel_completed, parallel_map

__all__ = ["NAME_LIMIT", "SUMMARY_COLUMNS", "BatchTask", "ParallelFault", "TaskOutcome", "folder_name",
           "parallel_completed", "parallel_map", "run_batch", "run_task", "task_key", "write_outcome", "write_summary"]

#: Columns of ``summary.csv``; errors in [mm], time in [s].
SUMMARY_COLUMNS = (
    "set", "status", "error", "method", "seed", "rows",
    *(f"{split}_{stat}_{stage}_mm" for split in ("train", "test") for stat in ("rmse", "mean", "max")
      for stage in ("before", "after")),
    "time_s",
)


#: Longest name of a set's output folder, bytes of UTF-8 (a file system's limit is 255).
NAME_LIMIT = 100


def folder_name(stems: Sequence[str]) -> str:
    """The output folder's name of a calibration of files with these stems: joined by ``+``
    when that is a safe folder name (not empty, not hidden, ``.`` or ``..``, at most
    :data:`NAME_LIMIT` bytes), else a safe short form that stays unique: the first stem
    without its leading dots (``set`` if nothing is left), ``+N-more`` for the others, and
    8 hex digits of the joined stems (``session_01+11-more-3fa2c1d0``, ``set-9c1e07aa`` for
    a file ``...csv``)."""
    import hashlib

    joined = "+".join(stems)
    if joined and not joined.startswith(".") and len(joined.encode()) <= NAME_LIMIT:
        return joined
    digest = hashlib.sha256(joined.encode()).hexdigest()[:8]
    head = (stems[0].lstrip(".") if stems else "") or "set"
    more = f"+{len(stems) - 1}-more" if len(stems) > 1 else ""
    room = NAME_LIMIT - len(f"{more}-{digest}".encode())
    head = head.encode()[:room].decode(errors="ignore")  # whole characters only
    return f"{head}{more}-{digest}"


@dataclass(frozen=True)
class BatchTask:
    """One calibration of one measurement set.

    Attributes:
        robot: Robot name or URDF path (``irb120``); None takes the (first) file's
            ``# robot:`` line.
        data: Measurement CSV, readable at this path where the task runs; or several
            (a tuple of paths): one calibration of those sets together, one robot and
            each set its own sensor set-up (:func:`calib_pin.calibrate` of a list).
        method: Estimator name.
        seed: Seed of the split and the estimator: the task's result depends on it only.
        options: Further keyword arguments of :func:`calib_pin.calibrate`
            (``test_fraction``, ``loss``, ``parameters``, ``noise_mm``, ...).
    """

    robot: str | None
    data: str | tuple[str, ...]
    method: str = "lm"
    seed: int = 0
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def files(self) -> tuple[str, ...]:
        """The measurement files of the calibration (one, or each set's)."""
        return (self.data,) if isinstance(self.data, str) else tuple(self.data)

    @property
    def name(self) -> str:
        """The calibration's name, and its output folder's (:func:`folder_name`).

        The data file's stem (``session_03``); with several sets, their stems joined by
        ``+`` (``a+b+c``).
        """
        return folder_name([Path(f).name.removesuffix(".csv") for f in self.files])


@dataclass
class TaskOutcome:
    """What one task returns to the calling process.

    Attributes:
        name: The set's name.
        status: ``ok`` or ``failed``.
        error: One-line error of a failed set, else empty.
        row: Its ``summary.csv`` row (keys of :data:`SUMMARY_COLUMNS`).
        report: The calibration report (``report.json``, without the output paths), or
            None if it did not run.
        urdf_name: File name of the corrected URDF, or None (refused, ``rbf``, failed).
        files: The set's output files besides report.json, file name -> text (the
            corrected URDF, the calibration file).
        exports: Export format -> file name (``{"urdf": "irb120_calibrated.urdf"}``).
        retry: The set failed on a fault of the machine (an OSError: a full disk, a
            permission), not of its data: its outcome is not kept, the next run tries again.
    """

    name: str
    status: str
    error: str
    row: dict[str, Any]
    report: dict | None = None
    urdf_name: str | None = None
    files: dict[str, str] = field(default_factory=dict)
    exports: dict[str, str] = field(default_factory=dict)
    retry: bool = False

    @property
    def urdf_text(self) -> str | None:
        """The corrected URDF's text, or None."""
        return self.files.get(self.urdf_name) if self.urdf_name else None


def run_task(task: BatchTask) -> TaskOutcome:
    """Calibrate one set and return its report, output files and summary row.

    Never raises for a bad set: the error becomes ``status=failed`` and one line.
    """
    from ..calibration.holdout import as_holdout
    from ..calibration.prepare import prepare
    from ..calibration.solve import method_record, solve
    from ..report.bundle import check_exportable, render_outputs

    start = time.perf_counter()
    row: dict[str, Any] = {"set": task.name, "method": task.method, "seed": task.seed}
    try:
        data = task.data if isinstance(task.data, str) else list(task.data)
        options = dict(task.options)  # calibrate()'s: prepare's, the holdout's and the loss
        loss = options.pop("loss", "linear")
        record = method_record(task.method, loss)
        holdout = as_holdout(options.pop("test_fraction", 0.2), options.pop("test_data", None))
        calibration = prepare(_robot(task), data, **options)
        check_exportable(("urdf",), calibration.chain, record.kinematic)  # before the fit, not after it
        result = solve(calibration, record, holdout=holdout, seed=task.seed, loss=loss)
        rendered = render_outputs(result, ("urdf",), html=False)
        report = rendered.report
        row["rows"] = len(result.data)
        for split, stages in result.metrics.items():
            for stage, m in stages.items():
                for stat, value in m.as_dict().items():
                    row[f"{split}_{stat.removesuffix('_mm')}_{stage}_mm"] = f"{value:.6f}"
        files, exports, error = rendered.files, rendered.exports, rendered.refused or ""
    except Exception as e:  # noqa: BLE001 - a failing set must not stop the others
        report, files, exports, error = None, {}, {}, error_line(e)
        retry = isinstance(e, OSError)
    else:
        retry = False
    row["time_s"] = f"{time.perf_counter() - start:.3f}"
    status = "failed" if error else "ok"
    row.update(status=status, error=error)
    return TaskOutcome(task.name, status, error, row, report, exports.get("urdf"), files, exports, retry)


def _robot(task: BatchTask) -> str:
    if task.robot is not None:
        return task.robot
    from ..measurements import read_measurements

    robot = read_measurements(task.files[0]).robot
    if robot is None:
        raise CalibPinError(f"{task.files[0]}: no robot named: add '# robot: NAME' to the file or pass --robot")
    return robot


def write_outcome(outcome: TaskOutcome, out: Path) -> None:
    """Write a set's outputs under ``out/<set>/`` together, and remove what an earlier run left there.

    report.json is written even when its URDF is refused; of a set that fails in this run
    without a report, all an earlier run left is removed.
    """
    files = Outputs(Path(out))
    stale = _earlier_files(Path(out), outcome)
    _add_outcome(files, outcome)
    _remove_stale(stale, files.commit(), files.inputs)


def _add_outcome(files: Outputs, outcome: TaskOutcome) -> None:
    """Queue a set's files and report.json in ``files`` (an Outputs of the batch folder)."""
    if outcome.report is None:
        return
    from ..report.bundle import RenderedOutputs, add_outputs

    report = dict(outcome.report)
    rendered = RenderedOutputs(str(report.get("robot", "")), dict(outcome.files), dict(outcome.exports), report,
                               outcome.error or None)
    add_outputs(files, rendered, files.folder / outcome.name)


def _earlier_files(out: Path, outcome: TaskOutcome) -> list[Path]:
    """The files an earlier batch run wrote for the set.

    Its report.json, the files that report names, and what a calibration of its robot (or
    this run's) writes.
    """
    from ..report.bundle import stale_files

    folder = out / outcome.name
    robots = [str(outcome.report["robot"])] if outcome.report and outcome.report.get("robot") else []
    report = folder / "report.json"
    if not report.is_file():
        return [path for robot in robots for path in stale_files(folder, robot)]
    files = [report]
    try:
        earlier = json.loads(report.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        earlier = None
    if isinstance(earlier, dict):
        named = [earlier.get("urdf"), *(earlier.get("exports") or {}).values()] \
            if isinstance(earlier.get("exports") or {}, dict) else [earlier.get("urdf")]
        files += [folder / Path(p).name for p in named if isinstance(p, str) and Path(p).name]
        if isinstance(earlier.get("robot"), str) and earlier["robot"]:
            robots.insert(0, earlier["robot"])
    return files + [path for robot in dict.fromkeys(robots) for path in stale_files(folder, robot)]


def _remove_stale(stale: Sequence[Path], written: Sequence[Path], inputs: Any = None) -> None:
    """Remove the earlier run's files this run did not write (never an input), and a set folder left empty."""
    from ..report.bundle import remove_stale

    for path in remove_stale(stale, written, inputs):
        try:
            path.parent.rmdir()  # only when empty
        except OSError:
            pass


def write_summary(outcomes: Sequence[TaskOutcome], path: Path) -> Path:
    """Write ``summary.csv``: one row per set in :data:`SUMMARY_COLUMNS` order."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=SUMMARY_COLUMNS, restval="")
        writer.writeheader()
        for outcome in outcomes:
            writer.writerow(outcome.row)
    return path


def task_key(task: BatchTask) -> str:
    """The fingerprint of what a task's outcome depends on.

    The data file's bytes (every set's, in order), the robot (and its URDF's bytes), the
    method, the seed and the options (see :func:`calib_pin.studies.checkpoint.fingerprint`).
    """
    if isinstance(task.data, str):  # one set: the "batch-set" key, under which existing checkpoints are kept
        data = Path(task.data)
        return fingerprint("batch-set", task.robot, file_digest(task.robot), str(data.resolve()), file_digest(data),
                           task.method, task.seed, task.options)
    files = [[str(Path(f).resolve()), file_digest(f)] for f in task.files]
    return fingerprint("batch-sets", task.robot, file_digest(task.robot), files, task.method, task.seed, task.options)


def _outcome_from_json(value: dict[str, Any]) -> TaskOutcome:
    return TaskOutcome(**value)


def _check_names(tasks: Sequence[BatchTask]) -> None:
    seen: dict[str, str] = {}
    for task in tasks:
        if task.name in seen:
            raise CalibPinError(
                f"two sets share the name '{task.name}' ({seen[task.name]}, {'+'.join(task.files)}): "
                "their outputs would overwrite each other under the same folder"
            )
        seen[task.name] = "+".join(task.files)


def run_batch(
    tasks: Sequence[BatchTask], *, out: str | Path = "out/batch", jobs: int = 1, scheduler: str | None = None,
    notify: Callable[[str], Any] | None = None,
) -> list[TaskOutcome]:
    """Calibrate many sets; write their outputs and ``<out>/summary.csv``.

    Each set's outcome is kept in ``<out>/.calib-pin-checkpoint`` as soon as it is done;
    a run of the same tasks into the same folder reuses the kept ones (a task whose data
    file, robot, method, seed or options changed runs again). After the outputs are
    written the checkpoint is removed. The outputs are written all together or none;
    no earlier run's report or URDF is left beside a set that fails in this run.

    Args:
        tasks: One task per measurement set (set names, the file stems, must differ).
        out: Output folder: ``<out>/<set>/report.json``, ``<out>/<set>/<robot>_calibrated.urdf``
            and ``<out>/summary.csv``.
        jobs: Local worker processes (1: this process).
        scheduler: Address of a running Dask scheduler, instead of local processes.
        notify: Called with one line when kept outcomes are reused.

    Returns:
        One outcome per task, in the tasks' order.

    Raises:
        CalibPinError: duplicate set names, jobs below 1, a malformed scheduler address.
        ParallelFault: a worker or the scheduler failed; the finished sets are kept.
        calib_pin.studies.checkpoint.Interrupted: Ctrl-C; the finished sets are kept.
    """
    tasks = list(tasks)
    _check_names(tasks)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise CalibPinError(f"{out}: the output folder is a file")
    inputs: dict[str, str | None] = {f"SESSION {f}": f for t in tasks for f in t.files}
    inputs["--robot"] = tasks[0].robot if tasks else None
    Outputs(out, inputs=inputs).check(out / "summary.csv")  # an input is never an output: refused before the work
    checkpoint = Checkpoint(out, "set")
    outcomes = checkpoint.map(limited(run_task), tasks, [task_key(t) for t in tasks], encode=dataclasses.asdict,
                              decode=_outcome_from_json, keep=lambda o: not o.retry, jobs=jobs, scheduler=scheduler,
                              notify=notify)
    files = Outputs(out, inputs=inputs)
    stale = [path for outcome in outcomes for path in _earlier_files(out, outcome)]
    try:
        for outcome in outcomes:
            _add_outcome(files, outcome)
        files.add(out / "summary.csv", lambda tmp: write_summary(outcomes, tmp))
        _remove_stale(stale, files.commit(), inputs)  # all sets' outputs and the summary together, or none
    except KeyboardInterrupt:
        raise Interrupted(f"stopped by Ctrl-C: {checkpoint.kept(len(outcomes), len(outcomes))}") from None
    except (OSError, CalibPinError) as e:  # a full disk: no output changed, every set is kept
        raise checkpoint.unwritten(e, len(outcomes)) from None
    checkpoint.clear()
    return outcomes

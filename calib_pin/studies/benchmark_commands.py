"""The user's commands timed as whole processes, and the quick start's phases.

``benchmark.py --commands`` times the commands, ``benchmark.py --quick-start`` the phases.

What a user feels is a whole process: interpreter start, imports, reading the files, the
fit, the report and its figures, writing. :func:`time_commands` runs each command as a
user types it (``python scripts/<command>.py ...``) in a fresh interpreter, on seeded
simulated IRB120 drawstring sets made beforehand (untimed) at each size, and reads each
process's wall time and peak resident memory (``os.wait4``). Commands:

* ``calibrate``: ``calibrate irb120 --data SET --method M`` with report.json and report.html;
* ``no-html``: the same with ``--no-html``;
* ``compare``: ``compare irb120 --data SET --trials 10`` (every method, the default);
* ``batch``: ``batch`` over 8 sets of rows/8 poses each (``--method M``);
* ``compensate``: ``compensate`` of 1000 targets with the ``calibrate`` run's calibration.

Each size's ratio to the size before is printed beside its time. The machine may be
shared: each cell is the median of ``repeats`` runs. Every process runs as a user's does,
with its bytecode (``PYTHONDONTWRITEBYTECODE`` unset: :func:`user_environment`), after one
untimed warm-up run of the same command (:func:`warm_up`).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

#: Rows (poses) of the command table; ``--max-rows`` cuts it.
COMMAND_SIZES = (1000, 10_000, 100_000)
#: The commands timed (see the module docstring), in order.
COMMANDS = ("calibrate", "no-html", "compare", "batch", "compensate")
#: Sets of the batch command (each rows / BATCH_SETS poses).
BATCH_SETS = 8
#: Targets of the compensate command.
TARGETS = 1000
#: Trials of the compare command.
COMPARE_TRIALS = 10

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Run:
    """One command at one size: median wall time [s], largest peak resident memory [MiB], exit code.

    The time and memory are over its runs.
    """

    command: str
    rows: int
    method: str
    wall_s: float
    peak_mib: float
    code: int


def script_argv(name: str) -> list[str]:
    """How a user runs a command: the script wrapper, or ``-m calib_pin.cli``.

    ``-m calib_pin.cli`` when the package is installed without the scripts folder.
    """
    path = ROOT / "scripts" / f"{name}.py"
    if path.is_file():
        return [sys.executable, str(path)]
    return [sys.executable, "-c", "import sys; from calib_pin.cli.process import main; sys.exit(main())", name]


#: How the child processes run, for the printed notes.
PROCESS_NOTE = ("each process with bytecode as a user's install has it (PYTHONDONTWRITEBYTECODE unset), "
                "after one untimed warm-up run of the same command")


def user_environment() -> dict[str, str]:
    """This process's environment as a user's shell has it: without ``PYTHONDONTWRITEBYTECODE``.

    A user's install has its bytecode; without it every process recompiles its modules.
    """
    return {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def warm_up(argv: list[str], cwd: Path) -> None:
    """One untimed run of ``argv`` (its bytecode written, its files in the page cache)."""
    subprocess.run(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=user_environment())


def timed_process(argv: list[str], cwd: Path) -> tuple[float, float, int]:
    """Wall time [s], peak resident memory [MiB] and exit code of one process.

    Its output is discarded; it runs in :func:`user_environment`.
    """
    env = user_environment()
    start = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here: Popen must not wait again
    return wall, usage.ru_maxrss / 1024.0, proc.returncode


def _make_sets(folder: Path, rows: int, seed: int) -> None:
    """The size's sets, simulated beforehand (untimed).

    ``set.csv`` (rows poses), ``b_1.csv`` .. ``b_8.csv`` (rows / 8 each) and
    ``targets.csv`` (TARGETS poses away from the wrist and elbow singularities).
    """
    import numpy as np

    from ..measurements.csv_writer import write_poses

    # Within 20 deg of a pose reaching forward and down, the wrist bent 50 deg: away from the
    # wrist, elbow and shoulder singularities, so every target compensates.
    centre = np.deg2rad([0.0, 20.0, 0.0, 0.0, 50.0, 0.0])
    q = centre + np.deg2rad(20.0) * np.random.default_rng(seed + 1).uniform(-1.0, 1.0, (TARGETS, len(centre)))
    write_poses(folder / "targets.csv", q, robot="irb120")

    quiet = ["--force"]
    for argv in (["irb120", "--poses", str(rows), "--seed", str(seed), "--out", str(folder / "set.csv"), *quiet],
                 ["irb120", "--poses", str(max(rows // BATCH_SETS, 20)), "--sessions", str(BATCH_SETS),
                  "--seed", str(seed), "--out", str(folder / "b.csv"), *quiet]):
        made = subprocess.run([*script_argv("simulate"), *argv], cwd=folder, capture_output=True, text=True)
        if made.returncode:
            raise RuntimeError(f"simulate {' '.join(argv)} failed: {made.stderr.strip()[-300:]}")


def command_argv(name: str, folder: Path, method: str) -> list[str]:
    """The command line of ``name`` (see :data:`COMMANDS`) on the sets in ``folder``."""
    data = str(folder / "set.csv")
    if name == "calibrate":
        return [*script_argv("calibrate"), "irb120", "--data", data, "--method", method, "--out", str(folder / "cal")]
    if name == "no-html":
        return [*script_argv("calibrate"), "irb120", "--data", data, "--method", method, "--no-html",
                "--out", str(folder / "cal-nohtml")]
    if name == "compare":
        return [*script_argv("compare"), "irb120", "--data", data, "--trials", str(COMPARE_TRIALS), "--quiet",
                "--out", str(folder / "compare")]
    if name == "batch":
        return [*script_argv("batch"), *(str(folder / f"b_{k}.csv") for k in range(1, BATCH_SETS + 1)),
                "--robot", "irb120", "--method", method, "--out", str(folder / "batch")]
    if name == "compensate":
        return [*script_argv("compensate"), "irb120", "--calibration", str(folder / "cal"),
                "--targets", str(folder / "targets.csv"), "--out", str(folder / "compensated.csv"), "--force"]
    raise ValueError(f"unknown command '{name}' (valid: {', '.join(COMMANDS)})")


def time_commands(commands: tuple[str, ...] = COMMANDS, sizes: tuple[int, ...] = COMMAND_SIZES,
                  method: str = "ekf-qibas", repeats: int = 1, seed: int = 0,
                  compare_max_rows: int | None = None) -> list[Run]:
    """Each command at each size as whole processes (median of ``repeats``).

    Args:
        commands: Of :data:`COMMANDS`; ``compensate`` needs ``calibrate`` before it.
        sizes: Rows (poses) of the sets.
        method: Of calibrate, --no-html and batch.
        compare_max_rows: compare only up to this many rows (it runs all nine methods
            ten times; None: every size).
    """
    runs = []
    for rows in sizes:
        with tempfile.TemporaryDirectory(prefix="calib-pin-bench-") as tmp:
            folder = Path(tmp)
            _make_sets(folder, rows, seed)
            for name in commands:
                if name == "compare" and compare_max_rows is not None and rows > compare_max_rows:
                    continue
                if name == "compensate" and not (folder / "cal").is_dir():
                    subprocess.run(command_argv("calibrate", folder, method), cwd=folder, capture_output=True)
                warm_up(command_argv(name, folder, method), folder)
                measured = [timed_process(command_argv(name, folder, method), folder) for _ in range(repeats)]
                runs.append(Run(name, rows, method, statistics.median(m[0] for m in measured),
                                max(m[1] for m in measured), max(m[2] for m in measured)))
    return runs


def format_commands(runs: list[Run]) -> str:
    """The command table: per command and size the wall time [s], ratio and peak memory [MiB].

    The ratio is to the size before.
    """
    sizes = sorted({r.rows for r in runs})
    names = list(dict.fromkeys(r.command for r in runs))
    cell = {(r.command, r.rows): r for r in runs}
    lines = [f"{'command':12s}" + "".join(f"{f'{n} rows: s (x prev) MiB':>34s}" for n in sizes)]
    for name in names:
        cells = []
        for k, n in enumerate(sizes):
            r = cell.get((name, n))
            if r is None:
                cells.append(f"{'-':>34s}")
                continue
            before = cell.get((name, sizes[k - 1])) if k else None
            ratio = f"(x{r.wall_s / before.wall_s:.1f})" if before is not None else "(-)"
            failed = f" exit {r.code}" if r.code else ""
            cells.append(f"{r.wall_s:12.2f} {ratio:>8s} {r.peak_mib:8.0f}{failed:>5s}")
        lines.append(f"{name:12s}" + "".join(cells))
    return "\n".join(lines)


#: The quick start's phases, timed inside one fresh process (see :func:`quick_start_phases`),
#: with Python's cyclic collector off as in the command's own process (:mod:`calib_pin.cli.process`).
PHASES_SCRIPT = r"""
import gc, json, sys, time
gc.disable()
t0 = time.perf_counter()
import calib_pin.cli.calibrate, calib_pin.calibration.solve, calib_pin.report.bundle, calib_pin.estimators.ekf
t1 = time.perf_counter()
from calib_pin.calibration.solve import prepare, solve
calibration = prepare("irb120", None)
t2 = time.perf_counter()
result = solve(calibration, "ekf-qibas")
t3 = time.perf_counter()
from calib_pin.report.bundle import render_outputs
rendered = render_outputs(result, html=False)
t4 = time.perf_counter()
from calib_pin.report.html import render_html
render_html(rendered.report)
t5 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "load": t2 - t1, "fit": result.estimate.time_s,
                  "split+noise+metrics": t3 - t2 - result.estimate.time_s, "report": t4 - t3, "figures": t5 - t4}))
"""


def quick_start_phases(repeats: int = 3) -> tuple[dict[str, float], float]:
    """Median seconds of each phase of the quick start (``calibrate.py irb120``), and of the whole.

    Each run in a fresh process: import, load (the robot and the shipped set), fit (the
    estimate), the rest of the calibration (split, metrics, uncertainty), report
    (report.json and the URDF, in memory), figures (report.html); and the median wall time
    of the command itself.
    """
    import json

    phases: list[dict[str, float]] = []
    walls = []
    with tempfile.TemporaryDirectory(prefix="calib-pin-quick-") as tmp:
        quick = [*script_argv("calibrate"), "irb120", "--out", str(Path(tmp) / "out")]
        warm_up([sys.executable, "-c", PHASES_SCRIPT], Path(tmp))
        warm_up(quick, Path(tmp))
        for _ in range(repeats):
            run = subprocess.run([sys.executable, "-c", PHASES_SCRIPT], capture_output=True, text=True, cwd=tmp,
                                 env=user_environment())
            if run.returncode:
                raise RuntimeError(f"the quick start's phases failed: {run.stderr.strip().splitlines()[-1:]}")
            phases.append(json.loads(run.stdout.strip().splitlines()[-1]))
            walls.append(timed_process(quick, Path(tmp))[0])
    return {k: statistics.median(p[k] for p in phases) for k in phases[0]}, statistics.median(walls)

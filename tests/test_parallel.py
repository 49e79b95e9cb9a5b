"""Parallel runs keep finished work and report their faults in one line.

Each fault is made to happen: Ctrl-C (SIGINT to the process group, as a terminal sends
it) after the first set or trial is kept, a joblib worker killed by SIGKILL, a plain TCP
server given as the Dask scheduler, a scheduler without workers and a scheduler killed
during the run. A test-only ``sitecustomize`` on ``PYTHONPATH`` slows a set down or
kills its worker in the subprocess and in the worker processes it starts. Every
process is stopped by its PID.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

import calib_pin as cp

#: Where a run keeps its finished sets or trials (in its output folder).
CHECKPOINT_FOLDER = ".calib-pin-checkpoint"

ROOT = Path(__file__).resolve().parent.parent

#: Set names whose calibration the hook slows down (30 s) or whose worker it kills.
HOOK_BATCH = """
    import glob, os, time
    import calib_pin.calibration.prepare as _pipeline  # a batch task prepares its set, then fits it
    _calibrate = _pipeline.prepare
    def calibrate(robot, data, *args, **kwargs):
        name = os.path.basename(str(data))
        if name.startswith("slow"):
            time.sleep(30)
        if name.startswith("die"):  # once the other sets are kept: the worker dies by SIGKILL
            deadline = time.monotonic() + 20
            while len(glob.glob("out/.calib-pin-checkpoint/*.json")) < 2 and time.monotonic() < deadline:
                time.sleep(0.02)
            os.kill(os.getpid(), 9)
        return _calibrate(robot, data, *args, **kwargs)
    _pipeline.prepare = calibrate
"""

#: Trials of seed > 0 take 30 s.
HOOK_COMPARE = """
    import time
    import calib_pin.studies.comparison as _comparison
    _trial = _comparison.run_trial
    def slow_trial(setup, truth, methods, seed, *args, **kwargs):
        if seed > 0:
            time.sleep(30)
        return _trial(setup, truth, methods, seed, *args, **kwargs)
    _comparison.run_trial = slow_trial
"""


def _env(tmp_path: Path, hook: str | None) -> dict[str, str]:
    env = dict(os.environ)
    if hook is not None:
        folder = tmp_path / "hook"
        folder.mkdir(exist_ok=True)
        (folder / "sitecustomize.py").write_text(textwrap.dedent(hook))
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(folder), env.get("PYTHONPATH")) if p)
    return env


#: ``calib-pin ARGS...`` in a subprocess.
CLI = [sys.executable, "-c", "import sys; from calib_pin.cli import main; sys.exit(main(sys.argv[1:]))"]


def _start(argv: list[str], tmp_path: Path, hook: str | None) -> subprocess.Popen:
    return subprocess.Popen([*CLI, *argv], cwd=tmp_path, env=_env(tmp_path, hook),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_default_ctrl_c)


def _default_ctrl_c() -> None:
    """In the child: Ctrl-C as a user's shell gives it (a runner started with ``&`` ignores it)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _finish(proc: subprocess.Popen, timeout: float = 30) -> tuple[int, str, str]:
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"still running after {timeout} s: {err[-2000:]}")
    return proc.returncode, out, err


def _wait_for_kept(folder: Path, n: int, proc: subprocess.Popen, timeout: float = 15) -> None:
    """Until ``n`` items are in the run's checkpoint (or fail, stopping ``proc``)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        if len(list((folder / CHECKPOINT_FOLDER).glob("*.json"))) >= n:
            return
        time.sleep(0.05)
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
    _, err = proc.communicate()
    pytest.fail(f"no checkpoint of {n} item(s) in {folder}: {err[-2000:]}")


def _lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.strip()]


def _table(path: Path) -> list[dict[str, str]]:
    """A CSV's rows without the wall-time columns."""
    with path.open() as f:
        return [{k: v for k, v in row.items() if not k.startswith("time_s")} for row in csv.DictReader(f)]


@pytest.fixture(scope="module")
def sets(tmp_path_factory, chain, params) -> list[Path]:
    """Three simulated 30-pose sets (seeds 0-2)."""
    folder = tmp_path_factory.mktemp("parallel_sets")
    paths = []
    for seed in range(3):
        data, _ = cp.simulate(chain, params, 30, seed=seed, noise_mm=0.05)
        path = folder / f"s{seed}.csv"
        cp.write_measurements(path, data)
        paths.append(path)
    return paths


def _copy_sets(sets: list[Path], folder: Path, names: list[str]) -> list[str]:
    for path, name in zip(sets, names, strict=True):
        (folder / f"{name}.csv").write_bytes(path.read_bytes())
    return [f"{name}.csv" for name in names]


def test_batch_ctrl_c_keeps_finished_sets_and_the_same_command_resumes(sets, tmp_path, monkeypatch, capsys):
    from calib_pin.cli.batch import batch_main

    files = _copy_sets(sets, tmp_path, ["s0", "slow1", "slow2"])
    argv = [*files, "--out", "out", "--method", "lm"]
    proc = _start(["batch", *argv], tmp_path, HOOK_BATCH)
    _wait_for_kept(tmp_path / "out", 1, proc)
    os.killpg(proc.pid, signal.SIGINT)
    code, _, err = _finish(proc)
    assert code == 130 and len(_lines(err)) == 1, err
    assert "stopped by Ctrl-C: 1 of 3 set(s) kept in out; run the same command to resume" in err, err
    assert not (tmp_path / "out" / "summary.csv").exists()

    monkeypatch.chdir(tmp_path)  # the same command again (here, without the slow sets), then an uninterrupted run
    assert batch_main(argv) == 0
    assert "resuming out: 1 of 3 set(s) already done" in capsys.readouterr().out
    assert not (tmp_path / "out" / CHECKPOINT_FOLDER).exists()  # a complete run leaves no checkpoint
    assert batch_main([*files, "--out", "ref", "--method", "lm"]) == 0
    assert "resuming" not in capsys.readouterr().out
    assert _table(tmp_path / "out" / "summary.csv") == _table(tmp_path / "ref" / "summary.csv")
    for name in ("s0", "slow1", "slow2"):
        assert (tmp_path / "out" / name / "irb120_calibrated.urdf").read_bytes() == \
            (tmp_path / "ref" / name / "irb120_calibrated.urdf").read_bytes()
        reports = [json.loads((tmp_path / o / name / "report.json").read_text()) for o in ("out", "ref")]
        for report in reports:
            report.pop("time_s", None)
            report.pop("urdf")  # the paths differ: out/ and ref/
            report.pop("exports")
        assert reports[0] == reports[1]


def test_compare_ctrl_c_keeps_finished_trials_and_the_same_command_resumes(tmp_path, monkeypatch, capsys):
    from calib_pin.cli.compare import compare_main

    argv = ["irb120", "--simulate", "gauss", "--poses", "30", "--methods", "lm", "--trials", "3", "--quiet"]
    proc = _start(["compare", *argv, "--out", "out"], tmp_path, HOOK_COMPARE)
    _wait_for_kept(tmp_path / "out", 1, proc)
    os.killpg(proc.pid, signal.SIGINT)
    code, _, err = _finish(proc)
    assert code == 130 and len(_lines(err)) == 1, err
    assert "stopped by Ctrl-C: 1 of 3 trial(s) kept in out; run the same command to resume" in err, err
    assert list((tmp_path / "out").iterdir()) == [tmp_path / "out" / CHECKPOINT_FOLDER]

    monkeypatch.chdir(tmp_path)
    assert compare_main([*argv, "--out", "out"]) == 0
    assert "resuming out: 1 of 3 trial(s) already done" in capsys.readouterr().out
    assert not (tmp_path / "out" / CHECKPOINT_FOLDER).exists()
    assert compare_main([*argv, "--out", "ref"]) == 0
    assert _table(tmp_path / "out" / "table1.csv") == _table(tmp_path / "ref" / "table1.csv")
    assert {p.name for p in (tmp_path / "out").iterdir()} == {p.name for p in (tmp_path / "ref").iterdir()}


def test_a_killed_joblib_worker_is_one_line_and_keeps_the_finished_sets(sets, tmp_path, monkeypatch, capsys):
    from calib_pin.cli.batch import batch_main

    files = _copy_sets(sets, tmp_path, ["s0", "s1", "die2"])
    argv = [*files, "--out", "out", "--method", "lm"]
    code, out, err = _finish(_start(["batch", *argv, "--jobs", "2"], tmp_path, HOOK_BATCH), timeout=60)
    assert code == 2 and len(_lines(err)) == 1, err
    assert "a local worker process died (exit SIGKILL" in err and "2 of 3 set(s) kept in out" in err, err
    assert len(list((tmp_path / "out" / CHECKPOINT_FOLDER).glob("*.json"))) == 2
    monkeypatch.chdir(tmp_path)
    assert batch_main(argv) == 0
    assert "resuming out: 2 of 3 set(s) already done" in capsys.readouterr().out
    assert [row["status"] for row in _table(tmp_path / "out" / "summary.csv")] == ["ok"] * 3


def test_a_tcp_server_that_is_not_a_dask_scheduler_is_one_line_within_seconds(sets, tmp_path, monkeypatch, capfd):
    pytest.importorskip("distributed")
    import calib_pin.studies.parallel
    from calib_pin.cli.batch import batch_main

    monkeypatch.setattr(calib_pin.studies.parallel, "ANSWER_TIMEOUT_S", 0.5)
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    status: list[int] = []
    run = threading.Thread(target=lambda: status.append(batch_main([str(sets[0]), "--out", str(tmp_path / "o"),
                                                                     "--scheduler", address])), daemon=True)
    try:
        run.start()
        run.join(timeout=10)  # it hung for ever
    finally:
        server.close()
    assert not run.is_alive(), "still waiting for the server after 10 s"
    err = capfd.readouterr().err
    assert status == [2] and len(_lines(err)) == 1, err
    assert f"{address} is not a Dask scheduler: it accepts connections but gave no Dask answer within 0.5 s" in err


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class _Scheduler:
    """A ``dask scheduler`` subprocess on 127.0.0.1 without workers; its log lines kept."""

    def __init__(self) -> None:
        self.port = _free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.proc = subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port",
                                      str(self.port), "--dashboard-address", ":0", "--no-show"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        self.log: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.log.append(line)

    def seen(self, text: str) -> int:
        return sum(text in line for line in self.log)

    def wait_for(self, text: str, timeout: float = 20, times: int = 1) -> None:
        deadline = time.monotonic() + timeout
        while self.seen(text) < times:
            if time.monotonic() > deadline or self.proc.poll() is not None:
                pytest.fail(f"the scheduler did not log '{text}': {''.join(self.log)[-2000:]}")
            time.sleep(0.05)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()


def test_dask_scheduler_without_workers_and_killed_scheduler_are_one_line(sets, tmp_path):
    pytest.importorskip("distributed")
    from calib_pin.studies.batch import ParallelFault, parallel_map

    scheduler = _Scheduler()
    try:
        scheduler.wait_for("Scheduler at:")
        start = time.monotonic()
        with pytest.raises(ParallelFault, match=f"no Dask worker is connected to the scheduler at {scheduler.address}"):
            parallel_map(abs, [1, 2], scheduler=scheduler.address, worker_wait_s=1.0)
        assert time.monotonic() - start < 10

        clients = scheduler.seen("Receive client connection")
        proc = _start(["batch", str(sets[0]), "--out", "out", "--scheduler", scheduler.address], tmp_path, None)
        try:
            scheduler.wait_for("Receive client connection", timeout=20, times=clients + 1)
            time.sleep(0.3)
            scheduler.kill()
            code, _, err = _finish(proc, timeout=30)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    finally:
        scheduler.kill()
    assert code == 2 and len(_lines(err)) == 1, err
    assert f"the Dask scheduler at {scheduler.address} died or is unreachable" in err, err


def test_checkpoint_keeps_whole_results_under_their_keys_and_resumes_only_the_rest(tmp_path):
    from calib_pin.studies.checkpoint import Checkpoint, fingerprint

    calls: list[int] = []

    def square(x: int) -> int:
        calls.append(x)
        return x * x

    store = Checkpoint(tmp_path, "item")
    keys = [fingerprint("square", x) for x in (1, 2, 3)]
    assert len(set(keys)) == 3 and fingerprint("square", 1) == keys[0] != fingerprint("square", 1.5)
    lines: list[str] = []
    assert store.map(square, [1, 2, 3], keys, encode=int, decode=int, keep=lambda r: r != 4, notify=lines.append) \
        == [1, 4, 9]
    assert lines == [] and len(list(store.folder.glob("*.json"))) == 2  # the result not to keep: not on disk
    (store.folder / f"item-{keys[2]}.json").write_text('{"format": 1, "key": "other", "result": 0}')
    assert store.map(square, [1, 2, 3], keys, encode=int, decode=int, notify=lines.append) == [1, 4, 9]
    assert calls == [1, 2, 3, 2, 3] and lines == [f"resuming {tmp_path}: 1 of 3 item(s) already done"]
    assert not list(store.folder.glob(".*.tmp"))
    store.clear()
    assert not store.folder.exists()

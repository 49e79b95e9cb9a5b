"""Collecting a measurement set from a simulated indicator: complete, killed, resumed, faulty."""

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.cli.collect import collect_main
from calib_pin.cli.poses import make_poses_main
from calib_pin.hardware.fake_indicator import FakeIndicator
from calib_pin.hardware.reader import SensorProfile
from calib_pin.hardware.session import open_session
from calib_pin.measurements.pose_list import read_pose_list
from calib_pin.sensors import CableModel

ROOT = Path(__file__).resolve().parent.parent
N = 20
CHAIN = cp.load_chain("irb120")
FAST = ["--auto", "0", "--interval", "0", "--samples", "3", "--timeout", "0.2"]
MODBUS = ["--protocol", "modbus", "--baud", "9600", "--slave", "1", "--function", "3",
          "--register", "0", "--words", "2", "--signed", "--scale-mm", "0.001"]


@pytest.fixture(scope="module")
def poses(tmp_path_factory, chain, params, session):
    """A 20-pose list and the readings the true robot of the seeded session gives there [mm]."""
    path = tmp_path_factory.mktemp("poses") / "poses.csv"
    assert make_poses_main(["irb120", "--n", str(N), "--seed", "4", "--out", str(path)]) == 0
    q = read_pose_list(path, chain).q
    _, truth = session
    values = CableModel(chain, params, truth.sensor).predict(truth.x, q) * 1e3
    return path, values


def _collect(fake, poses_path, out, *extra):
    return collect_main(["irb120", "--poses", str(poses_path), "--port", fake.path, "--out", str(out),
                         *MODBUS, *FAST, *extra])


def _start_collect_script(fake, poses_path, out, rows):
    """Start scripts/collect.py as a process and return (command, process) once the
    output holds ``rows`` rows."""
    command = [sys.executable, str(ROOT / "scripts" / "collect.py"), "irb120", "--poses", str(poses_path),
               "--port", fake.path, "--out", str(out), *MODBUS,
               "--auto", "0.05", "--interval", "0", "--samples", "3", "--timeout", "0.2"]
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # as a user's shell
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (out.exists() and len(_rows(out)[0]) >= rows):
        time.sleep(0.02)
    return command, proc


def _rows(out):
    data = cp.read_measurements(out, CHAIN, allow_empty=True)
    return data.pose_ids.tolist(), data.lengths * 1e3


def test_make_poses_within_limits_with_margin(chain, poses):
    path, _ = poses
    q = read_pose_list(path, chain).q
    margin = np.deg2rad(5.0)
    assert q.shape == (N, 6)
    assert np.all(q >= chain.lower + margin - 1e-9) and np.all(q <= chain.upper - margin + 1e-9)


def test_full_collection_matches_the_simulated_values(poses, tmp_path, capsys):
    """20 poses: every row holds the value the indicator served at that pose (to its 1 um counts)."""
    path, values = poses
    out = tmp_path / "s.csv"
    with FakeIndicator("modbus", values_mm=values, follow=out) as fake:
        assert _collect(fake, path, out, "--anchor-mm", "600,200,-100", "--tool-mm", "0,0,50") == 0
    ids, lengths = _rows(out)
    assert ids == list(range(1, N + 1))
    np.testing.assert_allclose(lengths, values, atol=0.0006)
    text = capsys.readouterr().out
    assert f"pose {N} ({N} of {N}):" in text and "spread 0.000 mm" in text
    assert "# anchor_mm: 600, 200, -100" in out.read_text()


def test_ascii_collection(poses, tmp_path):
    path, values = poses
    out = tmp_path / "s.csv"
    with FakeIndicator("ascii", values_mm=values, follow=out, period_s=0.005) as fake:
        acceptance = [a if a != "modbus" else "ascii" for a in MODBUS]  # the same flags, ascii
        code = collect_main(["irb120", "--poses", str(path), "--port", fake.path, "--out", str(out),
                             *acceptance, *FAST])
    assert code == 0
    ids, lengths = _rows(out)
    assert ids == list(range(1, N + 1))
    np.testing.assert_allclose(lengths, values, atol=0.0006)


def test_kill_and_resume_loses_and_duplicates_nothing(poses, tmp_path):
    """SIGKILL in the middle of a run, then the same command again: all 20 poses, once each."""
    path, values = poses
    out = tmp_path / "s.csv"
    with FakeIndicator("modbus", values_mm=values, follow=out) as fake:
        command, proc = _start_collect_script(fake, path, out, rows=6)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        ids_after_kill = _rows(out)[0]
        assert 6 <= len(ids_after_kill) < N
        resumed = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming {out}: {len(ids_after_kill)} of {N} poses done" in resumed.stdout
    ids, lengths = _rows(out)
    assert ids == list(range(1, N + 1))
    np.testing.assert_allclose(lengths, values, atol=0.0006)


def test_ctrl_c_keeps_rows_and_says_how_to_resume(poses, tmp_path):
    path, values = poses
    out = tmp_path / "s.csv"
    with FakeIndicator("modbus", values_mm=values, follow=out) as fake:
        _, proc = _start_collect_script(fake, path, out, rows=3)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130 and "Traceback" not in err
    assert "stopped by Ctrl-C: every completed row is saved; run the same command to resume" in err
    ids, lengths = _rows(out)
    assert 3 <= len(ids) < N and ids == list(range(1, len(ids) + 1))
    np.testing.assert_allclose(lengths, values[: len(ids)], atol=0.0006)


def test_incomplete_last_line_is_dropped_on_resume(poses, tmp_path, capsys):
    path, values = poses
    out = tmp_path / "s.csv"
    with FakeIndicator("modbus", values_mm=values, follow=out) as fake:
        assert _collect(fake, path, out) == 0
        text = out.read_text().splitlines(keepends=True)
        out.write_text("".join(text[:-3]) + text[-3][:17])  # two rows lost, one cut mid-write
        assert _collect(fake, path, out) == 0
    assert "warning: dropped an incomplete last line" in capsys.readouterr().err
    ids, lengths = _rows(out)
    assert ids == list(range(1, N + 1))
    np.testing.assert_allclose(lengths, values, atol=0.0006)


def test_sensor_fault_stops_without_a_bad_row(poses, tmp_path, capsys):
    """A fault that outlives its retries: exit 3, a clear message, no row for that pose;
    the same command then resumes."""
    path, values = poses
    out = tmp_path / "s.csv"
    with FakeIndicator("modbus", values_mm=values, follow=out) as fake:
        fake.inject("crc", 50)
        assert _collect(fake, path, out, "--retries", "2") == 3
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "error: sensor: bad answer from slave 1" in err[0]
        assert "0 of 20 poses are saved" in err[0]
        assert _rows(out)[0] == []
        fake._faults.clear()
        assert _collect(fake, path, out) == 0
    assert _rows(out)[0] == list(range(1, N + 1))


def test_unplugged_adapter_mid_session(poses, tmp_path, capsys, monkeypatch):
    """The adapter vanishes after 4 poses: exit 3, a clear message, the 4 rows intact."""
    import calib_pin.hardware.session as cli

    path, values = poses
    out = tmp_path / "s.csv"
    with FakeIndicator("modbus", values_mm=values, follow=out) as fake:
        def unplug_after_four(text):
            if "(4 of" in text:
                fake.inject("disconnect")

        original = cli.collect
        monkeypatch.setattr(cli, "collect", lambda s, r, w: original(s, r, w, report=unplug_after_four))
        assert _collect(fake, path, out) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "adapter unplugged" in err[0] and "4 of 20 poses are saved" in err[0]
    ids, lengths = _rows(out)
    assert ids == [1, 2, 3, 4]
    np.testing.assert_allclose(lengths, values[:4], atol=0.0006)


def test_resume_refuses_another_pose_list(poses, tmp_path, chain):
    path, values = poses
    out = tmp_path / "s.csv"
    with FakeIndicator("modbus", values_mm=values, follow=out) as fake:
        assert _collect(fake, path, out) == 0
    other = tmp_path / "other.csv"
    assert make_poses_main(["irb120", "--n", "20", "--seed", "5", "--out", str(other)]) == 0
    with pytest.raises(cp.DataError, match="pose 1 has other joint angles than in"):
        open_session(out, read_pose_list(other, chain), chain, SensorProfile())


def test_probe_prints_values(capsys):
    with FakeIndicator("modbus", 432.1) as fake:
        fake.inject("silence")
        code = collect_main(["--probe", "--port", fake.path, *MODBUS, "--count", "3", "--timeout", "0.1",
                             "--retries", "0"])
    out = capsys.readouterr().out
    assert code == 0 and "1: fault: no answer" in out and "2: 432.100 mm" in out and "3: 432.100 mm" in out


def test_profile_saved_then_used(tmp_path, capsys):
    profile = tmp_path / "sensor.json"
    with FakeIndicator("modbus", 432.1) as fake:
        assert collect_main(["--probe", "--port", fake.path, *MODBUS, "--count", "1",
                             "--save-profile", str(profile)]) == 0
        assert collect_main(["--probe", "--port", fake.path, "--profile", str(profile), "--count", "1"]) == 0
    assert capsys.readouterr().out.count("1: 432.100 mm") == 2


@pytest.mark.parametrize(
    "args, message",
    [
        (["irb120", "--port", "/dev/null"], "collect needs --poses, --out"),
        (["--port", "/dev/nonexistent-tty", "--probe"], "cannot open /dev/nonexistent-tty"),
        (["--port", "x", "--probe", "--profile", "missing.json"], "missing.json: cannot read sensor profile"),
        (["--port", "x", "--probe", "--slave", "300"], "sensor setting slave = 300: must be 1 to 247"),
        (["irb120", "--port", "x", "--poses", "nope.csv", "--out", "o.csv"], "nope.csv: no such file"),
    ],
)
def test_bad_input_one_line_exit_2(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        code = collect_main(args)
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and message in err[0]


def test_make_poses_bad_margin(capsys, tmp_path):
    assert make_poses_main(["irb120", "--n", "5", "--margin-deg", "200", "--out", str(tmp_path / "p.csv")]) == 2
    assert "leaves no range for joint_" in capsys.readouterr().err


def _full_disk(limit):
    """A preexec function: files of at most ``limit`` bytes; a write past it is short,
    then fails (EFBIG), as on a full disk, instead of killing the process."""
    import resource

    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


def test_full_disk_keeps_only_whole_rows_and_says_how_many(poses, tmp_path):
    """The disk fills during the last row: that row is not counted and is cut away again,
    the run stops with one line saying 19 of 20 are saved, and a rerun completes the set.
    A disk too full for the header leaves no file at all."""
    path, values = poses
    reference, out = tmp_path / "reference.csv", tmp_path / "s.csv"
    with FakeIndicator("modbus", values_mm=values, follow=reference) as fake:
        assert _collect(fake, path, reference) == 0
    full = reference.read_bytes()
    last_row = len(full) - full.rstrip(b"\n").rfind(b"\n") - 1
    header_only = tmp_path / "h.csv"
    for target, limit, saved in ((header_only, 40, None), (out, len(full) - last_row // 2, 19)):
        with FakeIndicator("modbus", values_mm=values, follow=target) as fake:
            command = [sys.executable, str(ROOT / "scripts" / "collect.py"), "irb120", "--poses", str(path),
                       "--port", fake.path, "--out", str(target), *MODBUS, *FAST]
            done = subprocess.run(command, capture_output=True, text=True, timeout=120,
                                  preexec_fn=_full_disk(limit))
        err = done.stderr.strip().splitlines()
        assert done.returncode == 2 and len(err) == 1, done.stderr
        if saved is None:
            assert "cannot write the header" in err[0] and not target.exists(), err[0]
            assert sorted(p.name for p in tmp_path.iterdir()) == ["reference.csv"]
            continue
        assert "cannot write pose 20" in err[0] and "19 of 20 poses are saved" in err[0], err[0]
        assert "complete" not in done.stdout
        kept = [ln for ln in out.read_bytes().splitlines(keepends=True) if not ln.startswith(b"# started:")]
        whole = [ln for ln in full.splitlines(keepends=True) if not ln.startswith(b"# started:")]
        assert kept == whole[:-1]  # the cut row is gone, every byte of the rest is there
        assert _rows(out)[0] == list(range(1, 20))
    with FakeIndicator("modbus", values_mm=values, follow=out) as fake:
        assert _collect(fake, path, out) == 0
    ids, lengths = _rows(out)
    assert ids == list(range(1, N + 1))
    np.testing.assert_allclose(lengths, values, atol=0.0006)


def test_second_collect_on_one_session_refuses(poses, tmp_path, capsys):
    """Two collects on one file at once: the second refuses with one line while the first
    goes on; every pose is then in the file once."""
    path, values = poses
    out = tmp_path / "s.csv"
    with FakeIndicator("modbus", values_mm=values, follow=out) as fake:
        _, proc = _start_collect_script(fake, path, out, rows=2)
        try:
            assert proc.poll() is None
            code = _collect(fake, path, out)
            err = capsys.readouterr().err.strip().splitlines()
            assert code == 2 and len(err) == 1 and "another collect is writing this session now" in err[0], err
        finally:
            _, first_err = proc.communicate(timeout=120)
    assert proc.returncode == 0, first_err
    ids, lengths = _rows(out)
    assert ids == list(range(1, N + 1))
    np.testing.assert_allclose(lengths, values, atol=0.0006)


def test_refused_collect_writes_no_header_and_no_profile(poses, tmp_path, monkeypatch, capsys):
    """Everything is checked before anything is written: a port that cannot be opened, an
    existing --save-profile without --force, or a session of another sensor set-up
    leave no session header, no cut and no profile."""
    path, values = poses
    monkeypatch.chdir(tmp_path)
    base = ["irb120", "--poses", str(path), "--out", "s.csv", *MODBUS, *FAST]
    assert collect_main([*base, "--port", "/dev/nonexistent-tty", "--save-profile", "prof.json"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    Path("prof.json").write_text("{}")
    with FakeIndicator("modbus", values_mm=values, follow=tmp_path / "s.csv") as fake:
        assert collect_main([*base, "--port", fake.path, "--save-profile", "prof.json"]) == 2
        assert sorted(p.name for p in tmp_path.iterdir()) == ["prof.json"]
        assert Path("prof.json").read_text() == "{}"
        Path("prof.json").unlink()
        assert _collect(fake, path, tmp_path / "s.csv") == 0
    cut = Path("s.csv").read_bytes()[:-30]  # the last row cut short
    Path("s.csv").write_bytes(cut)
    assert collect_main([*base, "--port", "/dev/nonexistent-tty", "--save-profile", "prof.json"]) == 2
    assert collect_main([*base, "--port", "/dev/nonexistent-tty", "--save-profile", "prof.json",
                         "--anchor-mm", "1,2,3"]) == 2
    assert Path("s.csv").read_bytes() == cut and not Path("prof.json").exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4 and "cannot open /dev/nonexistent-tty" in err[0] and "prof.json exists" in err[1], err
    assert "was collected with anchor_mm none" in err[-1], err


def test_a_session_that_cannot_be_created_names_it(poses, tmp_path, capsys):
    """A file where the session's folder should be, or a read-only folder: one line naming
    the session (not its temporary file, not "File exists"), and no file left."""
    path, values = poses
    (tmp_path / "f").write_text("x")
    with FakeIndicator("modbus", values_mm=values) as fake:
        assert _collect(fake, path, tmp_path / "f" / "s.csv") == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "s.csv: cannot create its folder" in err[0] and "a file is in the way" in err[0], err
        ro = tmp_path / "ro"
        ro.mkdir()
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k,ro", "tmpfs", str(ro)],
                          capture_output=True).returncode != 0:
            pytest.skip("cannot mount a tmpfs here")
        try:
            assert _collect(fake, path, ro / "s.csv") == 2
        finally:
            subprocess.run(["umount", str(ro)], check=True)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{ro / 's.csv'}: cannot create the session: Read-only" in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f", "ro"]


def test_stdout_on_a_full_disk_says_how_many_poses_are_saved(poses, tmp_path):
    """``collect ... > log.txt`` on a full disk: printing a progress line fails. That was
    'error: File too large' alone; the line now says how many poses are saved, and the
    session holds whole rows only (a rerun completes it)."""
    path, values = poses
    local = tmp_path / "p.csv"
    local.write_bytes(Path(path).read_bytes())
    with FakeIndicator("modbus", values_mm=values, follow=tmp_path / "s.csv") as fake:
        command = [sys.executable, str(ROOT / "scripts" / "collect.py"), "irb120", "--poses", "p.csv",
                   "--port", fake.path, "--out", "s.csv", *MODBUS, *FAST]
        with open(tmp_path / "log.txt", "w") as log:
            done = subprocess.run(command, cwd=tmp_path, stdout=log, stderr=subprocess.PIPE, text=True,
                                  timeout=120, preexec_fn=_full_disk(1500))
        err = done.stderr.strip().splitlines()
        assert done.returncode == 2 and len(err) == 1, done.stderr
        saved = len(_rows(tmp_path / "s.csv")[0])
        assert 0 < saved < N and f"{saved} of {N} poses are saved in s.csv" in err[0], err[0]
        assert _collect(fake, tmp_path / "p.csv", tmp_path / "s.csv") == 0
    assert _rows(tmp_path / "s.csv")[0] == list(range(1, N + 1))

"""Outputs (calib_pin/util/outputs.py): never overwritten without --force, never an input,
never cut or half-moved: a full disk and a failed rename leave every file as it was."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from calib_pin.cli import command
from calib_pin.util.outputs import OutputError, Outputs

#: Run ``calib-pin ARGS`` in a process whose files may not grow past ``limit`` bytes.
ENTRY = "import sys; from calib_pin.cli import main; sys.exit(main(sys.argv[1:]))"


def _full_disk(limit: int):
    """A preexec function: files of at most ``limit`` bytes, and a write past it fails
    (EFBIG, after a short write) instead of killing the process, as on a full disk."""
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


def _run_full(args: list[str], cwd: Path, limit: int = 2000) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", ENTRY, *args], cwd=cwd, capture_output=True, text=True,
                          timeout=120, preexec_fn=_full_disk(limit))


FULL_DISK = {
    "make-poses": (["make-poses", "irb120", "--n", "200", "--out", "p.csv"], ["p.csv"]),
    "plan-poses": (["plan-poses", "irb120", "--n", "100", "--candidates", "200", "--out", "p.csv", "--quiet"],
                   ["p.csv"]),
    "simulate": (["simulate", "irb120", "--poses", "200", "--out", "s.csv"], ["s.csv", "s.truth.json"]),
}


@pytest.mark.parametrize("name", FULL_DISK)
def test_full_disk_leaves_no_cut_file(name, tmp_path):
    """On a full disk a command fails with one line, and leaves no file of its own: an
    earlier output given --force to replace is kept whole, a new one never appears."""
    args, outputs = FULL_DISK[name]
    for out in outputs:
        (tmp_path / out).write_text("earlier run, kept\n")
    done = _run_full([*args, "--force"], tmp_path)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert "cannot write" in lines[0] and outputs[0] in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(outputs)
    assert all((tmp_path / out).read_text() == "earlier run, kept\n" for out in outputs)
    for out in outputs:
        (tmp_path / out).unlink()
    done = _run_full(args, tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert list(tmp_path.iterdir()) == []


def _set(folder: Path, force: bool, break_second) -> Outputs:
    """Three outputs a, b, c; writing b's temporary file also calls ``break_second`` (b's
    final name turns into a folder, so renaming b into place fails for real)."""
    out = Outputs(folder, force=force)
    out.add(folder / "a.txt", lambda tmp: tmp.write_text("new a"))

    def write_b(tmp: Path) -> None:
        tmp.write_text("new b")
        break_second()

    out.add(folder / "b.txt", write_b)
    out.add(folder / "c.txt", lambda tmp: tmp.write_text("new c"))
    return out


def test_failed_rename_mid_commit_restores_the_earlier_set(tmp_path):
    """With --force: a renamed, b's rename fails: a is the earlier a again, c untouched,
    no temporary or backup file is left."""
    for name in "ac":
        (tmp_path / f"{name}.txt").write_text(f"old {name}")

    def folder_at_b() -> None:
        (tmp_path / "b.txt").mkdir()
        (tmp_path / "b.txt" / "inside").write_text("x")

    with pytest.raises(OutputError, match=r"b\.txt: cannot rename into place: .*no output was changed"):
        _set(tmp_path, True, folder_at_b).commit()
    assert (tmp_path / "a.txt").read_text() == "old a" and (tmp_path / "c.txt").read_text() == "old c"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt", "c.txt"]
    assert [p.name for p in (tmp_path / "b.txt").iterdir()] == ["inside"]


def test_output_appearing_mid_commit_is_not_replaced(tmp_path):
    """Without --force: b appears while the set is written (another program): it is kept,
    and a, already moved into place, is removed again: none of the set is left."""
    def other_writes_b() -> None:
        (tmp_path / "b.txt").write_text("someone else's")

    with pytest.raises(OutputError, match=r"b\.txt exists: give --force"):
        _set(tmp_path, False, other_writes_b).commit()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.txt"]
    assert (tmp_path / "b.txt").read_text() == "someone else's"


def test_commit_replaces_with_force_and_lists_the_files(tmp_path):
    (tmp_path / "a.txt").write_text("old a")
    written = _set(tmp_path, True, lambda: None).commit()
    assert written == [tmp_path / f"{n}.txt" for n in "abc"]
    assert [(tmp_path / f"{n}.txt").read_text() for n in "abc"] == ["new a", "new b", "new c"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt", "c.txt"]


def test_an_input_is_refused_by_any_name(tmp_path):
    """./p.csv, a symbolic link and a hard link to an input are that input."""
    poses = tmp_path / "p.csv"
    poses.write_text("x")
    os.symlink(poses, tmp_path / "sym.csv")
    os.link(poses, tmp_path / "hard.csv")
    out = Outputs(tmp_path, force=True, inputs={"--poses": poses, "ROBOT": None})
    for name in ("p.csv", "./p.csv", "sym.csv", "hard.csv"):
        with pytest.raises(OutputError, match=r"is an input of this command \(--poses\)"):
            out.check(tmp_path / name)
    assert out.check(tmp_path / "other.csv") == tmp_path / "other.csv"


@pytest.fixture(scope="module")
def calibration(tmp_path_factory):
    """A calibrate --out folder of the shipped IRB120 set (dh model)."""
    folder = tmp_path_factory.mktemp("cal")
    assert command("calibrate")(["irb120", "--out", str(folder), "--no-html", "--method", "lm"]) == 0
    return folder


def test_compensate_replaces_only_with_force(calibration, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert command("make-poses")(["irb120", "--n", "4", "--out", "t.csv"]) == 0
    Path("x.csv").write_text("old")
    args = ["irb120", "--calibration", str(calibration), "--targets", "t.csv", "--out", "x.csv"]
    assert command("compensate")(args) == 2
    assert Path("x.csv").read_text() == "old"
    assert command("compensate")([*args, "--force"]) == 0
    assert "position_error_mm" in Path("x.csv").read_text()
    capsys.readouterr()


def test_compensate_hint_names_only_its_own_options(calibration, tmp_path, capsys):
    """A URDF path loses the robot's DH table: the message says to name the robot, and
    names no option compensate does not have (it has no --model)."""
    urdf = Path(__file__).resolve().parent.parent / "robots" / "irb120.urdf"
    targets = tmp_path / "t.csv"
    assert command("make-poses")(["irb120", "--n", "4", "--out", str(targets)]) == 0
    capsys.readouterr()
    code = command("compensate")([str(urdf), "--calibration", str(calibration), "--targets", str(targets),
                                  "--out", str(tmp_path / "x.csv")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "give the robot by its name 'irb120'" in err[0] and "--model" not in err[0], err[0]
    assert not (tmp_path / "x.csv").exists()


#: Each command's output options that a FIFO (standing for /dev/null) is given as.
SPECIAL = {
    "make-poses": ["irb120", "--n", "4", "--out", "f"],
    "plan-poses": ["irb120", "--n", "4", "--candidates", "40", "--out", "f", "--quiet"],
    "simulate": ["irb120", "--poses", "5", "--out", "f"],
    "collect": ["irb120", "--poses", "p.csv", "--out", "o.csv", "--port", "/dev/null/x", "--save-profile", "f"],
}


@pytest.mark.parametrize("name", SPECIAL)
def test_a_device_or_pipe_output_is_refused_even_with_force(name, tmp_path, monkeypatch, capsys):
    """``--out /dev/null --force`` once replaced /dev/null by a regular file (as root): an
    output that is a device, a pipe or a socket is refused, --force or not; a FIFO stands
    for the device here."""
    monkeypatch.chdir(tmp_path)
    assert command("make-poses")(["irb120", "--n", "4", "--out", "p.csv"]) == 0
    os.mkfifo("f")
    capsys.readouterr()
    assert command(name)([*SPECIAL[name], "--force"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "f is a pipe or socket, not a file" in err[0], err
    assert Path("f").is_fifo() and not Path("o.csv").exists()
    with pytest.raises(OutputError, match="is a pipe or socket"):
        Outputs(tmp_path).check(tmp_path / "f")


def test_compensate_to_a_pipe_is_refused_even_with_force(calibration, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert command("make-poses")(["irb120", "--n", "4", "--out", "t.csv"]) == 0
    os.mkfifo("f")
    capsys.readouterr()
    args = ["irb120", "--calibration", str(calibration), "--targets", "t.csv", "--out", "f", "--force"]
    assert command("compensate")(args) == 2
    assert "f is a pipe or socket" in capsys.readouterr().err and Path("f").is_fifo()


@pytest.fixture
def read_only_folder(tmp_path):
    """A read-only tmpfs (root writes through chmod, not through a read-only mount);
    skipped where mounting is not permitted."""
    folder = tmp_path / "ro"
    folder.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k,ro", "tmpfs", str(folder)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], check=True)


def test_a_read_only_folder_names_the_output_not_its_temporary_file(read_only_folder, tmp_path, capsys):
    """The clean-up of a temporary file that could not be made once replaced the error
    with ``ro/.p.csv.PID.tmp: Read-only file system``; the line names the output."""
    for out in (read_only_folder / "p.csv", read_only_folder / "sub" / "p.csv"):
        assert command("make-poses")(["irb120", "--n", "4", "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{out}: cannot" in err[0] and "Read-only file system" in err[0], err
        assert ".tmp" not in err[0], err


@pytest.mark.parametrize(("name", "argv"), [
    ("compensate", ["--targets", "t.csv", "--out", "{robots}/irb120.urdf"]),
    ("make-poses", ["--n", "4", "--out", "{robots}/irb120.toml"]),
    ("plan-poses", ["--n", "4", "--candidates", "40", "--quiet", "--out", "{robots}/irb120.urdf"]),
    ("simulate", ["--poses", "4", "--out", "{robots}/irb120_default.csv"]),
])
def test_a_robot_given_by_name_keeps_its_files(name, argv, calibration, tmp_path, monkeypatch, capsys):
    """``compensate irb120 ... --out robots/irb120.urdf --force`` once replaced the shipped
    URDF the name reads: a robot's own files are inputs (a copy of robots/ stands in)."""
    import shutil

    import calib_pin.robot.description as description

    robots = tmp_path / "robots"
    shutil.copytree(description.ROBOTS_DIR, robots)
    monkeypatch.setattr(description, "ROBOTS_DIR", robots)
    monkeypatch.chdir(tmp_path)
    assert command("make-poses")(["irb120", "--n", "4", "--out", "t.csv"]) == 0
    before = {p.name: p.read_bytes() for p in robots.iterdir()}
    extra = ["--calibration", str(calibration)] if name == "compensate" else []
    capsys.readouterr()
    assert command(name)(["irb120", *extra, *[a.format(robots=robots) for a in argv], "--force"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is an input of this command (ROBOT irb120's" in err[0], err
    assert {p.name: p.read_bytes() for p in robots.iterdir()} == before


@pytest.mark.parametrize(("name", "argv"), [
    ("make-poses", ["irb120", "--n", "4", "--out", "p.csv"]),
    ("simulate", ["irb120", "--poses", "5", "--out", "s.csv"]),
    ("calibrate", ["irb120", "--method", "lm", "--no-html", "--out", "o"]),
])
def test_ctrl_c_after_the_commit_does_not_say_nothing_was_written(name, argv, tmp_path, monkeypatch, capsys):
    """Ctrl-C while the summary is printed, after every output is in place, once said
    'nothing was written': the line names what was written in full."""
    import calib_pin.util.outputs as outputs

    real = outputs.Outputs.commit

    def commit_then_ctrl_c(self):
        real(self)
        raise KeyboardInterrupt

    monkeypatch.setattr(outputs.Outputs, "commit", commit_then_ctrl_c)
    monkeypatch.chdir(tmp_path)
    assert command(name)(argv) == 130
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and "after the outputs were written in full" in err[0], err
    assert "nothing was written" not in err[0]

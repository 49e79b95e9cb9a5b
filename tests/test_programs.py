"""Controller programs (calib_pin.export.programs): each writer's file parsed back by a
reader written here from the language's syntax, every axis value checked against the
compensated CSV to 1e-6 deg; the joint conventions; the CLI's --format."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.calibration.record import write_calibration
from calib_pin.cli import command
from calib_pin.export.calibration_file import calibration_path
from calib_pin.export.programs import PROGRAMS, Convention, Program, program_files, rapid, urscript
from calib_pin.measurements.pose_list import read_pose_list

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "robots" / "irb120_program.csv"
NUMBER = r"[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?"


def read_rapid(text: str) -> tuple[list[int], np.ndarray]:
    """Pose numbers in MoveAbsJ order and their robot axes [deg] from a RAPID module."""
    assert text.startswith("MODULE ") and text.rstrip().endswith("ENDMODULE")
    targets = {}
    for name, robax, extax in re.findall(r"CONST jointtarget (\w+):=\[\[([^\]]*)\],\[([^\]]*)\]\];", text):
        assert extax.split(",") == ["9E9"] * 6
        targets[name] = [float(v) for v in robax.split(",")]
    body = text[text.index("PROC "):text.index("ENDPROC")]
    order = re.findall(r"MoveAbsJ (\w+)\\NoEOffs, v\d+, fine, tool0;", body)
    assert sorted(order) == sorted(targets)
    return [_pose_of(name, "jt_") for name in order], np.array([targets[name] for name in order])


def _pose_of(name: str, prefix: str) -> int:
    """The pose number of a target's name (``jt_3``, ``XPm3`` for pose -3)."""
    assert name.startswith(prefix)
    number = name[len(prefix):]
    return -int(number[1:]) if number.startswith("m") else int(number)


def read_krl(src: str, dat: str) -> tuple[list[int], np.ndarray]:
    """Pose numbers in PTP order and A1..A6 [deg] from a KRL .src/.dat pair."""
    name = re.search(r"^DEF (\w+)\( \)$", src, re.M).group(1)
    assert re.search(rf"^DEFDAT {name} PUBLIC$", dat, re.M) and src.rstrip().endswith("END")
    points = {}
    for point, body in re.findall(r"^DECL E6AXIS (\w+)=\{([^}]*)\}$", dat, re.M):
        fields = dict(f.split(" ") for f in body.split(","))
        assert list(fields) == [f"A{i}" for i in range(1, 7)] + [f"E{i}" for i in range(1, 7)]
        points[point] = [float(fields[f"A{i}"]) for i in range(1, 7)]
    order = re.findall(r"^  PTP (\w+)$", src, re.M)
    assert sorted(order) == sorted(points)
    return [_pose_of(p, "XP") for p in order], np.array([points[p] for p in order])


def read_urscript(text: str) -> tuple[list[int], np.ndarray, list[tuple[float, float]]]:
    """Pose numbers, joint positions [rad] and (a, v) of each movej of a URScript function."""
    assert re.search(r"^def \w+\(\):$", text, re.M) and text.rstrip().endswith("end")
    poses = [int(p) for p in re.findall(r"^  # pose (-?\d+)", text, re.M)]
    moves = re.findall(rf"^  movej\(\[([^\]]*)\], a=({NUMBER}), v=({NUMBER})\)$", text, re.M)
    assert len(moves) == len(poses)
    return poses, np.array([[float(v) for v in q.split(",")] for q, _, _ in moves]), \
        [(float(a), float(v)) for _, a, v in moves]


@pytest.fixture(scope="module")
def calibration(chain, params, tmp_path_factory):
    data, _ = cp.simulate(chain, params, 80, seed=4)
    result = cp.calibrate("irb120", data, method="lm", test_fraction=0)
    folder = tmp_path_factory.mktemp("programs")
    write_calibration(result, calibration_path(folder, "irb120"))
    return folder


def test_every_format_of_the_example_program_reads_back(calibration, chain, tmp_path, capsys):
    """The shipped example program in CSV, RAPID, KRL and URScript: the same targets in
    the same order, every value within 1e-6 deg of the CSV's."""
    compensate = command("compensate")
    base = ["irb120", "--calibration", str(calibration), "--targets", str(EXAMPLE)]
    assert compensate([*base, "--out", str(tmp_path / "c.csv")]) == 0
    csv = read_pose_list(tmp_path / "c.csv", chain)
    expected = np.rad2deg(csv.q)
    assert np.abs(expected - np.rad2deg(read_pose_list(EXAMPLE, chain).q)).max() > 1e-3  # corrected
    for fmt in PROGRAMS:
        assert compensate([*base, "--out", str(tmp_path / "prog"), "--format", fmt]) == 0
    capsys.readouterr()
    poses, values = read_rapid((tmp_path / "prog.mod").read_text())
    assert poses == [1, 2, 3, 4, 5] and np.abs(values - expected).max() < 1e-6
    poses, values = read_krl((tmp_path / "prog.src").read_text(), (tmp_path / "prog.dat").read_text())
    assert poses == [1, 2, 3, 4, 5] and np.abs(values - expected).max() < 1e-6
    poses, q, speeds = read_urscript((tmp_path / "prog.script").read_text())
    assert poses == [1, 2, 3, 4, 5] and np.abs(np.rad2deg(q) - expected).max() < 1e-6
    assert speeds == [(1.4, 1.05)] * 5
    for name in ("prog.mod", "prog.src", "prog.dat", "prog.script"):  # what the controllers require
        _vendor_rules({Path(name).suffix: (tmp_path / name).read_text()})
    assert "ABB axis values = URDF joint angles" in (tmp_path / "prog.mod").read_text()
    # existing outputs are refused without --force (both KRL files checked), replaced with it
    assert compensate([*base, "--out", str(tmp_path / "prog.src"), "--format", "krl"]) == 2
    assert "prog.src exists" in capsys.readouterr().err
    (tmp_path / "prog.src").unlink()
    assert compensate([*base, "--out", str(tmp_path / "prog"), "--format", "krl"]) == 2
    assert "prog.dat exists" in capsys.readouterr().err and not (tmp_path / "prog.src").exists()
    assert compensate([*base, "--out", str(tmp_path / "prog"), "--format", "krl", "--force"]) == 0
    assert compensate([*base, "--out", str(tmp_path / "u.script"), "--format", "urscript",
                       "--speed-rad-s", "0.5", "--accel-rad-s2", "0.8"]) == 0
    assert read_urscript((tmp_path / "u.script").read_text())[2] == [(0.8, 0.5)] * 5
    for argv, message in ((["--out", str(tmp_path / "x.mod"), "--format", "krl"], "a krl program is .src"),
                          (["--out", str(tmp_path / "9x"), "--format", "krl"], "must be a KRL name"),
                          (["--out", str(tmp_path / "loop.src"), "--format", "krl"], "not a keyword), e.g. p_loop"),
                          (["--out", str(tmp_path / "x.csv"), "--speed-rad-s", "1"], "are for --format urscript")):
        assert compensate([*base, *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1


def test_conventions_and_a_ur5_urscript(tmp_path):
    """A convention's sign and zero are applied on writing and undone on reading; the UR5
    is written in the URDF's joint values (they are UR's); a 7-joint arm is refused."""
    conv = Convention((1.0, -1.0, 1.0, -1.0, 1.0, 1.0), (0.0, -90.0, 90.0, 0.0, 0.0, 180.0), "test")
    q = np.random.default_rng(2).uniform(-2.0, 2.0, (7, 6))
    assert np.allclose(conv.to_urdf_rad(conv.to_controller_deg(q)), q, atol=1e-14)
    assert np.allclose(conv.to_controller_deg(np.zeros((1, 6))), [[0, -90, 90, 0, 0, 180]])
    program = Program("ur_test", q, np.arange(1, 8), "ur5", tuple(f"j{i}" for i in range(6)))
    files = program_files("urscript", program, tmp_path / "ur_test")
    (path, text), = files.items()
    assert path.name == "ur_test.script" and "UR joint values = URDF joint angles" in text
    poses, values, _ = read_urscript(text)
    assert poses == list(range(1, 8)) and np.abs(np.rad2deg(values - q)).max() < 1e-6
    rapid.CONVENTIONS["signed_test"] = conv  # a robot whose controller differs from its URDF
    try:
        text = rapid.write(Program("m", q, np.arange(1, 8), "signed_test", ()))[".mod"]
    finally:
        del rapid.CONVENTIONS["signed_test"]
    _, values = read_rapid(text)
    assert np.abs(conv.to_urdf_rad(values) - q).max() < 1e-9
    with pytest.raises(cp.CalibPinError, match="holds 6 robot axes; robot 'arm7' has 7 joints"):
        urscript.write(Program("p", np.zeros((1, 7)), np.ones(1), "arm7", ()))


def _vendor_rules(files: dict[str, str]) -> None:
    """What the controllers require of the files, beyond the reader's parse: URScript starts
    with ``def`` in the first column, every other line indented, ``end`` last in the first
    column (script manual, "Connecting to URControl"); RAPID and KRL names are identifiers of
    at most 32 / 24 characters that are no reserved word; every file is ASCII; no comment
    line is longer than 78 characters."""
    from calib_pin.export.programs import COMMENT_WIDTH, RESERVED

    for suffix, text in files.items():
        assert text.isascii(), suffix
        lines = text.splitlines()
        comments = [line for line in lines if line.lstrip().startswith(("!", ";", "#")) and
                    not line.lstrip().startswith((";FOLD", ";ENDFOLD"))]
        assert comments and max(len(line) for line in comments) <= COMMENT_WIDTH, suffix
        if suffix == ".script":
            assert lines[0].startswith("def ") and lines[-1] == "end"
            assert all(line.startswith(" ") for line in lines[1:-1])
        names = re.findall(r"(?:MODULE|PROC|DEF|DEFDAT|jointtarget|E6AXIS|def) (\w+)", text)
        assert names
        limit = 24 if suffix in (".src", ".dat") else 32
        for name in names:
            assert re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name) and len(name) <= limit, name
            assert name.lower() not in RESERVED, name


def test_controller_syntax_negative_poses_long_notes_and_reserved_names(tmp_path):
    """A pose numbered -3 gets a valid name (jt_m3, XPm3) and reads back as -3; a long or
    non-ASCII note is wrapped and made ASCII; a reserved word as the name is prefixed; a
    URScript file follows the controller's def/indent/end rule."""
    from calib_pin.export.programs import identifier

    q = np.random.default_rng(5).uniform(-1.0, 1.0, (3, 6))
    poses = np.array([-3, 0, 12])
    header = ("calib-pin compensate: a header naming a calibration file \u00e9t\u00e9 with a very long path "
              + "/x" * 60, "refused pose 7 (line 9): out of reach: the position is 3432 um off")
    notes = ("", "position-only: near a singularity: position met, orientation off by 4.202e+04 urad (the least "
             "the joints allow for their change), largest joint change joint_1 +2.26 deg", "")
    assert identifier("module") == "p_module" and identifier("END") == "p_END" and identifier("9x") == "p9x"
    assert identifier("a" * 40) == "a" * 24
    for fmt in PROGRAMS:
        program = Program(identifier("module" if fmt == "rapid" else "prog"), q, poses, "irb120",
                          tuple(f"joint_{i}" for i in range(1, 7)), header, notes)
        files = PROGRAMS[fmt].write(program)
        _vendor_rules(files)
        if fmt == "rapid":
            read, values = read_rapid(files[".mod"])
            assert "MODULE p_module" in files[".mod"] and "PROC p_module_run()" in files[".mod"]
        elif fmt == "krl":
            read, values = read_krl(files[".src"], files[".dat"])
        else:
            read, radians, _ = read_urscript(files[".script"])
            values = np.rad2deg(radians)
        assert read == [-3, 0, 12] and np.abs(values - np.rad2deg(q)).max() < 1e-6
        assert "?t?" in next(iter(files.values()))  # the accented letters, as ASCII


@pytest.mark.parametrize(("fmt", "name", "poses", "message"), [
    ("urscript", "movej", [1, 2], "a URScript function named 'movej' collides with the built-in function it calls, 'movej'"),
    ("urscript", "sleep", [1], "collides with the built-in function it would hide, 'sleep'"),
    ("rapid", "jt_1", [1, 2], "a RAPID module named 'jt_1' collides with a joint target it defines, 'jt_1'"),
    ("rapid", "JT_m3", [-3], "a RAPID module named 'JT_m3' collides with a joint target it defines, 'jt_m3'"),
    ("rapid", "tool0", [1], "a RAPID module named 'tool0' collides with the predefined tool it moves, 'tool0'"),
    ("rapid", "v100", [1], "collides with the predefined speed data it moves at, 'v100'"),
    ("krl", "xp2", [1, 2], "a KRL program named 'xp2' collides with a point it declares, 'XP2'"),
    ("krl", "bas", [1], "a KRL program named 'bas' collides with the system subprogram it calls, 'BAS'"),
])
def test_a_program_named_like_what_it_defines_or_calls_is_refused(fmt, name, poses, message):
    """A URScript function that calls (or hides) a built-in of its name, a RAPID module named
    like a joint target it defines or a predefined datum it uses, a KRL program named like a
    point it declares or the subprogram it calls (RAPID and KRL without case): refused,
    naming both, by the writer and by the format's check (compensate's, before the work)."""
    program = Program(name, np.zeros((len(poses), 6)), np.array(poses), "irb120", tuple(f"joint_{k}" for k in range(1, 7)))
    with pytest.raises(cp.CalibPinError, match=re.escape(message)):
        PROGRAMS[fmt].write(program)
    with pytest.raises(cp.CalibPinError, match=re.escape(message)):
        PROGRAMS[fmt].check(name, np.array(poses))


def test_names_that_only_resemble_what_a_program_uses_are_kept():
    """URScript compares with case (Movej is not movej); a RAPID module jt (its routine
    jt_run) and a KRL program XP are no target or point."""
    joints = tuple(f"joint_{k}" for k in range(1, 7))
    for fmt, name in (("urscript", "Movej"), ("rapid", "jt"), ("krl", "XP")):
        PROGRAMS[fmt].write(Program(name, np.zeros((2, 6)), np.array([1, 2]), "irb120", joints))

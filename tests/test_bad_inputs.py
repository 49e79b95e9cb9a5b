"""Bad inputs across every command: one clear line on stderr, the right exit status, no traceback.

Each row of :data:`CASES` is (command, arguments, files to create, expected exit status,
fragment of the one stderr line). A row with status 0 is a valid input that must be
accepted: no traceback, exit 0, and the fragment somewhere in what the command printed.
The files are created in a fresh folder that is the working directory of the run;
``calib-pin`` is the entry point itself.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from calib_pin.cli import command, main

ROOT = Path(__file__).resolve().parent.parent
URDF = (ROOT / "robots" / "irb120.urdf").read_text()
SHIPPED = (ROOT / "robots" / "irb120_default.csv").read_text().splitlines()
META, HEAD, ROWS = SHIPPED[:6], SHIPPED[6], SHIPPED[7:]
GOOD_ROW = ROWS[0]


def csv(*rows: str, meta: tuple[str, ...] = tuple(META), head: str = HEAD) -> str:
    """A cable measurement set: the shipped metadata and header, then ``rows``."""
    return "\n".join([*meta, head, *rows]) + "\n"


def data(n: int = 40) -> str:
    return csv(*ROWS[:n])


def bad(column: int, value: str) -> str:
    """40 good rows, but field ``column`` of the 4th (file line 11) is ``value``."""
    return data().replace(ROWS[3], swap(ROWS[3], column, value))


def anchor(line: str) -> str:
    """40 good rows under the metadata line ``line`` in place of the anchor."""
    return csv(*ROWS[:40], meta=(*META[:2], line, *META[3:]))


def swap(row: str, column: int, value: str) -> str:
    """``row`` with field ``column`` (0-based) replaced by ``value``."""
    fields = row.split(",")
    fields[column] = value
    return ",".join(fields)


POSE_SHIPPED = (ROOT / "robots" / "irb120_pose_example.csv").read_text().splitlines()
POSE_HEAD = next(k for k, line in enumerate(POSE_SHIPPED) if not line.startswith("#"))
POSE_ROWS = POSE_SHIPPED[POSE_HEAD + 1 :]


def pose_set(quaternion: str | None = None) -> str:
    """The shipped 6-D pose example's first 40 rows; ``quaternion``: the 3rd row's (file line 9) instead."""
    rows = POSE_ROWS[:40]
    if quaternion is not None:
        rows[2] = ",".join(rows[2].split(",")[:-4] + quaternion.split(","))
    return "\n".join([*POSE_SHIPPED[: POSE_HEAD + 1], *rows]) + "\n"


CONTACT_SHIPPED = (ROOT / "robots" / "irb120_contact_example.csv").read_text().splitlines()
CONTACT_HEAD = next(k for k, line in enumerate(CONTACT_SHIPPED) if not line.startswith("#"))
CONTACT_ROWS = CONTACT_SHIPPED[CONTACT_HEAD + 1 :]


def contact_set(*meta: str, planes: int = 0, label: str | None = None, half: slice = slice(None)) -> str:
    """The shipped contact example (its metadata, then ``meta``); ``planes``: that many of
    socket A's rows touch plane W instead; ``label``: the 2nd row's two ids (file line 8);
    ``half``: its rows of this slice only (``slice(1, None, 2)``: another session's touches)."""
    rows = list(CONTACT_ROWS)[half]
    for k in range(planes):
        rows[k] = rows[k].rsplit(",", 2)[0] + ",,W"
    if label is not None:
        rows[1] = rows[1].rsplit(",", 2)[0] + "," + label
    return "\n".join([*CONTACT_SHIPPED[:CONTACT_HEAD], *meta, CONTACT_SHIPPED[CONTACT_HEAD], *rows]) + "\n"


def urdf(old: str, new: str, count: int = 1) -> str:
    assert old in URDF
    return URDF.replace(old, new, count)


LIMIT1 = 'lower="-2.879793265790644" upper="2.879793265790644"'
POSES = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0\n2,10,10,10,10,10,10\n"
IDENTICAL = csv(*[ROWS[0]] * 120)
SESSION = ("# robot: irb120\n# end_frame: tool0\n# anchor_mm: 600, 200, -100\n"
           "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,length_mm\n1,0,0,0,0,0,0,1000.5\n")
CAL = "calibrate"
SIM = "simulate"
CMP = "compare"
COL = "collect"
MK = "make-poses"
PLAN = "plan-poses"
FAKE = "fake-indicator"
BENCH = "benchmark"
ENTRY = "calib-pin"
PORT = ["--port", "/dev/null/nonexistent"]
COLLECT = ["irb120", "--poses", "p.csv", "--out", "o.csv", *PORT]

#: (command, arguments, files to create, expected exit status, fragment of the one stderr line).
Case = tuple[str, list[str], dict[str, str | bytes], int, str]

CASES: list[Case] = [
    # --- calibrate: robot and options
    (CAL, ["nosuchrobot"], {}, 2, "nosuchrobot"),
    (CAL, ["missing.urdf"], {}, 2, "missing.urdf"),
    (CAL, ["r.urdf", "--data", "d.csv"], {"r.urdf": "<robot name='x'><link", "d.csv": data()}, 2, "r.urdf"),
    (CAL, ["r.urdf", "--data", "d.csv"], {"r.urdf": b"\x00\x01\x02binary", "d.csv": data()}, 2, "r.urdf"),
    (CAL, ["irb120", "--method", "nope"], {}, 2, "nope"),
    (CAL, ["irb120", "--test-fraction", "1.5"], {}, 2, "--test-fraction"),
    (CAL, ["irb120", "--noise-mm", "0"], {}, 2, "--noise-mm"),
    (CAL, ["irb120", "--noise-mm", "1e300"], {}, 2, "--noise-mm"),
    (CAL, ["irb120", "--noise-mm", "nan"], {}, 2, "--noise-mm"),
    (CAL, ["irb120", "--anchor-mm", "1,2"], {}, 2, "--anchor-mm"),
    (CAL, ["irb120", "--anchor-mm", "1e300,0,0"], {}, 2, "--anchor-mm"),
    (CAL, ["irb120", "--length-offset-mm", "inf"], {}, 2, "--length-offset-mm"),
    (CAL, ["irb120", "--seed", "-1"], {}, 2, "--seed"),
    (CAL, ["irb120", "--loss", "wobbly"], {}, 2, "wobbly"),
    (CAL, ["irb120", "--estimate", "moon"], {}, 2, "moon"),
    (CAL, ["irb120", "--end-frame", "nowhere"], {}, 2, "nowhere"),
    (CAL, ["irb120", "--model", "poe"], {}, 2, "--model"),
    (CAL, ["irb120", "--bogus"], {}, 2, "--bogus"),
    # --- calibrate: the data file
    (CAL, ["irb120", "--data", "none.csv"], {}, 2, "none.csv"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": ""}, 2, "d.csv"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bytes(range(256)) * 20}, 2, "d.csv"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(2, "1\x002")}, 2, "d.csv:"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(2, "1_0")}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(6, "nan")}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(6, "inf")}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(6, "1e300")}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(6, "-5")}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(1, "1e20")}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(1, "abc")}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(1, "x" * 200_000)}, 2, "d.csv"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": data().replace(ROWS[3], ROWS[3] + ",7")}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": data().replace(ROWS[3], ROWS[3].rsplit(",", 1)[0])}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": data().replace(ROWS[3], '"1,2",' + ROWS[3])}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": data().replace(ROWS[3], '"' + ROWS[3])}, 2, "d.csv"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], head=HEAD + ",q1_rad")}, 2, "q1_rad"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], head=HEAD.replace("q2_deg", "q1_deg"))}, 2, "q1_deg"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], head=HEAD.replace("q6_deg,", ""))}, 2, "q6"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], head=HEAD + ",length_m")}, 2, "length_m"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], head=HEAD.replace("length_mm", "lenght_mm"))}, 2, "d.csv"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], meta=(*META, "# anchor_mm: 1, 2, 3"))}, 2, "anchor_mm"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": anchor("# anchor_mm: 1e300, 0, 0")}, 2, "anchor_mm"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": anchor("# anchor_mm: 1, 2")}, 2, "anchor_mm"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": anchor("# anchor_mm: nan, 0, 0")}, 2, "anchor_mm"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], meta=("# robot: ur5", *META[1:]))}, 2, "ur5"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40]) + "# tool_mm: 0, 0, 60\n"}, 2, "tool_mm"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:3])}, 2, "d.csv"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv()}, 2, "d.csv"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": bad(1, "400")}, 2, "d.csv:11"),
    (CAL, ["irb120", "--data", "d.csv", "--test-data", "t.csv"], {"d.csv": data()}, 2, "t.csv"),
    (CAL, ["irb120", "--data", "d.csv", "--test-data", "t.csv"], {"d.csv": data(), "t.csv": "x\n"}, 2, "t.csv"),
    (CAL, ["irb120", "--data", "d.csv", "--test-data", "t.csv"],
     {"d.csv": data(), "t.csv": csv(*ROWS[40:60], meta=("# robot: ur5", *META[1:]))}, 2, "t.csv"),
    (CAL, ["irb120", "--data", "d.csv", "--test-data", "w.csv"],
     {"d.csv": data(), "w.csv": (ROOT / "robots" / "irb120_wu2015.csv").read_text()}, 2, "w.csv"),
    (CAL, ["irb120", "--data", "same.csv", "--method", "lm"], {"same.csv": IDENTICAL}, 2, "identify only 1 of 24"),
    (CAL, ["irb120", "--data", "d.csv", "--analyze"], {"d.csv": csv(*ROWS[:40], head=HEAD + ",q1_rad")}, 2, "q1_rad"),
    (CAL, ["irb120", "--data", "w.csv", "--analyze"], {"w.csv": "pose,x_mm\n1,2\n"}, 2, "w.csv"),
    (CAL, ["r.urdf", "--analyze"],
     {"r.urdf": urdf('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>')}, 2, "'joint_2' has a zero axis"),
    (CAL, ["irb120", "--data", "d.csv", "--out", "f", "--method", "lm"], {"d.csv": data(), "f": "a file"}, 2, "f"),
    # --- simulate
    (SIM, ["irb120"], {}, 2, "--out"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "1e9"], {}, 2, "--poses"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "0"], {}, 2, "--poses"),
    (SIM, ["irb120", "--out", "s.csv", "--noise-mm", "0"], {}, 0, "noise 0 mm"),
    (SIM, ["irb120", "--out", "s.csv", "--noise-mm", "1e300"], {}, 2, "--noise-mm"),
    (SIM, ["irb120", "--out", "s.csv", "--noise-kind", "pink"], {}, 2, "--noise-kind"),
    (SIM, ["irb120", "--out", "s.csv", "--nominal-rmse-mm", "-1"], {}, 2, "--nominal-rmse-mm"),
    (SIM, ["irb120", "--out", "s.csv", "--length-offset-mm", "1e300"], {}, 2, "--length-offset-mm"),
    (SIM, ["irb120", "--out", "s.csv", "--length-offset-mm", "-5000"], {}, 2, "a drawstring reading is >= 0"),
    (SIM, ["irb120", "--out", "s.csv", "--kinds", "cable,position", "--sessions", "3"], {}, 2,
     "--kinds names 2 kinds for 3 sessions"),
    (SIM, ["irb120", "--out", "s.csv", "--kinds", "cable,laser"], {}, 2, "unknown kinds 'laser'"),
    (SIM, ["irb120", "--out", "s.csv", "--kinds", "cable,"], {}, 2, "--kinds"),
    (SIM, ["irb120", "--out", "s.csv", "--sessions", "2", "--noise-mm", "0.05,0.02,0.01"], {}, 2,
     "--noise-mm gives 3 values for 2 session(s)"),
    (SIM, ["irb120", "--out", "s.csv", "--kinds", "position", "--noise-kind", "student"], {}, 2,
     "noise_kind: 'student' is drawn for rows of one value"),
    (SIM, ["irb120", "--out", ""], {}, 2, "--out"),
    (SIM, ["irb120", "--out", "sub"], {"sub/x": "x"}, 2, "sub"),
    (SIM, ["irb120", "--out", "s.csv", "--poses-file", "nope.csv"], {}, 2, "nope.csv"),
    (SIM, ["irb120", "--out", "s.csv", "--poses-file", "p.csv"],
     {"p.csv": POSES.replace("10,10,10,10", "10,10,999,10")}, 2, "p.csv:3"),
    (SIM, ["r.urdf", "--out", "s.csv"], {"r.urdf": urdf(LIMIT1, 'lower="1" upper="-1"')}, 2, "'joint_1' has limits"),
    (SIM, ["r.urdf", "--out", "s.csv"], {"r.urdf": urdf(LIMIT1, 'lower="1" upper="1"')}, 2, "'joint_1' has limits"),
    (SIM, ["r.urdf", "--out", "s.csv"],
     {"r.urdf": urdf('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>')}, 2, "'joint_1' has a zero axis"),
    (SIM, ["r.urdf", "--out", "s.csv"], {"r.urdf": urdf('<joint name="joint_6-flange" type="fixed">',
                                                       '<joint name="loop" type="fixed"><parent link="link_6"/>'
                                                       '<child link="link_2"/></joint>'
                                                       '<joint name="joint_6-flange" type="fixed">')}, 2, "kinematic loop"),
    (SIM, ["r.urdf", "--out", "s.csv"], {"r.urdf": urdf('type="revolute"', 'type="spinning"')}, 2, "r.urdf"),
    (SIM, ["r.urdf", "--out", "s.csv"], {"r.urdf": URDF[: len(URDF) // 2]}, 2, "XML_ERROR"),
    (SIM, ["irb120", "--out", "s.csv", "--model", "x"], {}, 2, "--model"),
    # --- compare
    (CMP, ["irb120", "--trials", "0"], {}, 2, "--trials"),
    (CMP, ["irb120", "--trials", "1e9"], {}, 2, "--trials"),
    (CMP, ["irb120", "--methods", "lm,zzz"], {}, 2, "zzz"),
    (CMP, ["irb120", "--methods", ","], {}, 2, "--methods"),
    (CMP, ["irb120", "--simulate", "gauss", "--data", "d.csv"], {"d.csv": data()}, 2, "--data or --simulate"),
    (CMP, ["irb120", "--simulate", "gauss", "--poses", "1", "--methods", "lm"], {}, 2, "1 rows at test fraction 0.2"),
    (CMP, ["irb120", "--data", "d.csv", "--methods", "lm"], {"d.csv": bad(6, "nan")}, 2, "d.csv:11"),
    (CMP, ["irb120", "--data", "none.csv"], {}, 2, "none.csv"),
    (CMP, ["irb120", "--noise-mm", "-1"], {}, 2, "--noise-mm"),
    (CMP, ["irb120", "--test-fraction", "1"], {}, 2, "--test-fraction"),
    (CMP, ["nosuch"], {}, 2, "nosuch"),
    # --- make-poses
    (MK, ["irb120"], {}, 2, "--out"),
    (MK, ["irb120", "--n", "0", "--out", "p.csv"], {}, 2, "--n"),
    (MK, ["irb120", "--n", "1e20", "--out", "p.csv"], {}, 2, "--n"),
    (MK, ["irb120", "--n", "abc", "--out", "p.csv"], {}, 2, "--n"),
    (MK, ["irb120", "--margin-deg", "200", "--out", "p.csv"], {}, 2, "--margin-deg"),
    (MK, ["irb120", "--margin-deg", "1e300", "--out", "p.csv"], {}, 2, "--margin-deg"),
    (MK, ["irb120", "--out", "dir"], {"dir/x": "x"}, 2, "dir"),
    (MK, ["irb120", "--end-frame", "base_link", "--out", "p.csv"], {}, 2, "base_link"),
    (MK, ["r.urdf", "--out", "p.csv"], {"r.urdf": urdf(LIMIT1, 'lower="1" upper="-1"')}, 2, "joint_1"),
    # --- plan-poses
    (PLAN, ["irb120", "--candidates", "1e7", "--out", "p.csv"], {}, 2, "--candidates"),
    (PLAN, ["irb120", "--n", "50", "--candidates", "10", "--out", "p.csv"], {}, 2, "--candidates"),
    (PLAN, ["irb120", "--estimate", "sky", "--out", "p.csv"], {}, 2, "sky"),
    (PLAN, ["irb120", "--anchor-mm", "a,b,c", "--out", "p.csv"], {}, 2, "--anchor-mm"),
    (PLAN, ["irb120", "--margin-deg", "500", "--out", "p.csv"], {}, 2, "margin"),
    (PLAN, ["irb120", "--model", "dh", "--end-frame", "link_1", "--out", "p.csv"], {}, 2, "link_1"),
    # --- collect
    (COL, ["irb120", "--poses", "p.csv", "--out", "o.csv"], {"p.csv": POSES}, 2, "--port"),
    (COL, ["irb120", *PORT], {}, 2, "--poses"),
    (COL, COLLECT, {}, 2, "p.csv"),
    (COL, COLLECT, {"p.csv": POSES.replace("\n2,", "\n1,")}, 2, "p.csv:3"),
    (COL, COLLECT, {"p.csv": POSES.replace("2,10,10", "2,10,1e400")}, 2, "p.csv:3"),
    (COL, COLLECT, {"p.csv": POSES, "o.csv": b"\x89PNG\r\n\x1a\n\x00\x00"}, 2, "o.csv"),
    (COL, COLLECT, {"p.csv": POSES, "o.csv": data()}, 2, "o.csv"),
    (COL, COLLECT, {"p.csv": POSES, "o.csv": '{"urdf": null}'}, 2, "o.csv"),
    (COL, [*COLLECT, "--anchor-mm", "1,2,3"], {"p.csv": POSES, "o.csv": SESSION}, 2, "was collected with anchor_mm 600"),
    (COL, [*COLLECT, "--tool-mm", "0,0,70"], {"p.csv": POSES, "o.csv": SESSION}, 2, "was collected with tool_mm none"),
    (COL, COLLECT, {"p.csv": POSES, "o.csv": SESSION.replace("\n1,0,", "\n9,0,")}, 2, "pose 9 is not in p.csv"),
    (COL, [*COLLECT, "--baud", "fast"], {"p.csv": POSES}, 2, "--baud"),
    (COL, [*COLLECT, "--samples", "0"], {"p.csv": POSES}, 2, "samples"),
    (COL, [*COLLECT, "--max-mm", "-1"], {"p.csv": POSES}, 2, "max_mm"),
    (COL, [*COLLECT, "--scale-mm", "nan"], {"p.csv": POSES}, 2, "scale_mm"),
    (COL, [*COLLECT, "--pattern", "("], {"p.csv": POSES}, 2, "pattern"),
    (COL, [*COLLECT, "--profile", "prof.json"], {"p.csv": POSES, "prof.json": '{"baud": "fast"}'}, 2, "baud"),
    (COL, [*COLLECT, "--profile", "prof.json"], {"p.csv": POSES, "prof.json": '{"colour": 1}'}, 2, "colour"),
    (COL, [*COLLECT, "--profile", "prof.json"], {"p.csv": POSES, "prof.json": "{"}, 2, "prof.json"),
    (COL, [*COLLECT, "--profile", "prof.json"], {"p.csv": POSES, "prof.json": "[1]"}, 2, "prof.json"),
    (COL, [*COLLECT, "--profile", "none.json"], {"p.csv": POSES}, 2, "none.json"),
    (COL, [*COLLECT, "--anchor-mm", "1,2,3,4"], {"p.csv": POSES}, 2, "--anchor-mm"),
    (COL, [*COLLECT, "--auto", "-1"], {"p.csv": POSES}, 2, "--auto"),
    (COL, ["--probe", *PORT], {}, 2, "/dev/null/nonexistent"),
    (COL, ["--probe", *PORT, "--protocol", "ascii", "--pattern", "no group"], {}, 2, "pattern"),
    (COL, ["--probe", *PORT, "--count", "-3"], {}, 2, "--count"),
    # --- fake-indicator
    (FAKE, ["--protocol", "smoke"], {}, 2, "--protocol"),
    (FAKE, ["--words", "3"], {}, 2, "--words"),
    (FAKE, ["--values", "d.csv"], {"d.csv": data()}, 2, "--follow"),
    (FAKE, ["--values", "none.csv", "--follow", "o.csv"], {}, 2, "none.csv"),
    (FAKE, ["--scale-mm", "0"], {}, 2, "scale_mm"),
    (FAKE, ["--slave", "300"], {}, 2, "slave = 300"),
    (FAKE, ["--register", "-1"], {}, 2, "register = -1"),
    (FAKE, ["--words", "1", "--value-mm", "100"], {}, 2, "16 bits"),
    (FAKE, ["--fault", "crc"], {}, 2, "--fault-every"),
    (FAKE, ["--value-mm", "1e300"], {}, 2, "does not fit"),
    (FAKE, ["--noise-mm", "nan"], {}, 2, "--noise-mm"),
    (FAKE, ["--fault", "fire"], {}, 2, "--fault"),
    (FAKE, ["--fault-every", "-2", "--fault", "crc"], {}, 2, "--fault-every"),
    # --- benchmark
    (BENCH, ["--repeats", "0"], {}, 2, "--repeats"),
    (BENCH, ["--repeats", "1e9"], {}, 2, "--repeats"),
    (BENCH, ["--methods", "fast"], {}, 2, "fast"),
    (BENCH, ["--poses", "-1"], {}, 2, "--poses"),
    (BENCH, ["--seed", "x"], {}, 2, "--seed"),
    (BENCH, ["--commands", "nonsense"], {}, 2, "nonsense"),
    (BENCH, ["--max-rows", "0"], {}, 2, "--max-rows"),
    (BENCH, ["--command-method", "fast"], {}, 2, "fast"),
    # --- the entry point
    (ENTRY, [], {}, 2, "give a command"),
    (ENTRY, ["frobnicate"], {}, 2, "frobnicate"),
    (ENTRY, ["calibrate", "--method"], {}, 2, "--method"),
    (ENTRY, ["simulate", "irb120", "--out", "s.csv", "--poses", "-4"], {}, 2, "--poses"),
    (ENTRY, ["make-poses"], {}, 2, "robot"),
]


# ---------------------------------------------------------------------------
# round 3 (issue 20), 1 and 5: outputs never overwritten or cut, messages that name the real cause
# ---------------------------------------------------------------------------
SIM5 = ["irb120", "--poses", "20", "--out", "s.csv"]
MK5 = ["irb120", "--n", "5", "--out", "p.csv"]
PLAN5 = ["irb120", "--n", "5", "--candidates", "40", "--out", "p.csv"]
CMPN = "compensate"
COMP = ["irb120", "--calibration", "c.json", "--targets", "t.csv", "--out", "x.csv"]
R3_OUTPUTS: list[Case] = [
    # an existing output is refused without --force, replaced with it; an input is never an output
    (SIM, SIM5, {"s.csv": "old"}, 2, "s.csv exists: give --force to replace it"),
    (SIM, SIM5, {"s.truth.json": "old"}, 2, "s.truth.json exists: give --force"),
    (SIM, [*SIM5, "--force"], {"s.csv": "old", "s.truth.json": "old"}, 0, "wrote s.truth.json"),
    (SIM, ["irb120", "--poses-file", "p.csv", "--out", "p.csv", "--force"], {"p.csv": POSES}, 2,
     "p.csv is an input of this command (--poses-file)"),
    (SIM, ["irb120", "--poses-file", "./s.truth.json", "--out", "s.csv", "--force"], {"s.truth.json": POSES}, 2,
     "s.truth.json is an input of this command (--poses-file)"),
    (SIM, ["r.urdf", "--out", "r.urdf", "--force"], {"r.urdf": URDF}, 2, "r.urdf is an input of this command (ROBOT)"),
    (MK, MK5, {"p.csv": "old"}, 2, "p.csv exists: give --force to replace it"),
    (MK, [*MK5, "--force"], {"p.csv": "old"}, 0, "wrote p.csv"),
    (MK, ["r.urdf", "--out", "r.urdf", "--force"], {"r.urdf": URDF}, 2, "r.urdf is an input of this command"),
    (MK, ["irb120", "--out", "p.csv", "--force"], {"p.csv/x": "x"}, 2, "p.csv is a folder"),
    (PLAN, PLAN5, {"p.csv": "old"}, 2, "p.csv exists: give --force to replace it"),
    (PLAN, [*PLAN5, "--force"], {"p.csv": "old"}, 0, "wrote p.csv"),
    (PLAN, ["r.urdf", "--n", "5", "--candidates", "40", "--out", "r.urdf", "--force"], {"r.urdf": URDF}, 2,
     "r.urdf is an input of this command"),
    (CMPN, COMP, {"t.csv": POSES, "x.csv": "old"}, 2, "x.csv exists: give --force to replace it"),
    (CMPN, [*COMP[:-1], "t.csv", "--force"], {"t.csv": POSES}, 2, "t.csv is an input of this command (--targets)"),
    (CMPN, [*COMP[:-1], "c.json", "--force"], {"t.csv": POSES, "c.json": "{}"}, 2,
     "c.json is an input of this command (--calibration)"),
    (COL, [*COLLECT, "--save-profile", "prof.json"], {"p.csv": POSES, "prof.json": "{}"}, 2,
     "prof.json exists: give --force to replace it"),
    (COL, [*COLLECT, "--save-profile", "p.csv", "--force"], {"p.csv": POSES}, 2, "p.csv is an input of this command"),
    (COL, [*COLLECT, "--save-profile", "o.csv", "--force"], {"p.csv": POSES}, 2, "o.csv is an input of this command (--out"),
    (COL, [*COLLECT, "--profile", "s.json", "--save-profile", "s.json", "--force"], {"p.csv": POSES, "s.json": "{}"},
     2, "s.json is an input of this command (--profile)"),
    (COL, ["irb120", "--poses", "p.csv", "--out", "p.csv", *PORT], {"p.csv": POSES}, 2,
     "p.csv is an input of this command (--poses)"),
    (CAL, ["irb120", "--data", "o/report.json", "--out", "o", "--method", "lm", "--no-html"], {"o/report.json": data()},
     2, "o/report.json is an input of this command (--data)"),
    (CAL, ["irb120", "--data", "d.csv", "--test-data", "./report.html", "--out", ".", "--method", "lm"],
     {"d.csv": data(), "report.html": csv(*ROWS[40:60])}, 2, "report.html is an input of this command (--test-data)"),
    ("batch", ["summary.csv", "--out", "."], {"summary.csv": data()}, 2,
     "summary.csv is an input of this command (SESSION summary.csv)"),
    (CMP, ["irb120", "--data", "o/table1.csv", "--out", "o", "--methods", "lm"], {"o/table1.csv": data()}, 2,
     "o/table1.csv is an input of this command (--data)"),
    # a file where an output's folder should be: named as such, not "File exists"
    (MK, ["irb120", "--n", "5", "--out", "f/p.csv"], {"f": "x"}, 2, "f/p.csv: cannot create its folder f: a file is in"),
    (CAL, ["irb120", "--data", "d.csv", "--out", "f/o", "--method", "lm", "--no-html"], {"d.csv": data(), "f": "x"}, 2,
     "cannot create its folder f/o: a file is in the way"),
    ("batch", ["d.csv", "--out", "f/o"], {"d.csv": data(), "f": "x"}, 2,
     "cannot keep a finished set (Not a directory); none of the 1 set(s) is kept"),
    # messages that name the real cause
    (CAL, ["irb120", "--data", "/dev/zero"], {}, 2, "/dev/zero: is not a regular file"),
    (SIM, [*SIM5, "--poses-file", "/dev/zero"], {}, 2, "/dev/zero: is not a regular file"),
    (COL, ["irb120", "--poses", "/dev/zero", "--out", "o.csv", *PORT], {}, 2, "/dev/zero: is not a regular file"),
    (COL, [*COLLECT, "--profile", "/dev/zero"], {"p.csv": POSES}, 2, "/dev/zero: is not a regular file"),
    (CMPN, ["irb120", "--calibration", "/dev/zero", "--targets", "t.csv", "--out", "x.csv"], {"t.csv": POSES}, 2,
     "/dev/zero: is not a regular file"),
    (CAL, ["irb120", "--data", "a\nb.csv"], {}, 2, "a\\nb.csv: no such file"),
    (CAL, ["irb120", "--data", "a\rb\x1b[2J.csv"], {}, 2, "a\\rb\\x1b[2J.csv"),
    (CAL, ["irb120", "--method", "x\ny"], {}, 2, "x\\ny"),
    (MK, ["irb120", "--out", "p\n.csv"], {"p\n.csv": "old"}, 2, "p\\n.csv exists"),
]


# ---------------------------------------------------------------------------
# round 3 (issue 20), 1 and 4: batch and compare keep finished work; Dask and joblib faults in one line
# ---------------------------------------------------------------------------
R3_PARALLEL: list[Case] = [
    # batch refuses what calibrate refuses: identical poses give no URDF, and the set fails
    ("batch", ["d.csv", "--out", "o", "--method", "lm"], {"d.csv": IDENTICAL}, 2, "1 of 1 set(s) failed, first d"),
    # nothing listens on the scheduler port: one line at once, not a 10 s wait
    ("batch", ["d.csv", "--out", "o", "--scheduler", "tcp://127.0.0.1:1"], {"d.csv": data()}, 2,
     "cannot reach the Dask scheduler at tcp://127.0.0.1:1"),
    (CMP, ["irb120", "--methods", "lm", "--scheduler", "tcp://127.0.0.1:1"], {}, 2,
     "cannot reach the Dask scheduler at tcp://127.0.0.1:1"),
    # the output folder is a file: one line naming it, before any set runs
    ("batch", ["d.csv", "--out", "o"], {"d.csv": data(), "o": "x"}, 2, "o"),
    (CMP, ["irb120", "--methods", "lm", "--out", "o"], {"o": "x"}, 2, "o"),
    # an earlier run's unreadable report beside the set is replaced, not read
    ("batch", ["d.csv", "--out", "o", "--method", "lm"], {"d.csv": data(), "o/d/report.json": "{cut"}, 0,
     "wrote o/summary.csv"),
    # an unreadable checkpoint file is not a finished set: the set runs again
    ("batch", ["d.csv", "--out", "o", "--method", "lm"], {"d.csv": data(), "o/.calib-pin-checkpoint/set-0.json": "{"},
     0, "wrote o/summary.csv"),
]


# ---------------------------------------------------------------------------
# round 3 (issue 20), 2 and 4: no silent wrong result; calibration files validated; the parser
# ---------------------------------------------------------------------------
def _calibration_file(**changes: object) -> str:
    """A valid irb120 calibration file (zero deviations, rigid), JSON text, with ``changes``
    at dotted keys (``deviations_si.a_1``); a value None removes the key."""
    import hashlib
    import json

    from calib_pin import load_chain, parameter_model

    chain = load_chain("irb120")
    params = parameter_model(chain)
    doc: dict = {
        "format": "calib-pin calibration", "format_version": 1, "robot": "irb120",
        "urdf": str(ROOT / "robots" / "irb120.urdf"),
        "urdf_sha256": hashlib.sha256((ROOT / "robots" / "irb120.urdf").read_bytes()).hexdigest(),
        "end_frame": "tool0", "joints": list(chain.joint_names), "parameter_model": "dh",
        "deviations_si": dict.fromkeys(params.names, 0.0),
        "deviation_units": dict(zip(params.names, params.units, strict=True)),
        "compliance": {"joints": ["joint_2"], "payload": None, "cable_tension_n": 5.0,
                       "compliance_rad_per_Nm": {"joint_2": 2e-5},
                       "cable_pull": {"hook_mm": [0.0, 0.0, 50.0], "anchor_mm": [600.0, 200.0, -100.0]}},
        "sensor": {"kind": "cable", "unknowns_si": {"anchor_x": 0.0}},
    }
    for key, value in changes.items():
        *path, last = key.split(".")
        where = doc
        for part in path:
            where = where[part]
        if value is None:
            del where[last]
        else:
            where[last] = value
    return json.dumps(doc)


COMPENSATE = "compensate"
CAL_ARGS = ["irb120", "--calibration", "c.json", "--targets", "p.csv", "--out", "o.csv"]
SHIFTED = META[2].replace("600.000000", "650.000000")  # the anchor 50 mm away
TEST_ARGS = ["irb120", "--data", "d.csv", "--test-data", "t.csv", "--method", "lm", "--no-html", "--out", "out"]


def _test_csv(*meta: str) -> str:
    """A validation session of 20 poses with the metadata lines ``meta``."""
    return csv(*ROWS[40:60], meta=meta)


#: Two training sets of the same anchor (poses 1-40 and 61-100) and a validation session (poses 41-60).
TWO_SETS = ["irb120", "--data", "a.csv", "--data", "b.csv", "--method", "lm", "--no-html", "--out", "out"]
TWO_FILES = {"a.csv": data(), "b.csv": csv(*ROWS[60:100]), "t.csv": _test_csv(*META)}


R3_WRONG: list[Case] = [
    # -0 is 0 ("test fraction -0" was printed)
    (CMP, ["irb120", "--simulate", "gauss", "--poses", "4", "--methods", "lm", "--test-fraction", "-0"], {}, 2,
     "4 rows at test fraction 0 hold out none"),
    # --- compensate: the calibration file is validated on load
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(), "p.csv": POSES}, 0, "targets compensated"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"deviations_si.a_1": 0.5}), "p.csv": POSES},
     2, "c.json: deviations_si.a_1: +500 mm is beyond the sanity bound 20 mm"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"deviations_si.theta_3": 0.2}), "p.csv": POSES},
     2, "deviations_si.theta_3"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"deviations_si.a_1": float("nan")}), "p.csv": POSES},
     2, "c.json: deviations_si.a_1: NaN is not a finite number"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"deviations_si.d_2": float("inf")}), "p.csv": POSES},
     2, "c.json: deviations_si.d_2"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file().replace('"d_3": 0.0', '"d_3": 1e999'), "p.csv": POSES},
     2, "c.json: deviations_si.d_3"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"deviations_si.a_2": "0.001"}), "p.csv": POSES},
     2, "c.json: deviations_si.a_2"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"deviations_si.a_2": None}), "p.csv": POSES},
     2, "c.json: deviations_si"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"deviations_si.zeta_9": 0.0}), "p.csv": POSES},
     2, "c.json: deviations_si"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"compliance.compliance_rad_per_Nm.joint_2": -1e-5}),
                            "p.csv": POSES}, 2, "c.json: compliance.compliance_rad_per_Nm.joint_2"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"compliance.compliance_rad_per_Nm.joint_2": float("nan")}),
                            "p.csv": POSES}, 2, "c.json: compliance.compliance_rad_per_Nm.joint_2"),
    (COMPENSATE, [*CAL_ARGS, "--with-cable"],
     {"c.json": _calibration_file(**{"compliance.cable_pull.anchor_mm": [float("nan"), 0, 0]}), "p.csv": POSES},
     2, "c.json: compliance.cable_pull.anchor_mm"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"compliance.joints": ["joint_9"]}), "p.csv": POSES},
     2, "c.json: compliance.joints"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"sensor.unknowns_si.anchor_x": float("inf")}),
                            "p.csv": POSES}, 2, "c.json: sensor.unknowns_si.anchor_x"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(format_version="1.5"), "p.csv": POSES}, 2, "c.json: format_version"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(format_version=0), "p.csv": POSES}, 2, "c.json: format_version"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(format_version=None), "p.csv": POSES}, 2, "c.json: format_version"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(format_version=2), "p.csv": POSES}, 2, "c.json: format_version"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(robot="ur5"), "p.csv": POSES}, 2, "c.json: robot"),
    (COMPENSATE, ["ur5", *CAL_ARGS[1:]], {"c.json": _calibration_file(), "p.csv": POSES}, 2, "not 'ur5'"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(joints=["joint_1", "joint_2"]), "p.csv": POSES},
     2, "c.json: joints"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(parameter_model="poe"), "p.csv": POSES},
     2, "c.json: parameter_model"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(end_frame=7), "p.csv": POSES}, 2, "c.json: end_frame"),
    (COMPENSATE, CAL_ARGS, {"c.json": "[1, 2]", "p.csv": POSES}, 2, "c.json"),
    # ... a value edited by hand in the mm/deg copy only (compensate used deviations_si, silently)
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(deviations={"a_1_mm": 500.0}), "p.csv": POSES},
     2, "c.json: deviations.a_1_mm: 500 contradicts deviations_si.a_1 (0 mm)"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(deviations={"a_1_mm": 0.0, "theta_2_deg": 1e-12}),
                            "p.csv": POSES}, 0, "targets compensated"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(deviations="none"), "p.csv": POSES}, 2, "c.json: deviations"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"compliance.stiffness_Nm_per_rad": {"joint_2": 1000.0}}),
                            "p.csv": POSES}, 2, "c.json: compliance.stiffness_Nm_per_rad.joint_2: 1000.0 contradicts"),
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(**{"compliance.stiffness_Nm_per_rad": {"joint_2": 50000.0}}),
                            "p.csv": POSES}, 0, "targets compensated"),
    # ... saved by an editor with a byte-order mark (Windows Notepad): the same file
    (COMPENSATE, CAL_ARGS, {"c.json": "\ufeff" + _calibration_file(), "p.csv": POSES}, 0, "targets compensated"),
    # --- calibrate --test-data: the validation session's own set-up must agree with the training one
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META)}, 0, "test rows from t.csv"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META[:2], META[5])}, 0, "test rows from t.csv"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META[:2], META[2].replace("600.000000", "600.0000001"),
                                                          *META[3:])}, 0, "test rows from t.csv"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META[:2], META[2].replace("600.000000", "600.0004"),
                                                          *META[3:])}, 0, "test rows from t.csv"),  # um rounding
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META[:2], META[2].replace("600.000000", "600.002"),
                                                          *META[3:])}, 2, "t.csv: anchor_mm"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META[:2], "# anchor_m: 0.6, 0.2, -0.1", *META[3:])},
     0, "test rows from t.csv"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": data()}, 2, "t.csv: holds the training set's own rows"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META[:2], SHIFTED, *META[3:])},
     2, "t.csv: anchor_mm: the validation session has 650, 200, -100 mm, the calibration 600, 200, -100 mm"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META[:3], "# tool_mm: 0, 0, 60", *META[4:])},
     2, "t.csv: tool_mm"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META[:4], "# length_offset_mm: 12.5", META[5])},
     2, "t.csv: length_offset_mm"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": _test_csv(*META[:4], "# length_offset_m: 0.0125", META[5])},
     2, "t.csv: length_offset_mm"),
    (CAL, [*TEST_ARGS, "--anchor-mm", "650,200,-100"], {"d.csv": data(), "t.csv": _test_csv(*META)},
     2, "t.csv: anchor_mm: the validation session has 600, 200, -100 mm, the calibration 650, 200, -100 mm (given)"),
    (CAL, [*TEST_ARGS, "--length-offset-mm", "3"], {"d.csv": data(), "t.csv": _test_csv(*META)},
     2, "t.csv: length_offset_mm"),
    (CAL, [*TEST_ARGS, "--anchor-mm", "600,200,-100"], {"d.csv": csv(*ROWS[:40], meta=(*META[:2], *META[3:])),
                                                        "t.csv": _test_csv(*META)}, 0, "test rows from t.csv"),
    # --- calibrate --test-data FILE:register=K|role: a new set-up, re-registered on its stated rows (issue 22)
    (CAL, [*TEST_ARGS[:4], "t.csv:register=5", *TEST_ARGS[5:]],
     {"d.csv": data(), "t.csv": _test_csv(*META[:2], SHIFTED, *META[3:])}, 0, "re-registered it (first 5 poses"),
    (CAL, [*TEST_ARGS[:4], "t.csv:register=five", *TEST_ARGS[5:]], {"d.csv": data(), "t.csv": _test_csv(*META)},
     2, "register: expected a number of poses >= 1 or 'role', got 'five'"),
    (CAL, [*TEST_ARGS[:4], "t.csv:register=role", *TEST_ARGS[5:]], {"d.csv": data(), "t.csv": _test_csv(*META)},
     2, "t.csv: role: register=role needs a 'role' column"),
    (CAL, [*TEST_ARGS[:4], "t.csv:register=20", *TEST_ARGS[5:]], {"d.csv": data(), "t.csv": _test_csv(*META)},
     2, "t.csv: register: register=20 poses of its 20: nothing left to score"),
    (CAL, [*TEST_ARGS[:4], "t.csv:register=2", *TEST_ARGS[5:]], {"d.csv": data(), "t.csv": _test_csv(*META)},
     2, "2 registration rows give 2 values, fewer than the 3 set-up unknowns"),
    (CAL, [*TEST_ARGS[:4], "t.csv:same=other", *TEST_ARGS[5:]], {"d.csv": data(), "t.csv": _test_csv(*META)},
     2, "same: 'other' is not the training set (its label: d)"),
    (CAL, [*TEST_ARGS[:4], "t.csv:same=d", *TEST_ARGS[5:]], {"d.csv": data(), "t.csv": _test_csv(*META)},
     0, "test rows from t.csv"),
    (CAL, [*TEST_ARGS[:4], "t.csv:register=5:same=d", *TEST_ARGS[5:]], {"d.csv": data(), "t.csv": _test_csv(*META)},
     2, "register (a new set-up) or same (the training set's), not both"),
    (CAL, [*TEST_ARGS[:4], "v.csv:register=5", *TEST_ARGS[5:]], {"d.csv": data()}, 2, "no file 'v.csv'"),
    (CAL, [*TEST_ARGS[:4], "t.csv:register=5", *TEST_ARGS[5:6], "rbf", *TEST_ARGS[7:]],
     {"d.csv": data(), "t.csv": _test_csv(*META)}, 2, "a re-registered validation session needs a parameter method"),
    # --- calibrate: a drawstring set without # anchor_mm has it pre-fitted (issue 22)
    (CAL, ["irb120", "--data", "d.csv", "--method", "lm", "--no-html"], {"d.csv": csv(*ROWS[:40], meta=(*META[:2], *META[3:]))},
     0, "sensor set-up: anchor "),
    (CAL, ["irb120", "--data", "d.csv", "--method", "lm", "--no-html"], {"d.csv": csv(*ROWS[:4], meta=(*META[:2], *META[3:]))},
     2, "d.csv: anchor_mm: 4 training rows cannot locate the drawstring's anchor"),
    (CAL, ["irb120", "--data", "d.csv", "--method", "lm"], {"d.csv": csv(*ROWS[:40], meta=(*META[:2], *META[4:]))},
     2, "d.csv: tool_mm: no tool point"),
    (PLAN, ["irb120", "--sensor", "laser", "--out", "p.csv"], {}, 2, "--sensor: expected sensor kinds"),
    (PLAN, ["irb120", "--sensor", "cable,position", "--noise-mm", "0.05", "--out", "p.csv"], {}, 2,
     "--noise-mm: 1 values for 2 sensor(s)"),
    (PLAN, ["irb120", "--sensor", "position", "--anchor-mm", "1,2,3", "--out", "p.csv"], {}, 2,
     "--anchor-mm: not an option of positions"),
    # --- every command: a repeated option that is not a list is refused; negative values parse
    (CAL, ["irb120", "--test-data", "a.csv", "--test-data", "b.csv", "--analyze"], {"a.csv": data(), "b.csv": data()},
     2, "--test-data given twice"),
    (CAL, ["irb120", "--test-data=a.csv", "--analyze", "--test-data", "b.csv"], {"a.csv": data(), "b.csv": data()},
     2, "--test-data given twice"),
    # --data repeats: several sets in one fit, each with its own set-up (from its file)
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv", "--anchor-mm", "1,2,3"], {"a.csv": data(), "b.csv": data()},
     2, "--anchor-mm with several --data files: put each set's in its file"),
    (CAL, ["irb120", "--data", "a.csv", "--data", "a.csv", "--analyze"], {"a.csv": data()}, 2,
     "a.csv: given twice (sets a and 2): a row is fitted once"),
    # ... a validation session of several training sets: same=LABEL or register=K (issue 22)
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv", "--test-data", "a.csv"],
     {"a.csv": data(), "b.csv": csv(*ROWS[60:100])},
     2, "argument --test-data: same: 2 training sets of cable data (a, b): name the one whose set-up the session shares"),
    (CAL, [*TWO_SETS, "--test-data", "t.csv:same=c"], TWO_FILES, 2,
     "argument --test-data: same: 'c' is not a training set's label (labels: a, b)"),
    (CAL, [*TWO_SETS, "--test-data", "a.csv:same=a"], TWO_FILES, 2,
     "a.csv: holds training set a's own rows: it is a.csv again (the same file)"),
    (CAL, [*TWO_SETS[:4], "b.csv:role=test", *TWO_SETS[5:], "--test-data", "t.csv:same=a"], TWO_FILES, 2,
     "argument --test-data: a validation session beside set b, whose role is 'test': give the validation session one way"),
    (CAL, [*TWO_SETS, "--test-data", "t.csv:same=a"], {**TWO_FILES, "t.csv": _test_csv(*META[:2], SHIFTED, *META[3:])},
     2, "t.csv: anchor_mm: the validation session has 650, 200, -100 mm, the calibration 600, 200, -100 mm"),
    (CAL, [*TWO_SETS, "--test-data", "t.csv:same=a"], TWO_FILES, 0, "validation session t.csv: the set-up of set a"),
    (CAL, [*TWO_SETS, "--test-data", "t.csv:register=5"], {**TWO_FILES, "t.csv": _test_csv(*META[:2], SHIFTED,
                                                                                            *META[3:])},
     0, "validation session t.csv: a new set-up, 5 rows re-registered it"),
    # ... --fix/--free with several sets: the robot's unknowns are shared, a sensor's carries its set's label
    (CAL, [*TWO_SETS, "--estimate", "anchor", "--fix", "anchor_x", "--analyze"], TWO_FILES, 2,
     "argument --fix: 'anchor_x' is a sensor unknown of several sets: name the set's, a:anchor_x or b:anchor_x"),
    (CAL, [*TWO_SETS, "--fix", "theta_7", "--analyze"], TWO_FILES, 2, "argument --fix: no unknown 'theta_7'"),
    (CAL, [*TWO_SETS, "--estimate", "anchor", "--fix", "theta_1,b:anchor_x", "--analyze"], TWO_FILES, 0, "rank"),
    (CAL, [*TWO_SETS, "--nominal", "none.json"], TWO_FILES, 2, "none.json: no such start file"),
    # ... compare --nominal: measured data only; with --models every model starts from the file
    (CMP, ["irb120", "--simulate", "gauss", "--nominal", "c.json", "--methods", "lm"], {}, 2,
     "--nominal starts from one robot's own calibration: give --data, without --simulate"),
    (CMP, ["irb120", "--data", "a.csv", "--models", "dh,hayati", "--nominal", "c.json"], {"a.csv": data()}, 2,
     "c.json: no such start file"),
    (CMP, ["irb120", "--data", "a.csv", "--data", "b.csv", "--nominal", "none.json", "--methods", "lm", "--out", "o"],
     TWO_FILES, 2, "none.json: no such start file"),
    # ... rbf and lm+rbf learn one set-up's readings: refused with several sets
    (CAL, [*TWO_SETS[:6], "rbf", *TWO_SETS[7:]], TWO_FILES, 2,
     "method 'rbf' learns a correction of one sensor set-up's readings, not the robot"),
    # ... per-set options after the file: FILE:key=value:key=value (a key wins over the file's)
    (CAL, ["irb120", "--data", "a.csv:anchor_mm=600,200,-100:noise_mm=0.05", "--data", "b.csv", "--analyze"],
     {"a.csv": data(), "b.csv": csv(*ROWS[60:100])}, 0, "rank"),
    (CAL, ["irb120", "--data", "a.csv:colour=red", "--data", "b.csv", "--analyze"], {"a.csv": data(), "b.csv": data()},
     2, "--data 'a.csv:colour=red': unknown key 'colour' (valid: anchor_mm, tool_mm, length_offset_mm, noise_deg, "
     "camera_mount, board, intrinsics, noise_px, noise_mm"),
    (CAL, ["irb120", "--data", "a.csv:anchor_mm=600,200", "--data", "b.csv", "--analyze"],
     {"a.csv": data(), "b.csv": data()}, 2, "--data 'a.csv:anchor_mm=600,200': anchor_mm: expected 3 numbers"),
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv:role=validate", "--analyze"],
     {"a.csv": data(), "b.csv": data()}, 2, "--data 'b.csv:role=validate': role: expected one of split, train, test"),
    (CAL, ["irb120", "--data", "a.csv:noise_mm=-1", "--data", "b.csv", "--analyze"],
     {"a.csv": data(), "b.csv": data()}, 2, "--data 'a.csv:noise_mm=-1': noise_mm"),
    (CAL, ["irb120", "--data", "a.csv:anchor_mm", "--data", "b.csv", "--analyze"],
     {"a.csv": data(), "b.csv": data()}, 2, "--data 'a.csv:anchor_mm': 'anchor_mm' is not key=value"),
    (CAL, ["irb120", "--data", "x.csv:role=test", "--data", "b.csv", "--analyze"], {"b.csv": data()},
     2, "--data 'x.csv:role=test': no file 'x.csv'"),
    (CAL, ["irb120", "--data", "w.csv:anchor_mm=1,2,3", "--data", "v.csv", "--analyze"],
     {"w.csv": (ROOT / "robots" / "irb120_wu2015.csv").read_text(),
      "v.csv": (ROOT / "robots" / "irb120_wu2015.csv").read_text()},
     2, "--data 'w.csv:anchor_mm=1,2,3': anchor_mm: is for drawstring data; w.csv holds positions"),
    (CAL, ["irb120", "--data", "a.csv:noise_deg=2", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:noise_deg=2': noise_deg: is for 6-D data; a.csv holds drawstring readings"),
    (CAL, ["irb120", "--data", "a.csv:noise_deg=200", "--data", "b.csv", "--analyze"],
     {"a.csv": pose_set(), "b.csv": pose_set()}, 2,
     "--data 'a.csv:noise_deg=200': noise_deg: expected a number in (0, 180] deg, got '200'"),
    (CAL, ["irb120", "--dat", "a.csv", "--analyze"], {"a.csv": data()}, 2, "--dat"),
    (CAL, ["irb120", "--method", "lm", "--method=ekf", "--analyze"], {}, 2, "--method given twice"),
    (SIM, ["irb120", "--out", "a.csv", "--out", "b.csv"], {}, 2, "--out given twice"),
    (SIM, ["irb120", "--out", "a.csv", "--poses", "10", "--poses", "20"], {}, 2, "--poses given twice"),
    (COMPENSATE, [*CAL_ARGS, "--targets", "q.csv"], {}, 2, "--targets given twice"),
    (MK, ["irb120", "--n", "5", "--n", "6", "--out", "p.csv"], {}, 2, "--n given twice"),
    (PLAN, ["irb120", "--out", "p.csv", "--out", "q.csv"], {}, 2, "--out given twice"),
    (COL, [*COLLECT, "--port", "/dev/null/other"], {"p.csv": POSES}, 2, "--port given twice"),
    (CMP, ["irb120", "--trials", "1", "--trials", "2"], {}, 2, "--trials given twice"),
    (BENCH, ["--repeats", "1", "--repeats", "2"], {}, 2, "--repeats given twice"),
    (FAKE, ["--protocol", "modbus", "--protocol", "ascii"], {}, 2, "--protocol given twice"),
    ("batch", ["a.csv", "--out", "o", "--out", "p"], {"a.csv": data()}, 2, "--out given twice"),
    (ENTRY, ["simulate", "irb120", "--out", "a.csv", "--out=b.csv"], {}, 2, "--out given twice"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "20", "--anchor-mm", "-600,200,-100", "--tool-mm", "-2.2,0,50"],
     {}, 0, "wrote"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "20", "--length-offset-mm", "-1e-1"], {}, 0, "wrote"),
    (CAL, ["irb120", "--analyze", "--tool-mm", "-2.2,0,50", "--anchor-mm", "-600,-200,-100"], {}, 0, "rank"),
    (CAL, ["irb120", "--analyze", "--anchor-mm", "-600 200 -100"], {}, 0, "rank"),
    (CAL, ["irb120", "--analyze", "--length-offset-mm", "-1e-3"], {}, 0, "rank"),
    (CAL, ["irb120", "--analyze", "--anchor-mm", "-6,0"], {}, 2, "--anchor-mm"),
    # ... a name repeated inside a list option: joint_2,joint_2 wrote a calibration file compensate refused
    (CAL, ["irb120", "--method", "lm", "--compliance", "joint_2,joint_2", "--no-html"], {}, 2,
     "--compliance: 'joint_2' is given twice"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "5", "--compliance", "joint_3, joint_3"], {}, 2,
     "--compliance: 'joint_3' is given twice"),
    (CAL, ["irb120", "--analyze", "--estimate", "anchor,anchor"], {}, 2, "--estimate: 'anchor' is given twice"),
    (CAL, ["irb120", "--analyze", "--compliance", " , "], {}, 2, "--compliance: expected joint names"),
    (CAL, ["irb120", "--analyze", "--compliance", "joint_2, joint_3"], {}, 0, "compliance_joint_3"),
    # issue 23: the gravity basis model and compare --models
    (CAL, ["irb120", "--analyze", "--compliance-model", "basis"], {}, 2, "--compliance-model needs compliant joints"),
    (CAL, ["irb120", "--analyze", "--compliance", "joint_2", "--compliance-model", "basis", "--cable-tension-n", "5"],
     {}, 2, "a cable tension needs the CAD compliance model"),
    (CAL, ["irb120", "--analyze", "--compliance", "joint_2", "--compliance-model", "basis"], {}, 0, "basis_joint_2_1"),
    (CMP, ["irb120", "--models", "geometric,stiff", "--trials", "1"], {}, 2, "models: 'stiff' is not a model"),
    (CMP, ["irb120", "--models", "geometric,compliance:joint_9", "--trials", "1"], {}, 2, "no chain joint 'joint_9'"),
    (CMP, ["irb120", "--models", "geometric,compliance:joint_2:fem", "--trials", "1"], {}, 2,
     "the deflection model is one of cad, basis"),
    (CMP, ["irb120", "--models", "geometric,geometric", "--trials", "1"], {}, 2, "a model is named twice"),
    (CMP, ["irb120", "--models", "geometric", "--compliance", "joint_2"], {}, 2, "leave --compliance out"),
    (CMP, ["irb120", "--models", "geometric", "--methods", "ekf"], {}, 2, "leave --methods out"),
    (CAL, ["irb120", "--method", "lm", "--cv", "500", "--no-html"], {}, 2,
     "argument --cv: 500 folds for 96 training poses: give 2 to 96 folds"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "5", "--compliance", "joint_2", "--compliance-model", "basis",
           "--true-compliance-urad-per-nm", "20"], {}, 2, "a simulated compliant arm needs the CAD compliance model"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "5", "--compliance", "joint_2"], {}, 2,
     "give its true compliances, --true-compliance-urad-per-nm"),
    (CAL, ["irb120", "--method", "lm", "--cv", "1", "--no-html"], {}, 2, "--cv: expected a whole number from 2 to 1000"),
]


# ---------------------------------------------------------------------------
# round 3 (issue 20), 2 and 3: compliance >= 0, rank-deficient sets calibrate, figures optional
# ---------------------------------------------------------------------------
from simulated_sets import small_wrist_cable, ur5_grid  # noqa: E402 (seeded rank-deficient sets)

WU = (ROOT / "robots" / "irb120_wu2015.csv").read_text()
R3_COMPLIANCE: list[Case] = [
    # a compliance is >= 0: negative ones are bounded at zero and the fit repeated, the printout names them
    (CAL, ["irb120", "--data", "w.csv", "--method", "lm", "--compliance", "all", "--no-html"], {"w.csv": WU}, 0,
     "bounded at zero: joint_5"),
    # rank deficiency is normal: the identifiable subspace is fitted, one warning line, outputs written
    (CAL, ["irb120", "--data", "c.csv", "--method", "lm", "--estimate", "anchor,offset", "--no-html"],
     {"c.csv": small_wrist_cable()}, 0, "identify only 10 of 28 directions"),
    (CAL, ["ur5", "--data", "u.csv", "--model", "placement", "--method", "lm", "--no-html"],
     {"u.csv": ur5_grid(200)}, 0, "identify only 25 of 51 directions"),
    # ... but a set that cannot calibrate anything is refused: one distinct pose
    (CAL, ["irb120", "--data", "same.csv", "--method", "lm", "--estimate", "anchor,offset"], {"same.csv": IDENTICAL},
     2, "1 distinct pose"),
    # ... before any estimate, by every method (the default ekf-qibas divided by its zero cost; rbf wrote a report)
    (CAL, ["irb120", "--data", "same.csv"], {"same.csv": IDENTICAL}, 2, "1 distinct pose"),
    (CAL, ["irb120", "--data", "same.csv", "--method", "rbf"], {"same.csv": IDENTICAL}, 2, "1 distinct pose"),
    (CAL, ["irb120", "--data", "same.csv", "--method", "lm+rbf"], {"same.csv": IDENTICAL}, 2, "1 distinct pose"),
    # noise 0: a noise-free simulation is fine; a Kalman filter's assumed sigma of 0 is not
    (SIM, ["irb120", "--poses-file", "p.csv", "--seed", "1", "--noise-mm", "0", "--out", "truth.csv"],
     {"p.csv": POSES}, 0, "noise 0 mm"),  # the README's dry run
    (SIM, ["irb120", "--poses-file", "p.csv", "--noise-mm", "-0", "--out", "truth.csv"],
     {"p.csv": POSES}, 0, "noise 0 mm"),  # a negative zero was numpy's 'scale < 0' traceback
    (CAL, ["irb120", "--method", "lm", "--noise-mm", "0"], {}, 2, "Kalman"),
]


# ---------------------------------------------------------------------------
# round 3 (issue 20), 3: real files (extra columns, string labels, ';' and decimal comma)
# ---------------------------------------------------------------------------
WU = (ROOT / "robots" / "irb120_wu2015.csv").read_text().splitlines()
WU_META, WU_HEAD, WU_ROWS = WU[:4], WU[4], WU[5:]
#: The Wu set's point_id labels as a lab might write them.
WU_LABELS = {"1": "SMR1", "2": "T2", "3": "A"}
FAST = ["--method", "lm", "--no-html"]


def european(text: str) -> str:
    """``text`` in the ';'/decimal-comma dialect: rows and numeric metadata (';' between numbers)."""
    lines = []
    for line in text.splitlines():
        key, colon, value = line.partition(":")
        if line.startswith("#") and colon and key.endswith(("_mm", "_m")):
            lines.append(key + ":" + value.replace(",", ";").replace(".", ","))
        elif not line.startswith("#"):
            lines.append(line.replace(",", ";").replace(".", ","))
        else:
            lines.append(line)
    return "\n".join(lines) + "\n"


def with_columns(text: str, names: str = "temp_C,sigma_mm,time") -> str:
    """``text`` with columns ``names`` after the last (a temperature, a standard deviation, a time stamp)."""
    lines = text.splitlines()
    head = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    lines[head] += "," + names
    for k in range(head + 1, len(lines)):
        pool = [f"{20 + 0.1 * (k % 7):.1f}", f"0.01{k % 9}", f"2024-05-01T10:{k % 60:02d}:00", f"T{k % 4}"]
        lines[k] += "," + ",".join(pool[: len(names.split(","))])
    return "\n".join(lines) + "\n"


def wu(rows: range = range(0, 36), labels: dict[str, str] | None = None) -> str:
    """The real Wu position set, poses ``rows`` only, its point_id relabelled by ``labels``."""
    kept = [r for r in WU_ROWS if int(r.split(",", 1)[0]) in rows]
    if labels:
        kept = [swap(r, 1, labels[r.split(",")[1]]) for r in kept]
    return "\n".join([*WU_META, WU_HEAD, *kept]) + "\n"


R3_FILES: list[Case] = [
    # accepted: extra columns are read past and reported
    (CAL, ["irb120", "--data", "d.csv", *FAST], {"d.csv": with_columns(data())}, 0,
     "ignored columns: temp_C, sigma_mm, time"),
    (CAL, ["irb120", "--data", "d.csv", *FAST], {"d.csv": with_columns(data(), "label,comment,x_std_mm,Pose_1")}, 0,
     "ignored columns: label, comment, x_std_mm, Pose_1"),
    (CAL, ["irb120", "--data", "d.csv", *FAST], {"d.csv": csv(*(f"{k},{r}" for k, r in enumerate(ROWS[:40])),
                                                               head="," + HEAD)}, 0, "ignored columns: column 1"),
    # accepted: ';' with decimal commas, ';' with points, a trailing separator, the '# csv:' override
    (CAL, ["irb120", "--data", "d.csv", *FAST], {"d.csv": european(data())}, 0, "40 poses from d.csv"),
    (CAL, ["irb120", "--data", "d.csv", *FAST], {"d.csv": european(with_columns(data()))}, 0,
     "ignored columns: temp_C, sigma_mm, time"),
    (CAL, ["irb120", "--data", "d.csv", *FAST], {"d.csv": csv(*(r.replace(",", ";") for r in ROWS[:40]),
                                                               head=HEAD.replace(",", ";"))}, 0, "40 poses from d.csv"),
    (CAL, ["irb120", "--data", "d.csv", *FAST], {"d.csv": "\n".join(line if line.startswith("#") else line + ";"
                                                                    for line in european(data()).splitlines())}, 0,
     "40 poses from d.csv"),
    (CAL, ["irb120", "--data", "d.csv", *FAST], {"d.csv": "# csv: sep=; decimal=,\n" + european(data())}, 0,
     "40 poses from d.csv"),
    (CAL, ["irb120", "--data", "d.csv", *FAST], {"d.csv": "\n".join(line.replace(",", "\t") if not line.startswith("#")
                                                                    else line for line in data().splitlines())}, 0,
     "40 poses from d.csv"),
    # accepted: string marker labels, in the data and in a validation session
    (CAL, ["irb120", "--data", "w.csv", *FAST], {"w.csv": wu(labels=WU_LABELS)}, 0, "108 rows at 36 poses from w.csv"),
    (CAL, ["irb120", "--data", "w.csv", "--test-data", "v.csv", *FAST],
     {"w.csv": wu(range(0, 26), WU_LABELS), "v.csv": european(with_columns(wu(range(26, 36), WU_LABELS)))}, 0,
     "ignored columns: temp_C, sigma_mm, time (in v.csv"),
    # refused: what looks like one of the known columns but is not one, or is one twice
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], head=HEAD.replace("length_mm", "lenght_mm"))}, 2,
     "did you mean length_mm"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], head=HEAD.replace("length_mm", "length_cm"))}, 2,
     "length_cm"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], head=HEAD.replace("length_mm", "Length"))}, 2,
     "Length"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*(r + ",0" for r in ROWS[:40]), head=HEAD + ",q7_deg")}, 2,
     "q7"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*(r + ",0" for r in ROWS[:40]), head=HEAD + ",q2_degrees")}, 2,
     "q2_degrees"),
    (CAL, ["irb120", "--data", "w.csv"], {"w.csv": wu().replace("pose,point_id,", "pose,pointid,")}, 2,
     "did you mean point_id"),
    (CAL, ["irb120", "--data", "w.csv"], {"w.csv": wu().replace("x_mm,y_mm,z_mm", "X,Y,Z")}, 2, "w.csv:5: X"),
    # refused: mixed marker labels, separators or decimal marks
    (CAL, ["irb120", "--data", "w.csv"], {"w.csv": wu(labels={"1": "1", "2": "T2", "3": "3"})}, 2, "point_id"),
    (CAL, ["irb120", "--data", "w.csv"], {"w.csv": wu(labels={"1": "", "2": "T2", "3": "A"})}, 2, "w.csv:6: point_id"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": european(data()).replace(european(ROWS[5]), ROWS[5] + "\n")}, 2,
     "d.csv:13: has 1 field separated by ';'"),
    (CAL, ["irb120", "--data", "d.csv"],
     {"d.csv": european(data()).replace(european(ROWS[5]), european(ROWS[5]).replace(",", ".", 1))}, 2,
     "d.csv:13: q1_deg: decimal point in"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": csv(*ROWS[:40], head=HEAD.replace("q3_deg,", "q3_deg;"))}, 2,
     "d.csv:7"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": "# csv: sep=, decimal=,\n" + data()}, 2, "d.csv:1: csv"),
    (CAL, ["irb120", "--data", "d.csv"], {"d.csv": "# csv: sep=|\n" + data()}, 2, "d.csv:1: csv"),
    (CAL, ["irb120", "--data", "d.csv", "--analyze"], {"d.csv": csv(*(r + ",T1" for r in ROWS[:30]), head=HEAD + ",point_id")},
     2, "d.csv:7: has both length and a point_id column (the marker labels of a position set)"),  # said x/y/z columns
    # 6-D pose sets (calib_pin/sensors/pose.py): a non-unit quaternion, a missing or foreign column, a bad noise
    (CAL, ["irb120", "--data", "p.csv"], {"p.csv": pose_set(quaternion="0.5,0.5,0.5,0.6")}, 2,
     "p.csv:9: quaternion (qw, qx, qy, qz) has norm 1.05357, not 1 within 0.001"),
    (CAL, ["irb120", "--data", "p.csv"], {"p.csv": pose_set().replace(",qz\n", "\n")}, 2,
     "p.csv:6: missing column qz of a pose set (qw, qx, qy, qz)"),
    (CAL, ["irb120", "--data", "p.csv"], {"p.csv": pose_set().replace(",qz\n", ",qz,length_mm\n")}, 2,
     "has pose columns and length"),
    (CAL, ["irb120", "--data", "p.csv"], {"p.csv": pose_set().replace("# noise_deg: 0.01", "# noise_deg: -1")}, 2,
     "p.csv: noise_deg: '-1' is not a positive angle in degrees"),
    # a set-up flag the set's sensor does not take names the sensors that do; simulate refuses what it would ignore
    (CAL, ["irb120", "--data", "p.csv", "--tool-mm", "0,0,50"], {"p.csv": pose_set()}, 2,
     "--tool-mm is for drawstring and contact data; p.csv holds 6-D poses"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "5", "--noise-deg", "0.02"], {}, 2,
     "--noise-deg is for --kinds pose; this simulates cable"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "5", "--kinds", "pose", "--noise-deg", "0.02"], {}, 0, "wrote"),
    # contact fixtures (calib_pin/sensors/contact.py): a plane of 2 points, a distance to an unknown id, a row with
    # both ids or neither, distances in mixed units
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": contact_set(planes=2)}, 2,
     "c.csv: plane_id: plane_id W is touched at 2 distinct configuration(s) of the training rows: a plane needs 3"),
    (CAL, ["irb120", "--data", "c.csv"], {"c.csv": contact_set("# distance_mm: A, Z, 300")}, 2,
     "c.csv:6: distance_mm: A, Z: Z is no contact_id of this set (contact_ids: A, B, C)"),
    (CAL, ["irb120", "--data", "c.csv"], {"c.csv": contact_set(label="A,W")}, 2,
     "c.csv:8: contact_id: has both contact_id and plane_id: a row touches one fixture"),
    (CAL, ["irb120", "--data", "c.csv"], {"c.csv": contact_set(label=",")}, 2,
     "c.csv:8: contact_id: has neither contact_id nor plane_id"),
    (CAL, ["irb120", "--data", "c.csv"], {"c.csv": contact_set("# distance_m: A, C, 0.3")}, 2,
     "c.csv:6: distance_m: distance_mm on line 3 and distance_m here mix units"),
    (CAL, ["irb120", "--data", "c.csv", "--method", "ukf"], {"c.csv": contact_set()}, 2,
     "method 'ukf' needs rows of one size, and contact fixtures rows differ in size: use ekf, bas, pso, lm"),
    # several contact sets fit together now (each its own fixtures); what cannot: rows of one size, a bad layout
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv", "--no-html"],
     {"a.csv": contact_set(half=slice(0, None, 2)), "b.csv": contact_set(half=slice(1, None, 2))}, 0, "2 sets"),
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv", "--method", "ukf"],
     {"a.csv": contact_set(half=slice(0, None, 2)), "b.csv": contact_set(half=slice(1, None, 2))}, 2,
     "method 'ukf' needs rows of one size, and contact fixtures"),
    (SIM, ["irb120", "--kinds", "contact", "--geometry", "g.json", "--out", "s.csv"], {"g.json": "{"}, 2,
     "g.json: not JSON"),
    (SIM, ["irb120", "--kinds", "contact", "--geometry", "g.json", "--out", "s.csv"],
     {"g.json": '{"points_mm": {"A": [300, 0]}}'}, 2,
     "g.json: not a set-up of contact fixtures: A: expected 3 finite numbers"),
    (SIM, ["irb120", "--kinds", "contact", "--geometry", "g.json", "--out", "s.csv"],
     {"g.json": '{"points_mm": {"A": [300, 0, 300]}, "distances_mm": [["A", "Z"]]}'}, 2,
     "g.json: not a set-up of contact fixtures: distance A, Z: it joins two different points of points_mm"),
    (SIM, ["irb120", "--kinds", "contact", "--geometry", "g.json", "--out", "s.csv"],
     {"g.json": '{"points_mm": {"A": [3000, 0, 300]}}'}, 2, "fixture A at [3000.0, 0.0, 300.0] mm: the arm does not reach"),
    (SIM, ["irb120", "--geometry", "g.json", "--out", "s.csv"], {"g.json": '{"data_kind": "contact", "points_mm": {}}'},
     2, "g.json: data_kind: a set-up for contact: give \"data_kind\" one of cable"),
    (SIM, ["irb120", "--kinds", "contact", "--poses-file", "d.csv", "--out", "s.csv"], {"d.csv": data()}, 2,
     "pose 1: the nominal tool point is on no fixture of the layout"),
    (SIM, ["irb120", "--kinds", "contact", "--poses", "3", "--out", "s.csv"], {}, 2,
     "3 touches for 3 point(s) and 1 plane(s): give --poses 6 or more"),
    (PLAN, ["irb120", "--sensor", "cable,contact", "--out", "p.csv"], {}, 2,
     "is planned alone: no other sensor reads at its poses"),
    (PLAN, ["irb120", "--sensor", "contact", "--geometry", "g.json", "--out", "p.csv"],
     {"g.json": '{"points_mm": {}, "planes": {}}'}, 2, "no points_mm and no planes: nothing to touch"),
]

#: Issue 25: parameters held fixed, a start file, controller programs.
I25_CONTROLLER: list[Case] = [
    (CAL, ["irb120", "--data", "d.csv", "--fix", "theta_9"], {"d.csv": data()}, 2,
     "argument --fix: no unknown 'theta_9' in this calibration (valid: a_1, d_1, alpha_1, theta_1,"),
    (CAL, ["irb120", "--data", "d.csv", "--free", "device_x"], {"d.csv": data()}, 2,
     "argument --free: no unknown 'device_x' in this calibration (valid: a_1,"),
    (CAL, ["irb120", "--data", "d.csv", "--fix", "d_1", "--free", "d_1,a_2"], {"d.csv": data()}, 2,
     "'d_1' is both fixed and free"),
    (CAL, ["irb120", "--data", "d.csv", "--fix", "theta_1,theta_1"], {"d.csv": data()}, 2, "'theta_1' is given twice"),
    (CAL, ["irb120", "--data", "d.csv", "--nominal", "none.json"], {"d.csv": data()}, 2, "none.json: no such start file"),
    (CAL, ["irb120", "--data", "d.csv", "--nominal", "k.yaml"], {"d.csv": data(), "k.yaml": "kinematics: 3\n"}, 2,
     "k.yaml: no 'kinematics:' mapping"),
    (CAL, ["irb120", "--data", "d.csv", "--nominal", "k.yaml"], {"d.csv": data(), "k.yaml": "a: [1\n"}, 2,
     "k.yaml: not YAML"),
    (COMPENSATE, [*CAL_ARGS[:-1], "9p.src", "--format", "krl"], {"c.json": _calibration_file(), "p.csv": POSES},
     2, "must be a KRL name"),
    (COMPENSATE, [*CAL_ARGS[:-1], "p.src", "--format", "rapid"], {"c.json": _calibration_file(), "p.csv": POSES},
     2, "a rapid program is .mod, not '.src'"),
    (COMPENSATE, [*CAL_ARGS, "--speed-rad-s", "1"], {"c.json": _calibration_file(), "p.csv": POSES},
     2, "--speed-rad-s and --accel-rad-s2 are for --format urscript"),
    (COMPENSATE, [*CAL_ARGS, "--format", "urscript", "--speed-rad-s", "0"], {"c.json": _calibration_file(),
                                                                            "p.csv": POSES}, 2, "expected a number in (0, 10]"),
    (COMPENSATE, [*CAL_ARGS, "--nominal", "none.yaml"], {"c.json": _calibration_file(), "p.csv": POSES}, 2,
     "none.yaml: no such start file"),
    (COMPENSATE, [*CAL_ARGS, "--format", "vbs"], {"c.json": _calibration_file(), "p.csv": POSES}, 2, "invalid choice"),
    (COMPENSATE, [*CAL_ARGS[:-1], "p.script", "--format", "urscript"], {"c.json": _calibration_file(), "p.csv": POSES},
     0, "wrote p.script"),
]


def scaled_wu(factor: float) -> str:
    """The real Wu position set with every coordinate times ``factor`` (a unit mistake)."""
    rows = [",".join([*r.split(",")[:2], *(f"{float(v) * factor:.6f}" for v in r.split(",")[2:5]), *r.split(",")[5:]])
            for r in WU_ROWS]
    return "\n".join([*WU_META, WU_HEAD, *rows]) + "\n"


#: Every key a --data argument takes (calibrate's data_keys), each with an out-of-range
#: value: the refusal names the argument and its own key, the value and the valid range or
#: unit, whether the parse, the set-up record or the check of the set-up against the
#: readings refuses it (an anchor 100 m away named 'argument noise' before).
I26_PERSET: list[Case] = [
    (CAL, ["irb120", "--data", "a.csv:anchor_mm=1e4,0,0", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:anchor_mm=1e4,0,0': anchor_mm: the set-up (anchor_mm 10000,0,0 mm (given), tool_mm 0,0,50 mm "
     "(the file's), length_offset_mm 0 mm (the file's)) does not fit the readings"),
    (CAL, ["irb120", "--data", "a.csv:anchor_mm=1e4,0,0", "--no-html", "--out", "out"], {"a.csv": data()}, 2,
     "--data 'a.csv:anchor_mm=1e4,0,0': anchor_mm: the set-up (anchor_mm 10000,0,0 mm"),
    (CAL, ["irb120", "--data", "a.csv:anchor_mm=2e6,0,0", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:anchor_mm=2e6,0,0': anchor_mm: expected 3 numbers 'x,y,z' in mm, each of magnitude below 1000000"),
    (CAL, ["irb120", "--data", "a.csv:tool_mm=1500,0,0", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:tool_mm=1500,0,0': tool_mm: the set-up (anchor_mm 600,200,-100 mm (the file's), tool_mm "
     "1500,0,0 mm (given), length_offset_mm 0 mm (the file's)) does not fit the readings"),
    (CAL, ["irb120", "--data", "a.csv:length_offset_mm=1e5", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:length_offset_mm=1e5': length_offset_mm: 100000 mm (given) does not fit the readings: they "
     "miss the cable lengths at the nominal robot by the same "),
    (CAL, ["irb120", "--data", "a.csv:length_offset_mm=2e6", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:length_offset_mm=2e6': length_offset_mm: expected a number of magnitude below 1000000"),
    (CAL, ["irb120", "--data", "c.csv:tool_mm=1500,0,0", "--analyze"], {"c.csv": contact_set()}, 2,
     "--data 'c.csv:tool_mm=1500,0,0': tool_mm: 1500,0,0 mm (given; the tool point in the end frame) does not fit "
     "the touches"),
    (CAL, ["irb120", "--data", "c.csv:tool_mm=2e6,0,0", "--analyze"], {"c.csv": contact_set()}, 2,
     "--data 'c.csv:tool_mm=2e6,0,0': tool_mm: expected 3 numbers 'x,y,z' in mm, each of magnitude below 1000000"),
    (CAL, ["irb120", "--data", "p.csv:noise_deg=0", "--analyze"], {"p.csv": pose_set()}, 2,
     "--data 'p.csv:noise_deg=0': noise_deg: expected a number in (0, 180] deg, got '0'"),
    (CAL, ["irb120", "--data", "p.csv:noise_deg=200", "--analyze"], {"p.csv": pose_set()}, 2,
     "--data 'p.csv:noise_deg=200': noise_deg: expected a number in (0, 180] deg, got '200'"),
    (CAL, ["irb120", "--data", "a.csv:noise_px=0", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:noise_px=0': noise_px: expected a number in (0, 100] px, got '0'"),
    (CAL, ["irb120", "--data", "a.csv:camera_mount=sideways", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:camera_mount=sideways': camera_mount: expected eye-in-hand or eye-to-hand, got 'sideways'"),
    (CAL, ["irb120", "--data", "a.csv:board=charuco,1x7,30,22", "--analyze"], {"a.csv": data()}, 2,
     "board: expected 'charuco,COLSxROWS,SQUARE_MM,MARKER_MM[,DICT]' or 'chessboard,COLSxROWS,SQUARE_MM', got "
     "'charuco,1x7,30,22': columns 1 is not a whole number of squares in [2, 1000]"),
    (CAL, ["irb120", "--data", "a.csv:intrinsics=1000,1000,640", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:intrinsics=1000,1000,640': intrinsics: expected 'fx,fy,cx,cy,width,height[,k1,k2,p1,p2,k3]'"),
    (CAL, ["irb120", "--data", "a.csv:noise_mm=1e3", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:noise_mm=1e3': noise_mm: expected a number in (0, 100], got '1e3'"),
    (CAL, ["irb120", "--data", "a.csv:role=validate", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:role=validate': role: expected one of split, train, test, got 'validate'"),
    (CAL, ["irb120", "--data", "a.csv:label=", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:label=': label: an empty label"),
    # the same set-up checks for the global flags and the file's own metadata
    (CAL, ["irb120", "--data", "a.csv", "--anchor-mm", "1e4,0,0", "--analyze"], {"a.csv": data()}, 2,
     "a.csv: anchor_mm: the set-up (anchor_mm 10000,0,0 mm (given), tool_mm 0,0,50 mm (the file's)"),
    (CAL, ["irb120", "--data", "a.csv", "--analyze"], {"a.csv": anchor("# anchor_mm: 15000, 200, -100")}, 2,
     "a.csv: the set-up (anchor_mm 15000,200,-100 mm (the file's), tool_mm 0,0,50 mm (the file's), "
     "length_offset_mm 0 mm (the file's)) does not fit the readings"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": contact_set("# tool_mm: 0, 0, 1500")}, 2,
     "c.csv: tool_mm: 0,0,1500 mm (the file's; the tool point in the end frame) does not fit the touches"),
    (CAL, ["irb120", "--data", "a.csv:anchor_mm=650,200,-100", "--analyze"], {"a.csv": data()}, 0, "rank"),
    # the file's offset wrong: the same miss on every row names the offset, not the anchor
    (CAL, ["irb120", "--data", "a.csv", "--analyze"],
     {"a.csv": csv(*ROWS[:40], meta=(*META[:4], "# length_offset_mm: 700", *META[5:]))}, 2,
     "a.csv: length_offset_mm: 700 mm (the file's) does not fit the readings: they miss the cable lengths at the "
     "nominal robot by the same +0.7"),
    # the file's anchor wrong, a right --tool-mm given: every part of the set-up named, with where it came from
    (CAL, ["irb120", "--data", "a.csv", "--tool-mm", "0,0,50", "--analyze"],
     {"a.csv": anchor("# anchor_mm: 6000, 200, -100")}, 2,
     "the set-up (anchor_mm 6000,200,-100 mm (the file's), tool_mm 0,0,50 mm (given), length_offset_mm 0 mm (the "
     "file's)) does not fit the readings"),
    # a set that no robot fits (positions in um read as mm): the data named, not the filter's argument
    (CAL, ["irb120", "--data", "w.csv", "--method", "ekf", "--no-html", "--out", "out"], {"w.csv": scaled_wu(1e3)}, 2,
     "w.csv: a first LM fit leaves"),
    (CAL, ["irb120", "--tool-mm", "2e6,0,0", "--analyze"], {}, 2,
     "--tool-mm: expected 3 numbers 'x,y,z' in mm, each of magnitude below 1000000"),
    (CAL, ["irb120", "--length-offset-mm", "2e6", "--analyze"], {}, 2,
     "--length-offset-mm: expected a number of magnitude below 1000000"),
]


#: A URDF whose file stem (gen3lite) is not its <robot name> (kinova).
KINOVA = urdf('name="abb_irb120"', 'name="kinova"')

#: A session file's stem as a lab names it: four of them joined are over 255 bytes.
LONG_STEM = "kinova_gen3lite_ball_in_socket_session_recorded_2024_03_01_station_b"

#: Issue 34, part A: broken promises of the round on several sets, new sensors and real
#: lab files, one block of rows per class (docs/bad_input.md, "Classes and decisions").
I34_CLASSES: list[Case] = [
    # another robot's file is named by its robot line, not by its joints or limits
    (CAL, ["irb120", "--data", "d.csv", "--analyze"],
     {"d.csv": csv(swap(ROWS[0], 0, "200"), *ROWS[1:40], meta=("# robot: ur5", *META[1:]))}, 2,
     "d.csv: robot: is for robot 'ur5', not 'irb120'"),
    (CAL, ["irb120", "--data", "d.csv", "--analyze"],
     {"d.csv": csv(*(",".join([*r.split(",")[:6], "0", r.split(",")[6]]) for r in ROWS[:40]),
                   meta=("# robot: panda", *META[1:]), head=HEAD.replace("q6_deg", "q6_deg,q7_deg"))}, 2,
     "d.csv: robot: is for robot 'panda', not 'irb120'"),
    # a URDF robot is named by its file stem or by its <robot name>
    (CAL, ["gen3lite.urdf", "--data", "d.csv", "--analyze"],
     {"gen3lite.urdf": KINOVA, "d.csv": csv(*ROWS[:40], meta=("# robot: kinova", *META[1:]))}, 0,
     "gen3lite: 40 poses from d.csv"),
    (CAL, ["gen3lite.urdf", "--data", "d.csv", "--analyze"],
     {"gen3lite.urdf": KINOVA, "d.csv": csv(*ROWS[:40], meta=("# robot: kinova2", *META[1:]))}, 2,
     "d.csv: robot: is for robot 'kinova2', not 'gen3lite' (nor 'kinova', its URDF's <robot name>)"),
    # a metadata key that looks like one calib-pin reads is refused as a column is; free text stays a note
    (CAL, ["irb120", "--data", "d.csv", "--analyze"], {"d.csv": anchor("# anchor_mn: 600, 200, -100")}, 2,
     "d.csv:3: anchor_mn: unknown metadata key; did you mean anchor_mm?"),
    (CAL, ["irb120", "--data", "d.csv", "--analyze"], {"d.csv": anchor("# Anchor_mm: 600, 200, -100")}, 2,
     "d.csv:3: Anchor_mm: unknown metadata key; did you mean anchor_mm? (keys are case-sensitive"),
    (CAL, ["irb120", "--data", "d.csv", "--analyze"], {"d.csv": anchor("# anchor_cm: 60, 20, -10")}, 2,
     "d.csv:3: anchor_cm: unknown metadata key; did you mean anchor_mm? (unit 'cm' is not read"),
    (CAL, ["irb120", "--data", "d.csv", "--analyze"], {"d.csv": csv(*ROWS[:40], meta=(*META, "# tool: Schunk EGP 40"))},
     0, "40 poses from d.csv"),
    # a list option that names nothing is refused, not read as "none" or "every one"
    (CAL, ["irb120", "--data", "d.csv", "--free", "", "--analyze"], {"d.csv": data()}, 2,
     "argument --free: '' names nothing: give comma-separated names, or leave the option out"),
    (CAL, ["irb120", "--data", "d.csv", "--free", ",,", "--analyze"], {"d.csv": data()}, 2,
     "argument --free: ',,' names nothing"),
    (CAL, ["irb120", "--data", "d.csv", "--fix", " , ", "--analyze"], {"d.csv": data()}, 2,
     "argument --fix: ' , ' names nothing"),
    (CMP, ["irb120", "--data", "d.csv", "--free", "", "--methods", "lm", "--trials", "1"], {"d.csv": data()}, 2,
     "argument --free: '' names nothing"),
    (CMP, ["irb120", "--data", "d.csv", "--models", "", "--trials", "1"], {"d.csv": data()}, 2,
     "argument models: give comma-separated models"),
    # a per-set option and the global flag for the same set: refused naming both
    (CAL, ["irb120", "--data", "d.csv:anchor_mm=600,200,-100", "--anchor-mm", "650,200,-100", "--analyze"],
     {"d.csv": data()}, 2, "--data 'd.csv:anchor_mm=600,200,-100' and --anchor-mm both give anchor_mm of d.csv: give one"),
    (CAL, ["irb120", "--data", "p.csv:noise_deg=0.01", "--noise-deg", "0.02", "--analyze"], {"p.csv": pose_set()}, 2,
     "--data 'p.csv:noise_deg=0.01' and --noise-deg both give noise_deg of p.csv: give one"),
    (CAL, ["irb120", "--data", "d.csv:noise_mm=0.05", "--data", "p.csv", "--noise-mm", "0.1", "--analyze"],
     {"d.csv": data(), "p.csv": pose_set()}, 2, "--data 'd.csv:noise_mm=0.05' and --noise-mm both give noise_mm of d.csv"),
    # one length a pair of contact points: the pair again with another length (either order) refused
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": contact_set("# distance_mm: B, A, 300")}, 2,
     "c.csv:6: distance_mm: B, A: 300 mm here, 391.535 mm on line 3 (A, B): one length a pair"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": contact_set("# distance_mm: A, B, 391.0")}, 2,
     "c.csv:6: distance_mm: A, B: 391 mm here, 391.535 mm on line 3 (A, B): one length a pair"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": contact_set("# distance_mm: B, A, 391.535439")}, 0,
     "1 known distance(s)"),
    (SIM, ["irb120", "--kinds", "contact", "--geometry", "g.json", "--out", "s.csv"],
     {"g.json": '{"data_kind": "contact", "points_mm": {"A": [380, 120, 250], "B": [300, -250, 150]}, '
                '"distances_mm": [["A", "B", 400], ["B", "A", 410]]}'}, 2,
     "g.json: not a set-up of contact fixtures: distance B, A: 410 mm, and 400 mm as A, B: one length a pair"),
    # an end frame that is the last joint's own link: refused where it enters, before the fit
    (CAL, ["irb120", "--data", "d.csv", "--method", "lm", "--no-html", "--out", "o"],
     {"d.csv": csv(*ROWS[:40], meta=(META[0], "# end_frame: link_6", *META[2:]))}, 2,
     "end frame 'link_6' is the link of joint 'joint_6': a calibration moves the end frame"),
    (CAL, ["irb120", "--data", "d.csv", "--end-frame", "link_6", "--export", "yaml", "--method", "lm", "--no-html",
           "--out", "o"], {"d.csv": csv(*ROWS[:40], meta=(META[0], *META[2:]))}, 2,
     "end frame 'link_6' is the link of joint 'joint_6'"),
    # a tool point or anchor beyond reach (a unit mistake) is refused where it enters, with the bound
    (SIM, ["irb120", "--tool-mm", "0,0,-5000", "--out", "s.csv"], {}, 2,
     "--tool-mm: 0,0,-5000 mm is 5000 mm from the end frame, beyond the 2000 mm a point may be (a unit mistake?)"),
    (SIM, ["irb120", "--anchor-mm", "90000,0,0", "--out", "s.csv"], {}, 2,
     "--anchor-mm: 90000,0,0 mm is 90000 mm from the base, beyond the 20000 mm a point may be"),
    (SIM, ["irb120", "--kinds", "contact", "--tool-mm", "0,0,-5000", "--out", "s.csv"], {}, 2,
     "--tool-mm: 0,0,-5000 mm is 5000 mm from the end frame"),
    (SIM, ["irb120", "--compliance", "joint_2", "--true-compliance-urad-per-nm", "20", "--payload-kg", "1",
           "--payload-com-mm", "0,0,5000", "--out", "s.csv"], {}, 2, "--payload-com-mm: 0,0,5000 mm is 5000 mm"),
    (PLAN, ["irb120", "--tool-mm", "0,0,-5000", "--out", "p.csv"], {}, 2, "--tool-mm: 0,0,-5000 mm is 5000 mm"),
    (COL, [*COLLECT, "--anchor-mm", "1e5,0,0"], {"p.csv": POSES}, 2, "--anchor-mm: 100000,0,0 mm is 100000 mm"),
    (CAL, ["irb120", "--data", "a.csv:anchor_mm=1e5,0,0", "--analyze"], {"a.csv": data()}, 2,
     "--data 'a.csv:anchor_mm=1e5,0,0': anchor_mm: 100000,0,0 mm is 100000 mm from the base, beyond the 20000 mm"),
    (CAL, ["irb120", "--data", "c.csv:tool_mm=1e5,0,0", "--analyze"], {"c.csv": contact_set()}, 2,
     "--data 'c.csv:tool_mm=1e5,0,0': tool_mm: 100000,0,0 mm is 100000 mm from the end frame, beyond the 2000 mm"),
    (CAL, ["irb120", "--data", "a.csv", "--analyze"], {"a.csv": anchor("# anchor_mm: 600000, 200, -100")}, 2,
     "a.csv: anchor_mm: 600000,200,-100 mm is 600000 mm from the base, beyond the 20000 mm a point may be"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": contact_set("# tool_mm: 0, 0, 50000")}, 2,
     "c.csv: tool_mm: 0,0,50000 mm is 50000 mm from the end frame, beyond the 2000 mm a point may be"),
    (SIM, ["irb120", "--kinds", "contact", "--geometry", "g.json", "--out", "s.csv"],
     {"g.json": '{"data_kind": "contact", "points_mm": {"A": [380, 120, 250]}, "tool_mm": [0, 0, 5000]}'}, 2,
     "g.json: not a set-up of contact fixtures: tool_mm: 0,0,5000 mm is 5000 mm from the end frame"),
    # --nominal takes a calibrate output folder as compensate --calibration does, or says what to give
    (CAL, ["irb120", "--data", "d.csv", "--nominal", "o", "--method", "lm", "--no-html", "--out", "o2"],
     {"d.csv": data(), "o/irb120_calibration.json": _calibration_file()}, 0, "start: irb120_calibration.json"),
    (CAL, ["irb120", "--data", "d.csv", "--nominal", "o", "--analyze"], {"d.csv": data(), "o/x.txt": ""}, 2,
     "o: no *_calibration.json in this folder (--nominal: a calibrate output folder, a calib-pin calibration .json"),
    (CMP, ["irb120", "--data", "d.csv", "--nominal", "o", "--methods", "lm", "--trials", "1", "--out", "c"],
     {"d.csv": data(), "o/irb120_calibration.json": _calibration_file()}, 0, "wrote c/table1.csv"),
    # batch: set folder names safe and unique; a file name holding '+' joins
    ("batch", ["...csv", "--out", "o/p", "--method", "lm"], {"...csv": data()}, 0, "set-"),
    ("batch", ["a+b.csv+c.csv", "--out", "o", "--method", "lm"], {"a+b.csv": data(), "c.csv": csv(*ROWS[60:100])},
     0, "a+b+c  ok"),
    ("batch", ["+".join(f"{LONG_STEM}_{k}.csv" for k in range(4)), "--out", "o", "--method", "lm"],
     {f"{LONG_STEM}_{k}.csv": csv(*ROWS[30 * k:30 * k + 30]) for k in range(4)}, 0, f"{LONG_STEM}_0+3-more-"),
    # a row beyond the URDF's joint limits (a controller that allows more): refused pointing at the margin,
    # accepted with --limit-margin-deg, the rows named
    (CAL, ["irb120", "--data", "d.csv", "--analyze"], {"d.csv": csv(swap(ROWS[0], 0, "165.4"), *ROWS[1:40])}, 2,
     "d.csv:8: q1_deg: 165.4 is outside the limits of joint_1 [-165, 165] deg (the URDF's; a controller that allows "
     "more: calibrate --limit-margin-deg)"),
    (CAL, ["irb120", "--data", "d.csv", "--analyze", "--limit-margin-deg", "1"],
     {"d.csv": csv(swap(ROWS[0], 0, "165.4"), *ROWS[1:40])}, 0,
     "note: 1 row(s) of d.csv beyond the URDF's joint limits, accepted by --limit-margin-deg 1: line 8: joint_1 165.4"),
    (CAL, ["irb120", "--data", "d.csv", "--analyze", "--limit-margin-deg", "0.2"],
     {"d.csv": csv(swap(ROWS[0], 0, "165.4"), *ROWS[1:40])}, 2, "[-165.2, 165.2] deg (the URDF's, widened by 0.2 deg)"),
    (CAL, ["irb120", "--analyze", "--limit-margin-deg", "45"], {}, 2,
     "argument --limit-margin-deg: expected a number of degrees in [0, 30], got '45'"),
    # every numeric metadata value in the file's dialect: a 6-D set with decimal commas
    (CAL, ["irb120", "--data", "p.csv", "--analyze"],
     {"p.csv": european(pose_set()).replace("# noise_deg: 0.01", "# noise_deg: 0,01")}, 0, "(noise 0.05 mm, 0.01 deg)"),
    (CAL, ["irb120", "--data", "p.csv", "--analyze"],
     {"p.csv": european(pose_set()).replace("# noise_deg: 0.01", "# noise_deg: 0.01")}, 2,
     "p.csv:4: noise_deg: decimal point in '0.01', but line 3 has a decimal comma"),
]


def test_every_data_key_has_an_out_of_range_row():
    from calib_pin.cli.calibrate import data_keys

    typed = {item.split("=")[0] for _, argv, *_ in I26_PERSET for arg in argv if ":" in arg and "=" in arg
             for item in arg.split(":")[1:]}
    assert typed == set(data_keys())


def _again(rows: list[str], mm: float = 0.004) -> list[str]:
    """``rows`` read again at the same poses: each drawstring reading ``mm`` longer."""
    return [f"{r.rsplit(',', 1)[0]},{float(r.rsplit(',', 1)[1]) + mm:.6f}" for r in rows]


def _swapped(text: str) -> str:
    """A contact session whose sockets A and B were swapped (the fixtures moved)."""
    return text.replace(",A,", ",X,").replace(",B,", ",A,").replace(",X,", ",B,")


POSE_OTHER = "\n".join([*POSE_SHIPPED[: POSE_HEAD + 1], *POSE_ROWS[40:]]) + "\n"
CONTACT_EVEN, CONTACT_ODD = contact_set(half=slice(0, None, 2)), contact_set(half=slice(1, None, 2))
COMPENSATED = ("# robot: irb120\n# compensated: c.json (calib-pin 0.3.0), targets p.csv\n"
               "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,status,position_error_mm,orientation_error_urad\n"
               "1,0.1,0.2,0.3,0.1,30.5,0.2,ok,0.000001,0.0005\n2,10,10,10,10,10,10,ok,0,0\n")
B_MOVED = csv(*ROWS[60:100], meta=(*META[:2], META[2].replace("-100.000000", "-200.000000"), *META[3:]))

#: Issue 34 (part B): one measurement fitted twice, variance components of a thin set,
#: tracebacks, compensate's own output, program names that collide, a moved contact
#: plate, registration rows, counts against the identifiable directions, which set
#: misfits, what rows are called.
I34B: list[Case] = [
    # one measurement in two sets, or in a set and the validation session
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv", "--analyze"], {"a.csv": data(), "b.csv": data()}, 2,
     "b.csv: it is a.csv again (a file of identical contents): a row is fitted once"),
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv", "--analyze"], {"a.csv": data(), "b.csv": csv(*ROWS[30:70])},
     2, "b.csv: its lines 8-17 repeat a.csv's lines 38-47 (the same joint angles and readings, to the files' precision)"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": csv(*ROWS[30:60])}, 2,
     "t.csv: holds the training set's own rows: its lines 8-17 repeat d.csv's lines 38-47"),
    (CAL, TEST_ARGS, {"d.csv": data(), "t.csv": data()}, 2,
     "t.csv: holds the training set's own rows: it is d.csv again (a file of identical contents)"),
    (CAL, ["irb120", "--data", "d.csv", "--analyze"], {"d.csv": csv(*ROWS[:40], *ROWS[:5])}, 0, "rank"),
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv", "--analyze"],
     {"a.csv": data(), "b.csv": csv(*_again(ROWS[:40]))}, 0, "rank"),
    # a set too small to estimate its own noise beside a good one; one row of 6-D: counted first
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv", "--method", "lm", "--no-html", "--out", "out"],
     {"a.csv": data(), "b.csv": csv(*_again(ROWS[50:51]))}, 0,
     "noise of set b: its training values leave fewer than 2 degrees of freedom"),
    (CAL, ["irb120", "--data", "p.csv", "--analyze"], {"p.csv": pose_set().rsplit("\n", 40)[0] + "\n"}, 2,
     "p.csv: 1 training rows give 6 values, fewer than the 12 set-up unknowns (the device frame and the body)"),
    (CAL, ["irb120", "--data", "p.csv", "--test-data", "t.csv:register=1", "--method", "lm", "--no-html", "--out",
           "out"], {"p.csv": pose_set(), "t.csv": POSE_OTHER}, 2,
     "t.csv: 1 registration rows give 6 values, fewer than the 12 set-up unknowns"),
    # --fix/--free on a contact set, alone or beside another, and --analyze --fix
    (CAL, ["irb120", "--data", "c.csv", "--fix", "theta_1", "--analyze"], {"c.csv": contact_set()}, 0,
     "held at their start (--fix/--free), left out: theta_1"),
    (CAL, ["irb120", "--data", "c.csv", "--fix", "theta_1", "--method", "lm", "--no-html", "--out", "out"],
     {"c.csv": contact_set()}, 0, "fixed (held at their nominal value, --fix/--free): theta_1"),
    (CAL, ["irb120", "--data", "c.csv", "--data", "d.csv", "--free", "theta_2,d_2", "--method", "lm", "--no-html",
           "--out", "out"], {"c.csv": contact_set(), "d.csv": data()}, 0, "2 sets"),
    # compensate's own output as targets
    (COMPENSATE, CAL_ARGS, {"c.json": _calibration_file(), "p.csv": COMPENSATED}, 2,
     "p.csv:2: compensated: 'c.json (calib-pin 0.3.0), targets p.csv': these targets are compensate's own output"),
    # a program named like what it defines or calls
    (COMPENSATE, [*CAL_ARGS[:-1], "movej.script", "--format", "urscript"], {"c.json": _calibration_file(),
                                                                          "p.csv": POSES}, 2,
     "--out movej.script: a URScript function named 'movej' collides with the built-in function it calls, 'movej'"),
    (COMPENSATE, [*CAL_ARGS[:-1], "jt_1.mod", "--format", "rapid"], {"c.json": _calibration_file(), "p.csv": POSES},
     2, "a RAPID module named 'jt_1' collides with a joint target it defines, 'jt_1'"),
    (COMPENSATE, [*CAL_ARGS[:-1], "Tool0.mod", "--format", "rapid"], {"c.json": _calibration_file(), "p.csv": POSES},
     2, "a RAPID module named 'Tool0' collides with the predefined tool it moves, 'tool0'"),
    (COMPENSATE, [*CAL_ARGS[:-1], "XP2.src", "--format", "krl"], {"c.json": _calibration_file(), "p.csv": POSES},
     2, "a KRL program named 'XP2' collides with a point it declares, 'XP2'"),
    # a contact session from moved fixtures; registration rows of a file recorded fixture by fixture
    (CAL, ["irb120", "--data", "a.csv", "--test-data", "b.csv", "--method", "lm", "--no-html", "--out", "out"],
     {"a.csv": CONTACT_EVEN, "b.csv": _swapped(CONTACT_ODD)}, 2,
     "b.csv: fixtures: the session's own are "),
    (CAL, ["irb120", "--data", "a.csv", "--test-data", "b.csv:register=12", "--method", "lm", "--no-html", "--out",
           "out"], {"a.csv": CONTACT_EVEN, "b.csv": _swapped(CONTACT_ODD)}, 0,
     "12 poses, one of each fixture or point in turn"),
    (CAL, ["irb120", "--data", "a.csv", "--test-data", "b.csv:register=2", "--method", "lm", "--no-html", "--out",
           "out"], {"a.csv": CONTACT_EVEN, "b.csv": CONTACT_ODD}, 2,
     "of the registration rows: nothing locates it (register=2 took 2 poses, one of each fixture or point in turn"),
    # too few values: counted against the directions the rows identify (or the free unknowns)
    (CAL, ["irb120", "--data", "d.csv", "--test-fraction", "0", "--method", "lm", "--no-html", "--out", "out"],
     {"d.csv": csv(*ROWS[:23])}, 0, "of 24 determined by the data"),
    (CAL, ["irb120", "--data", "d.csv", "--test-fraction", "0", "--free", "theta_2,theta_3", "--method", "lm",
           "--no-html", "--out", "out"], {"d.csv": csv(*ROWS[:10])}, 0, "fixed (held at their nominal value"),
    (CAL, ["irb120", "--data", "d.csv", "--test-fraction", "0", "--method", "lm", "--no-html", "--out", "out"],
     {"d.csv": csv(*ROWS[:19])}, 2,
     "d.csv: 19 training rows give 19 values, no more than the 19 directions they identify (of the 24 unknowns)"),
    # which set misfits; what a cross-validation fold's and a registration's rows are called
    (CAL, ["irb120", "--data", "a.csv", "--data", "b.csv", "--method", "lm", "--no-html", "--out", "out"],
     {"a.csv": data(), "b.csv": B_MOVED}, 2, "set b misfits most: the start misses its training rows by 71.3 mm RMS"),
    (CAL, ["irb120", "--data", "d.csv", "--cv", "3", "--test-fraction", "0", "--method", "lm", "--no-html", "--out",
           "out"], {"d.csv": csv(*ROWS[:29])}, 2,
     "19 fitting rows of cross-validation fold 1 of 3 (the other folds') give 19 values"),
    (CAL, [*TEST_ARGS[:4], "t.csv:register=3", *TEST_ARGS[5:]],
     {"d.csv": data(), "t.csv": csv(*ROWS[40:60], meta=(*META[:2], *META[3:]))}, 2,
     "t.csv: anchor_mm: 3 registration rows cannot locate the drawstring's anchor"),
]


def _each_field(text: str, columns: tuple[str, ...], change) -> str:
    """A measurement file's text with each field of ``columns`` replaced by ``change(value)``
    (``change`` of the row's fields, for a reordering, when ``columns`` is empty)."""
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    head = lines[k].split(",")
    rows = []
    for line in lines[k + 1 :]:
        fields = line.split(",")
        for c, name in enumerate(head):
            if name in columns:
                fields[c] = change(float(fields[c]))
        rows.append(",".join(fields if columns else change(fields)))
    return "\n".join([*lines[: k + 1], *rows]) + "\n"


JOINTS_DEG = tuple(f"q{j}_deg" for j in range(1, 7))


def radians(text: str) -> str:
    """A measurement file's text with its joint angles in radians under the ``_deg`` columns."""
    return _each_field(text, JOINTS_DEG, lambda v: f"{math.radians(v):.9f}")


def _ur10_files() -> dict[str, str]:
    """A ur10 drawstring set (u.csv) and its catalogue's default_kinematics.yaml in degrees
    (deg.yaml) and a ur5's (ur5.yaml)."""
    import tempfile

    import pinocchio as pin

    import calib_pin as cp
    from calib_pin.export.yaml import write_ur_kinematics_yaml

    chain = cp.load_chain("ur10")
    params = cp.parameter_model(chain)
    data, _ = cp.simulate(chain, params, 40, seed=34)
    with tempfile.TemporaryDirectory() as folder:
        cp.write_measurements(Path(folder) / "u.csv", data)
        write_ur_kinematics_yaml(chain, [pin.SE3.Identity()] * 7, Path(folder) / "ur10.yaml")
        write_ur_kinematics_yaml(cp.load_chain("ur5"), [pin.SE3.Identity()] * 7, Path(folder) / "ur5.yaml")
        texts = {name: (Path(folder) / name).read_text() for name in ("u.csv", "ur10.yaml", "ur5.yaml")}
    texts["deg.yaml"] = re.sub(r"(roll|pitch|yaw): (\S+)", lambda m: f"{m.group(1)}: {math.degrees(float(m.group(2))):.9f}",
                               texts.pop("ur10.yaml"))
    return texts


UR10 = _ur10_files()
NO_ANCHOR = csv(*ROWS[:40], meta=(*META[:2], *META[3:]))
LM = ["--method", "lm", "--no-html", "--out", "out"]
SHIFTED = _each_field(pose_set(), ("q2_deg",), lambda v: f"{v + 10:.9f}")  # joint 2 read 10 deg off: no usual mistake

#: Issue 34: unit and order mistakes named before the fit (the pre-fit misfit check), a
#: correct set never refused, and the sanity-bound refusal's hint naming only what the sets take.
I34C: list[Case] = [
    (CAL, ["irb120", "--data", "d.csv", *LM], {"d.csv": radians(data())}, 2,
     "d.csv: q1_deg..q6_deg: radians in degree columns? every angle (-6.717 to 6.753) is within the joints' limits in "
     "radians; the nominal robot misses the rows by "),
    (CAL, ["irb120", "--data", "p.csv", *LM], {"p.csv": radians(pose_set())}, 2,
     "p.csv: q1_deg..q6_deg: radians in degree columns?"),
    (CAL, ["irb120", "--data", "c.csv", *LM], {"c.csv": radians(contact_set())}, 2,
     "c.csv: q1_deg..q6_deg: radians in degree columns?"),
    (CAL, ["irb120", "--data", "d.csv", "--anchor-mm", "0.6,0.2,-0.1", *LM], {"d.csv": NO_ANCHOR}, 2,
     "d.csv: anchor_mm: metres, not mm? 0.6,0.2,-0.1 mm (given); the nominal robot misses the rows by "),
    (CAL, ["irb120", "--data", "d.csv", *LM], {"d.csv": anchor("# anchor_mm: 0.6, 0.2, -0.1")}, 2,
     "d.csv:3: anchor_mm: metres, not mm? 0.6,0.2,-0.1 mm (the file's)"),
    (CAL, ["irb120", "--data", "p.csv", *LM], {"p.csv": _each_field(pose_set(), (), lambda f: f[:-4] + f[-3:] + f[-4:-3])},
     2, "p.csv: qw, qx, qy, qz: x, y, z, w order? read in w, x, y, z order; the nominal robot misses the rows by position"),
    (CAL, ["irb120", "--data", "p.csv", *LM], {"p.csv": _each_field(pose_set(), ("x_mm", "y_mm", "z_mm"),
                                                                    lambda v: f"{v * 1e-3:.9f}")}, 2,
     "p.csv: x_mm, y_mm, z_mm: metres in mm columns? every value"),
    (CAL, ["irb120", "--data", "c.csv", *LM], {"c.csv": contact_set().replace("391.535439", "0.391535")}, 2,
     "c.csv:3: distance_mm: metres, not mm? A, B, 0.391535 mm; the fixtures the nominal robot locates are "),
    (CAL, ["irb120", "--data", "c.csv", *LM], {"c.csv": contact_set().replace("391.535439", "39.1535")}, 2,
     "c.csv:3: distance_mm: cm, not mm? A, B, 39.1535 mm"),
    (CAL, ["ur10", "--data", "u.csv", "--nominal", "deg.yaml", *LM], UR10, 2,
     "deg.yaml: roll, pitch, yaw: degrees, not radians? its angles reach 90; the start misses the rows by "),
    (CAL, ["ur10", "--data", "u.csv", "--nominal", "ur5.yaml", *LM], UR10, 2,
     "ur5.yaml: kinematics: a ur5's file, not a ur10's? its joint origins are within 0.0 mm and 0.00 deg of a ur5's"),
    # correct sets stay accepted: the shipped ones (a real IRB120's markers among them)
    *[(CAL, ["irb120", "--data", name, "--analyze"], {name: (ROOT / "robots" / name).read_text()}, 0, "determined")
      for name in ("irb120_wu2015.csv", "irb120_pose_example.csv", "irb120_contact_example.csv")],
    # a fit beyond the sanity bound blames only the set-up its sets take
    (CAL, ["irb120", "--data", "p.csv", *LM], {"p.csv": SHIFTED}, 2,
     "the data cannot support it (a parameter the poses barely see, see --analyze; a unit or order mistake in the "
     "data; or outliers"),
]


CAMERA_SHIPPED = (ROOT / "robots" / "irb120_camera_example.csv").read_text().splitlines()
CAMERA_HEAD = next(k for k, line in enumerate(CAMERA_SHIPPED) if not line.startswith("#"))


def camera_set(row: int | None = None, column: int = 0, value: str = "", drop: str = "", thin: bool = False) -> str:
    """The shipped camera example; field ``column`` of data row ``row`` (0-based; file line CAMERA_HEAD + row + 2)
    set to ``value``; metadata lines starting with ``drop`` left out; ``thin``: pose 1 keeps only 3 corners."""
    meta = [line for line in CAMERA_SHIPPED[:CAMERA_HEAD] if not (drop and line.startswith(drop))]
    rows = CAMERA_SHIPPED[CAMERA_HEAD + 1 :]
    if row is not None:
        rows[row] = swap(rows[row], column, value)
    if thin:
        first = rows[0].split(",")[0]
        mine = [r for r in rows if r.split(",")[0] == first]
        rows = mine[:3] + [r for r in rows if r.split(",")[0] != first]
    return "\n".join([*meta, CAMERA_SHIPPED[CAMERA_HEAD], *rows]) + "\n"


def turned_pose() -> str:
    """The shipped camera example, pose 3's joints turned 30 deg at joint 1: its corners belong to another pose."""
    rows = CAMERA_SHIPPED[CAMERA_HEAD + 1 :]
    third = sorted({r.split(",")[0] for r in rows}, key=int)[2]
    rows = [swap(r, 2, f"{float(r.split(',')[2]) + 30:.6f}") if r.split(",")[0] == third else r for r in rows]
    return "\n".join([*CAMERA_SHIPPED[: CAMERA_HEAD + 1], *rows]) + "\n"


#: Camera sets (calib_pin/sensors/camera.py): a corner not on the board, a pixel outside the image, a pose of too
#: few corners, no intrinsics, a noise in mm.
I35_CAMERA: list[Case] = [
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": camera_set(3, 1, "99")}, 2,
     f"c.csv:{CAMERA_HEAD + 5}: corner_id: 99 is not a corner of the board (charuco 9x7 squares of 30 mm"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": camera_set(3, 8, "1500.5")}, 2,
     f"c.csv:{CAMERA_HEAD + 5}: u_px: (1500.5, "),
    (CAL, ["irb120", "--data", "c.csv", "--method", "lm", "--no-html", "--out", "out"], {"c.csv": camera_set(thin=True)},
     0, "1 pose(s) dropped, fewer than 4 corners (pose (corners)): 1 (3)"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": camera_set(drop="# camera_f")}, 2,
     "c.csv: camera_fx_px: intrinsics need # camera_fx_px"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze"], {"c.csv": camera_set(drop="# camera_")}, 2,
     "c.csv: intrinsics: no camera intrinsics: add '# camera_fx_px'"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze", "--intrinsics", "1000,1000,640,512,1280"], {"c.csv": camera_set()},
     2, "argument --intrinsics: expected 'fx,fy,cx,cy,width,height[,k1,k2,p1,p2,k3]'"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze", "--noise-mm", "0.1"], {"c.csv": camera_set()}, 2,
     "argument --noise-mm: a camera set's noise is in pixels"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze", "--board", "charuco,9x7,30"], {"c.csv": camera_set()}, 2,
     "argument --board: expected 'charuco,COLSxROWS,SQUARE_MM,MARKER_MM[,DICT]'"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "5", "--camera-mount", "eye-to-hand"], {}, 2,
     "--camera-mount is for --kinds camera; this simulates cable"),
]


#: A ROS camera_info file of the shipped camera example's lens (calib_pin/sensors/lens_file.py).
LENS_ROS = ("image_width: 1280\nimage_height: 1024\ncamera_name: cam\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
            "  data: [1000, 0, 642, 0, 1000, 509, 0, 0, 1]\ndistortion_model: plumb_bob\n"
            "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [-0.08, 0.05, 0.0005, -0.0003, 0]\n")
#: The same lens as OpenCV's camera file (what cv2.FileStorage writes).
LENS_CV = ("%YAML:1.0\n---\nimage_width: 1280\nimage_height: 1024\ncamera_matrix: !!opencv-matrix\n   rows: 3\n"
           "   cols: 3\n   dt: d\n   data: [ 1000., 0., 642., 0., 1000., 509., 0., 0., 1. ]\n"
           "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
           "   data: [ -0.08, 0.05, 0.0005, -0.0003, 0. ]\n")

#: A camera's lens file (--intrinsics FILE.yaml), its exports and plan-poses --sensor camera: a missing key, a
#: matrix of the wrong shape, another distortion model, not YAML, a skewed camera; a focus range that is none.
I35_CAMERA_FILES: list[Case] = [
    (CAL, ["irb120", "--data", "c.csv", "--analyze", "--intrinsics", "k.yaml"], {"c.csv": camera_set(),
     "k.yaml": LENS_CV}, 0, "analysed at zero deviations"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze", "--intrinsics", "k.yaml"],
     {"c.csv": camera_set(), "k.yaml": LENS_ROS.replace("image_height: 1024\n", "")}, 2,
     "argument --intrinsics: k.yaml: image_height: missing (a ROS camera_info file has image_width, image_height"),
    (CAL, ["irb120", "--data", "c.csv:intrinsics=k.yaml", "--analyze"],
     {"c.csv": camera_set(), "k.yaml": LENS_CV.replace("   rows: 3\n   cols: 3", "   rows: 2\n   cols: 3").replace(
         " 0., 0., 1. ]", " ]")}, 2, "--data 'c.csv:intrinsics=k.yaml': intrinsics: k.yaml:5: camera_matrix: "
     "expected a 3x3 matrix, got 2x3"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze", "--intrinsics", "k.yaml"],
     {"c.csv": camera_set(), "k.yaml": LENS_ROS.replace("plumb_bob", "equidistant")}, 2,
     "k.yaml:8: distortion_model: 'equidistant' is not a distortion model calib-pin's lens has (plumb_bob"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze", "--intrinsics", "k.yaml"],
     {"c.csv": camera_set(), "k.yaml": LENS_ROS.replace("[1000, 0, 642,", "[1000, 3, 642,")}, 2,
     "k.yaml:4: camera_matrix: not a pinhole camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze", "--intrinsics", "k.yaml"],
     {"c.csv": camera_set(), "k.yaml": LENS_ROS.replace("data: [1000,", "data: [1000,,")}, 2,
     "k.yaml:7: not valid YAML"),
    (CAL, ["irb120", "--data", "c.csv", "--analyze", "--intrinsics", "missing.yaml"], {"c.csv": camera_set()}, 2,
     "argument --intrinsics: missing.yaml: cannot read the camera's intrinsics: No such file or directory"),
    (CAL, ["irb120", "--data", "c.csv", "--intrinsics", "out/irb120_intrinsics.yaml", "--estimate", "intrinsics",
           "--method", "lm", "--no-html", "--out", "out"], {"c.csv": camera_set(), "out/irb120_intrinsics.yaml": LENS_CV},
     2, "out/irb120_intrinsics.yaml is an input of this command (--intrinsics): choose another output"),
    (PLAN, ["irb120", "--sensor", "camera", "--focus-mm", "900,300", "--out", "p.csv"], {}, 2,
     "argument --focus-mm: expected NEAR,FAR in mm with 0 < NEAR < FAR, got '900,300'"),
    (PLAN, [*PLAN5, "--focus-mm", "300,900"], {}, 2,
     "--focus-mm: a camera's focus range; not an option of drawstring readings"),
    (PLAN, ["irb120", "--sensor", "camera", "--n", "10", "--candidates", "20", "--out", "p.csv"], {}, 2,
     "candidates see 12 corners or more of the board, its middle 225 to 900 mm from the camera; ask for more"),
]


DET = "detect"


def board_png(spec: str = "charuco,9x7,30,22", blank: bool = False) -> bytes:
    """A 600x480 image of a board seen face on (2 px a mm), PNG; ``blank``: a grey image of that size."""
    import cv2

    from calib_pin.sensors.camera_render import board_texture
    from calib_pin.sensors.lens import board_spec

    image = board_texture(cv2, board_spec(spec), 2.0)[0]
    return cv2.imencode(".png", image * 0 + 128 if blank else image)[1].tobytes()


def joints(*names: str, column: str = "image") -> str:
    """A joints file naming one image a pose (within the IRB120's limits)."""
    rows = [f"{k},{5 * k},10,10,0,{20 + k},0,{name}" for k, name in enumerate(names, 1)]
    return "\n".join([f"pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,{column}", *rows]) + "\n"


BOARD = ["--board", "charuco,9x7,30,22"]
BOARD_FILE = "kind: charuco\ncolumns: 9\nrows: 7\nsquare_mm: 30\nmarker_mm: 22\ndictionary: DICT_5X5_100\n"
DETECT = ["irb120", "--images", "img", *BOARD, "--out", "d.csv"]
IMAGES = {"img/a.png": board_png(), "img/b.png": board_png()}
#: detect (calib_pin/cli/detect.py): images that cannot be read, show no board or another size, a joints file that
#: does not match the folder; a board of the wrong size in mm (calibrate), --images without a camera (simulate).
I35_IMAGES: list[Case] = [
    (DET, DETECT, {**IMAGES, "img/joints.csv": joints("a.png", "b.png")}, 0, "2 of 2 images used, 96 corners"),
    (DET, DETECT, {**IMAGES, "img/b.png": b"not an image", "img/joints.csv": joints("a.png", "b.png")}, 0,
     "img/joints.csv: pose 2: b.png: cannot be read as an image; left out"),
    (DET, DETECT, {**IMAGES, "img/joints.csv": joints("a.png", "b.png", "c.png")}, 0,
     "img/joints.csv: pose 3: c.png: no such file; left out"),
    (DET, DETECT, {**IMAGES, "img/c.png": board_png(blank=True), "img/joints.csv": joints("a.png", "b.png", "c.png")},
     0, "pose 3: c.png: board not found (charuco 9x7 squares of 30 mm, markers 22 mm, DICT_5X5_100; its size counts "
     "squares, not inner corners); left out"),
    (DET, ["irb120", "--images", "img", "--board", "charuco,5x5,30,22", "--out", "d.csv"],
     {**IMAGES, "img/joints.csv": joints("a.png", "b.png")}, 2,
     "img: no usable image among the 2 the joints file img/joints.csv names (board not found (charuco 5x5"),
    (DET, [*DETECT, "--intrinsics", "1000,1000,640,512,1280,1024"], {**IMAGES, "img/joints.csv": joints("a.png", "b.png")},
     2, "(600x480 px, the lens's intrinsics are 1280x1024 px (another camera's or resolution's?))"),
    (DET, DETECT, {**IMAGES, "img/joints.csv": joints("a.png", "b.png", column="file")}, 2,
     "img/joints.csv: image: no 'image' column: name each pose's image file"),
    (DET, DETECT, {**IMAGES, "img/x.png": board_png(), "img/joints.csv": joints("a.png", "b.png")}, 0,
     "img: 1 image(s) the joints file does not name, left out: x.png"),
    (DET, DETECT, {**IMAGES, "img/joints.csv": joints("a.png", "b.png", "a.png")}, 0,
     "pose 3: a.png: already pose 1's image (one image cannot show two poses); left out"),
    (DET, DETECT, {"img/joints.csv": joints()}, 2, "img/joints.csv: has a header but no data rows"),
    (DET, ["irb120", "--images", "nothere", *BOARD, "--out", "d.csv"], {}, 2, "nothere: --images: no such folder"),
    (DET, ["irb120", "--images", "img", "--board", "chessboard,9x7,30", "--out", "d.csv"],
     {**IMAGES, "img/joints.csv": joints("a.png", "b.png")}, 2,
     "intrinsics: a chessboard's corner numbering needs the lens (--intrinsics)"),
    (CAL, ["irb120", "--data", "c.csv", "--method", "lm", "--no-html", "--out", "out"],
     {"c.csv": "\n".join(camera_set().splitlines()).replace("# board_square_mm: 30.000000", "# board_square_mm: 25")},
     2, "c.csv: board_square_mm: the board's squares measure 30.1 mm by the robot's motion, not the 25 mm given"),
    (DET, ["irb120", "--images", "img", "--board", "b.yaml", "--out", "d.csv"],
     {**IMAGES, "img/joints.csv": joints("a.png", "b.png"), "b.yaml": BOARD_FILE}, 0, "2 of 2 images used, 96 corners"),
    (DET, ["irb120", "--images", "img", "--board", "b.yaml", "--out", "d.csv"],
     {"b.yaml": BOARD_FILE.replace("marker_mm", "markr_mm")}, 2,
     "argument --board: b.yaml:5: markr_mm: not a key of a board (it has kind, columns, rows, square_mm, marker_mm"),
    (DET, ["irb120", "--images", "img", "--board", "b.yaml", "--out", "d.csv"],
     {"b.yaml": BOARD_FILE.replace("rows: 7", "rows: seven")}, 2, "b.yaml:3: rows: expected a number, got 'seven'"),
    (DET, ["irb120", "--images", "img", "--board", "b.yaml", "--out", "d.csv"],
     {"b.yaml": BOARD_FILE.replace("marker_mm: 22", "marker_mm: 40")}, 2,
     "b.yaml:5: marker_mm: marker size 40.0 mm is not positive and smaller than the square (30 mm)"),
    (DET, ["irb120", "--images", "img", "--board", "b.yaml", "--out", "d.csv"],
     {"b.yaml": BOARD_FILE.replace("marker_mm: 22\n", "")}, 2,
     "b.yaml: marker_mm: missing (a charuco file has kind, columns, rows, square_mm, marker_mm)"),
    (CAL, ["irb120", "--data", "c.csv", "--test-fraction", "0", "--method", "lm", "--no-html", "--out", "out"],
     {"c.csv": turned_pose()}, 2, "c.csv: pose: 1 pose(s) whose corners do not belong to their joints: pose 3 (lines"),
    (CAL, ["irb120", "--data", "c.csv", "--method", "lm", "--no-html", "--out", "out"], {"c.csv": turned_pose()}, 2,
     "c.csv: pose: 1 pose(s) whose corners do not belong to their joints: pose 3 (lines"),
    (CAL, ["irb120", "--data", "c.csv", "--camera-mount", "eye-to-hand", "--method", "lm", "--no-html", "--out", "out"],
     {"c.csv": camera_set()}, 2, "c.csv: camera_mount: the images do not follow the robot's motion"),
    (CAL, ["irb120", "--data", "c.csv", "--estimate", "intrinsics", "--analyze"], {"c.csv": camera_set(drop="# camera_")},
     2, "(--estimate intrinsics refines a starting lens: give one, the nominal values will do)"),
    (DET, ["irb120", "--images", "img", "--board", "charuco,9x7,30,22,DICT_FOO", "--out", "d.csv"], {}, 2,
     "dictionary 'DICT_FOO' is not one of OpenCV's ArUco dictionaries"),
    (DET, ["irb120", "--images", "img", "--board", "b.yaml", "--out", "d.csv"],
     {"b.yaml": "kind: chessboard\ncolumns: 9\nrows: 7\nsquare_mm: 30\nmarker_mm: 22\n"}, 2,
     "b.yaml:5: marker_mm: marker size: a chessboard has no markers"),
    (DET, [*DETECT[:-2], "--out", "img/a.png", "--force"], {**IMAGES, "img/joints.csv": joints("a.png", "b.png")}, 2,
     "img/a.png is an input of this command (--images (a.png))"),
    (SIM, ["irb120", "--out", "s.csv", "--poses", "5", "--images", "img"], {}, 2,
     "--images renders a camera set's images; this simulates cable (--kinds camera)"),
]


#: The rows of the earlier rounds, then round 3's by class (docs/bad_input.md lists them all).
BASE_CASES = list(CASES)
SECTIONS: list[tuple[str, list[Case]]] = [
    ("Round 3: outputs never overwritten or cut; messages that name the real cause", R3_OUTPUTS),
    ("Round 3: batch and compare keep finished work; parallel faults in one line", R3_PARALLEL),
    ("Round 3: no silent wrong result; calibration files and the parser", R3_WRONG),
    ("Round 3: compliance >= 0, rank-deficient sets calibrate, figures optional", R3_COMPLIANCE),
    ("Round 3: real files (extra columns, string labels, ';' and decimal comma)", R3_FILES),
    ("Issue 25: parameters held fixed, a start file, controller programs", I25_CONTROLLER),
    ("Round 26: per-set options name their own key; a set-up that misses the readings", I26_PERSET),
    ("Issue 34 (C): unit and order mistakes named before the fit", I34C),
    ("Issue 34 (B): rows fitted twice, thin sets' noise, collisions, moved fixtures, counts, messages", I34B),
    ("Issue 34: several sets, new sensors and real lab files (part A)", I34_CLASSES),
    ("Issue 35: camera sets (a board's corners in images)", I35_CAMERA),
    ("Issue 35: a camera's lens file, its exports and planned poses", I35_CAMERA_FILES),
    ("Issue 35: images: detect, and a board's size", I35_IMAGES),
]
CASES += [row for _, rows in SECTIONS for row in rows]


@pytest.mark.parametrize(("name", "argv", "files", "status", "fragment"), CASES,
                         ids=[f"{c[0]}-{k}" for k, c in enumerate(CASES)])
def test_bad_input_gives_one_line(name, argv, files, status, fragment, tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    for path, content in files.items():
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        (Path(path).write_bytes if isinstance(content, bytes) else Path(path).write_text)(content)
    run = main if name == ENTRY else command(name)
    try:
        code = run(argv)
    except SystemExit as e:
        code = e.code
    captured = capfd.readouterr()
    err = captured.err
    # the one error line; warnings and notes of the work done before it may precede it
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith(("warning: ", "note: "))]
    assert "Traceback" not in err
    assert code == status, err
    if status == 0:  # a valid input that must be accepted: the fragment is somewhere in what it printed
        assert fragment in captured.out + err, captured.out + err
        return
    assert len(lines) == 1, err
    assert fragment in lines[0], err


def _other_robot_session() -> str:
    """A drawstring session of another robot, its last row cut short (no final newline)."""
    rows = (f"{k},{r}" for k, r in enumerate(ROWS[:5], 1))
    return csv(*rows, meta=("# robot: ur5", *META[1:]), head="pose," + HEAD).rstrip("\n")


WRONG_OUT: dict[str, str | bytes | None] = {
    "csv of another robot, no final newline": _other_robot_session(),
    "csv of another pose list, no final newline": csv(*(f"{k},{r}" for k, r in enumerate(ROWS[:3], 1)),
                                                      head="pose," + HEAD).rstrip("\n"),
    "binary file": bytes(range(256)) * 8,
    "empty file": b"",
    "a folder": None,
    "report.json": '{\n  "urdf": "out/irb120_calibrated.urdf",\n  "warnings": []\n}',
    "URDF": URDF,
}


@pytest.mark.parametrize("kind", WRONG_OUT)
def test_refused_collect_out_keeps_every_byte(kind, tmp_path, monkeypatch, capfd):
    """A wrong existing --out is refused with one line and not changed by one byte."""
    from calib_pin.hardware.fake_indicator import FakeIndicator

    monkeypatch.chdir(tmp_path)
    Path("p.csv").write_text(POSES)
    out = Path("o.csv")
    content = WRONG_OUT[kind]
    if content is None:
        out.mkdir()
        (out / "inside.txt").write_text("kept")
    else:
        (out.write_bytes if isinstance(content, bytes) else out.write_text)(content)
    before = None if content is None else out.read_bytes()
    with FakeIndicator("modbus", 1000.0) as fake:
        code = command("collect")(["irb120", "--poses", "p.csv", "--port", fake.path, "--out", str(out),
                                   "--auto", "0", "--interval", "0", "--samples", "3", "--timeout", "0.2"])
    err = capfd.readouterr().err
    assert code == 2, err
    assert len([line for line in err.splitlines() if line.strip()]) == 1 and "o.csv" in err, err
    if content is None:
        assert [p.name for p in out.iterdir()] == ["inside.txt"] and (out / "inside.txt").read_text() == "kept"
    else:
        assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.csv", "p.csv"]

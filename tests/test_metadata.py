"""A measurement file's ``# key: value`` lines: a key that looks like one calib-pin reads is
refused with "did you mean", a free-text note is kept."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import calib_pin as cp
from calib_pin.measurements.metadata import known_keys, read_metadata

PATH = Path("s.csv")


def _read(*lines: str, decimal: str = ".") -> tuple[dict, dict]:
    raw = [(k, key.strip(), value) for k, (key, _, value) in enumerate((line.partition(":") for line in lines), 1)]
    return read_metadata(raw, PATH, decimal)


@pytest.mark.parametrize(("line", "message"), [
    ("anchor_mn: 600, 200, -100", "s.csv:1: anchor_mn: unknown metadata key; did you mean anchor_mm?"),
    ("anchor_mn: 600, 200", "did you mean anchor_mm?"),  # a broken value is still no note
    ("Anchor_mm: 600, 200, -100", "did you mean anchor_mm? (keys are case-sensitive"),
    ("anchor_cm: 60, 20, -10", "did you mean anchor_mm? (unit 'cm' is not read: anchor_mm or anchor_m"),
    ("tool: 0, 0, 50", "did you mean tool_mm? (no unit: tool_mm or tool_m"),
    ("noise: 0.05", "did you mean noise_mm? (no unit: noise_mm, noise_m, noise_deg or noise_px"),
    ("lenght_offset_mm: 0", "did you mean length_offset_mm?"),
    ("noise_dge: 0.01", "did you mean noise_deg?"),
    ("distanse_mm: A, B, 300", "did you mean distance_mm?"),
    ("robt: irb120", "did you mean robot?"),
    ("endframe: tool0", "did you mean end_frame?"),
    ("cvs: sep=;", "did you mean csv?"),
])
def test_a_key_that_looks_like_one_calib_pin_reads_is_refused(line, message):
    with pytest.raises(cp.DataError, match=re.escape(message)):
        _read(line)


@pytest.mark.parametrize("lines", [
    ("tool: Schunk gripper",),  # words where tool_mm's numbers go: a note
    ("tool_mm: 0, 0, 50", "tool: 0, 0, 50"),  # the file gives tool_mm: the other one is a note
    ("source: calib-pin simulator, seed 0",),
    ("sensor: Modbus at 19200 baud", "stability: 5 samples within 0.02 mm", "started: 2024-05-01T10:00:00"),
    ("operator: J. Doe", "temperature_C: 21.5", "anchor_id: 3"),
])
def test_free_text_notes_stay_legal(lines):
    meta, notes = _read(*lines)
    assert set(notes) == {line.partition(":")[0] for line in lines if line.partition(":")[0] not in known_keys()}


def test_the_rule_holds_for_a_file(tmp_path, chain):
    """The reader refuses such a key naming its line; a set with a known key given reads it."""
    text = "# robot: irb120\n# anchor_mn: 600, 200, -100\nq1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,length_mm\n" \
           "10,20,-30,40,-50,60,812.5\n"
    (tmp_path / "s.csv").write_text(text)
    with pytest.raises(cp.DataError, match=r"s\.csv:2: anchor_mn: unknown metadata key; did you mean anchor_mm\?"):
        cp.read_measurements(tmp_path / "s.csv", chain)
    (tmp_path / "s.csv").write_text(text.replace("anchor_mn", "anchor_mm"))
    assert cp.read_measurements(tmp_path / "s.csv", chain).anchor.tolist() == [0.6, 0.2, -0.1]

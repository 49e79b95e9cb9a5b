"""The whole-process command benchmark (calib_pin.studies.benchmark_commands): each command
line runs and exits 0 on a small seeded set, and the table prints each size's ratio to the
size before. No time is asserted (speed is measured by benchmark.py, never tested)."""

from __future__ import annotations

import numpy as np

from calib_pin.studies import benchmark_commands as bc


def test_compensate_command_runs_on_every_target(tmp_path):
    """The benchmark's sets and the compensate command line it times: the command exits 0 and
    writes every one of the 1000 targets, each compensated to the 1 um / 1 urad rule."""
    bc._make_sets(tmp_path, 40, 0)
    assert all((tmp_path / f"b_{k}.csv").is_file() for k in range(1, bc.BATCH_SETS + 1))
    runs = bc.time_commands(("compensate",), (40,), "lm", compare_max_rows=0)
    assert [(r.command, r.rows, r.code) for r in runs] == [("compensate", 40, 0)]
    assert runs[0].wall_s > 0 and runs[0].peak_mib > 0


def test_format_commands_gives_ratios_to_the_size_before():
    runs = [bc.Run("calibrate", 1000, "lm", 2.0, 150.0, 0), bc.Run("calibrate", 10_000, "lm", 5.0, 200.0, 0),
            bc.Run("batch", 1000, "lm", 3.0, 140.0, 0)]
    text = bc.format_commands(runs)
    lines = text.splitlines()
    assert "1000 rows" in lines[0] and "10000 rows" in lines[0]
    assert "(x2.5)" in lines[1] and "(-)" in lines[1] and lines[2].rstrip().endswith("-")
    assert np.isclose(float(lines[1].split()[1]), 2.0)

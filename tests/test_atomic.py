"""The library's writers (calib_pin/util/atomic.py): on a full disk the earlier file is kept
whole, not cut, and no temporary file is left; a symbolic link is written through."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys

from calib_pin.util.atomic import write_text

#: Writes 300 poses (about 20 kB) over p.csv with the public writer.
WRITE = ("import numpy as np; from calib_pin.measurements import write_poses; "
         "write_poses('p.csv', np.zeros((300, 6)), robot='irb120')")


def _full_disk(limit: int):
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


def test_a_full_disk_keeps_the_earlier_file_whole(tmp_path):
    """write_poses over an existing file on a disk that fills: the library once truncated
    the file and left it cut; now it raises and the earlier file is as it was."""
    earlier = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n" + "1,0,0,0,0,0,0\n" * 200
    (tmp_path / "p.csv").write_text(earlier)
    done = subprocess.run([sys.executable, "-c", WRITE], cwd=tmp_path, capture_output=True, text=True,
                          timeout=60, preexec_fn=_full_disk(len(earlier) + 100))
    assert done.returncode != 0 and "File too large" in done.stderr, done.stderr
    assert (tmp_path / "p.csv").read_text() == earlier
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv"]
    done = subprocess.run([sys.executable, "-c", WRITE], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert len((tmp_path / "p.csv").read_text().splitlines()) == 302


def test_a_symbolic_link_is_written_through(tmp_path):
    target = tmp_path / "real.csv"
    target.write_text("old")
    os.symlink(target, tmp_path / "link.csv")
    write_text(tmp_path / "link.csv", "new")
    assert (tmp_path / "link.csv").is_symlink() and target.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.csv", "real.csv"]

"""The camera benchmark (calib_pin.studies.benchmark_camera): its set shows every corner in every image, and its
command lines run and exit 0. No time is asserted (speed is measured by benchmark.py, never tested)."""

from __future__ import annotations

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.studies import benchmark_camera as bcam

pytest.importorskip("cv2")


def test_the_camera_set_has_every_corner_in_every_image_and_calibrates(tmp_path):
    """12 images of the 50-corner board: 600 rows, 50 a pose; the timed command exits 0 and the table prints it
    beside the floor."""
    assert bcam.camera_images(tmp_path / "cam.csv", images=12) == (12, 600)
    data = cp.read_measurements(tmp_path / "cam.csv", cp.load_chain("irb120"))
    assert set(np.unique(data.pose_ids, return_counts=True)[1]) == {bcam.CORNERS}
    runs, images, rows = bcam.time_camera(repeats=1, variants={"lm --no-html": ["--method", "lm", "--no-html"]},
                                          images=12)
    assert (images, rows) == (12, 600) and [(r.variant, r.code) for r in runs] == [("lm --no-html", 0)]
    text = bcam.format_camera(runs)
    assert "lm --no-html" in text and "floor (import numpy, pinocchio, scipy)" in text

"""calibration/sets.py: the warnings a set's fit earns."""

from __future__ import annotations

from calib_pin.calibration.sets import held_out_warning


def test_held_out_rows_far_worse_than_the_training_rows_are_named():
    """Held-out rows 10 times worse than the training rows, and beyond 5 noise sigmas, get a warning in the
    set's unit; a usual split (test a little worse than train) and a noisy but fair one get none."""
    said = held_out_warning("cam", 0.04, 400.0, 0.1, "px")
    assert said is not None and said.startswith("cam: the held-out rows miss by 400 px, 10000 times")
    assert held_out_warning("cam", 0.12, 0.14, 0.1, "px") is None
    assert held_out_warning("cab", 0.01, 0.2, 0.05, "mm") is None  # 20 times, but within 5 sigmas of the noise

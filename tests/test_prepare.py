"""prepare checks each value once, where it enters: the chain it makes is not checked again on
its way through the reader, the set checks, the parameter model and the sensor models, and a
set's path is checked once."""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import calib_pin as cp
from calib_pin.robot.chain import Chain, as_chain
from calib_pin.util import arguments

SHIPPED = str(Path(cp.__file__).resolve().parent.parent / "robots" / "irb120_default.csv")


def _checks_during(call) -> Counter:
    """How often ``call()`` checks a value is a Chain (as_chain, as_instance of Chain) and a
    path (as_path), by the function that asked."""
    seen: Counter = Counter()
    codes = {as_chain.__code__: "chain", arguments.as_instance.__code__: "instance", arguments.as_path.__code__: "path"}

    def profile(frame, event, arg):
        what = codes.get(frame.f_code) if event == "call" else None
        if what is None or (what == "instance" and (frame.f_locals.get("kind") is not Chain
                                                    or frame.f_back.f_code is as_chain.__code__)):
            return
        seen[("chain" if what == "instance" else what, frame.f_back.f_code.co_name)] += 1

    sys.setprofile(profile)
    try:
        call()
    finally:
        sys.setprofile(None)
    return seen


def test_the_chain_and_the_path_are_checked_once():
    """calibrate of the shipped set: the robot's chain, made by prepare, is never checked again
    (it was six times: twice by parameter_model, by the reader, the set checks and each sensor
    model); the path is checked once, where it enters (FitSet)."""
    seen = _checks_during(lambda: cp.calibrate("irb120", SHIPPED, method="lm"))
    assert sum(n for (what, _), n in seen.items() if what == "chain") == 0, seen
    assert [(where, n) for (what, where), n in seen.items() if what == "path"] == [("__post_init__", 1)], seen


def test_the_public_entry_points_still_check():
    """What a caller passes to the public functions is checked as before."""
    import pytest

    with pytest.raises(cp.ArgumentError, match="chain"):
        cp.parameter_model("irb120")
    with pytest.raises(cp.ArgumentError, match="chain"):
        cp.check_measurements("irb120", cp.read_measurements(SHIPPED))
    with pytest.raises(cp.ArgumentError, match="chain"):
        cp.CableModel("irb120", None, cp.Drawstring((0, 0, 0), (0, 0, 0)))
    with pytest.raises(cp.ArgumentError, match="data"):
        cp.FitSet("")

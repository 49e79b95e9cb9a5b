"""The library checks a measurement set as the CSV reader does: another robot's data, NaN
readings or angles, joints outside their limits, and a validation session whose own
drawstring set-up contradicts the calibration's (calib_pin.calibration.validation)."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.calibration.validation import check_same_setup
from calib_pin.measurements.checks import check_measurements


@pytest.fixture(scope="module")
def cable(chain, params):
    return cp.simulate(chain, params, 30, seed=5)[0]


@pytest.fixture(scope="module")
def positions(chain, params):
    return cp.simulate_positions(chain, params, 12, seed=5)[0]


def changed(data: cp.MeasurementSet, **fields) -> cp.MeasurementSet:
    """A copy of ``data`` with arrays edited: ``q=(row, joint, value)``, ``values=(index, value)``."""
    q, values = data.q.copy(), data.values.copy()
    if "q" in fields:
        row, joint, value = fields.pop("q")
        q[row, joint] = value
    if "values" in fields:
        index, value = fields.pop("values")
        values[index] = value
    return dataclasses.replace(data, q=q, values=values, **fields)


def bad_sets(chain, cable, positions):
    """(set, fragment of the refusal) for each kind of fault."""
    over = chain.upper[2] + 0.01
    return [
        (changed(cable, robot="ur5"), "robot: is for robot 'ur5', not 'irb120'"),
        (changed(cable, values=(3, np.nan)), "row 3 (0-based): nan is not a finite length reading"),
        (changed(cable, values=(4, -0.2)), "length: row 4 (0-based): -200 mm is negative"),
        (changed(cable, q=(2, 1, np.nan)), "q2: row 2 (0-based): nan is not a finite joint angle"),
        (changed(cable, q=(7, 2, over)), "is outside the limits of joint_3"),
        (changed(cable, q=(1, 0, np.inf)), "q1"),
        (dataclasses.replace(cable, q=cable.q[:, :5]), "expected (n_rows, 6)"),
        (dataclasses.replace(cable, values=cable.values[:-1]), "values"),
        (dataclasses.replace(cable, end_frame="flange"), "end_frame"),
        (dataclasses.replace(cable, kind="laser"), "kind"),
        (dataclasses.replace(cable, anchor=np.array([np.nan, 0, 0])), "anchor"),
        (changed(positions, values=(5, np.inf)), "row 5 (0-based): inf is not a finite position reading"),
        (dataclasses.replace(positions, point_ids=None), "point_ids"),
        (dataclasses.replace(cable, lines=np.arange(10, 40)), None),  # lines name the file line: accepted
    ]


def test_check_measurements(chain, cable, positions):
    for data, fragment in bad_sets(chain, cable, positions):
        if fragment is None:
            assert check_measurements(chain, data) is data
            continue
        with pytest.raises(cp.DataError, match=re.escape(fragment)):
            check_measurements(chain, data)
    at_line = changed(cable, values=(3, np.nan), lines=np.arange(10, 40), source="s.csv")
    with pytest.raises(cp.DataError, match=r"^s\.csv:13: length: nan is not a finite length reading$"):
        check_measurements(chain, at_line)
    with pytest.raises(cp.ArgumentError, match="data"):
        check_measurements(chain, {"q": cable.q})


def test_another_robots_set_is_named_before_its_angles(chain, cable):
    """A set of another robot whose angles are also outside this robot's limits is refused
    for its robot, not for a joint limit."""
    other = changed(cable, robot="ur5", q=(3, 0, chain.upper[0] + 1.0))
    with pytest.raises(cp.DataError, match=re.escape("robot: is for robot 'ur5', not 'irb120'")):
        check_measurements(chain, other)


def test_a_set_may_name_its_robot_by_the_urdfs_robot_name(chain, cable):
    """The URDF's <robot name> (abb_irb120 for irb120) names the robot as its own name does."""
    assert chain.full_model.name == "abb_irb120"
    assert check_measurements(chain, changed(cable, robot="abb_irb120")).robot == "abb_irb120"


def test_entry_points_refuse_a_bad_set_in_memory(chain, params, cable, positions):
    """calibrate, prepare and a test_data session all check the set (once, where it
    enters): the checks are the library's, the CLI goes through them."""
    for data, fragment in bad_sets(chain, cable, positions)[:6]:
        with pytest.raises(cp.CalibPinError):
            cp.calibrate("irb120", data, method="lm")
        with pytest.raises(cp.CalibPinError):
            cp.prepare("irb120", data)
        with pytest.raises(cp.CalibPinError):
            cp.calibrate("irb120", cable, method="lm", test_data=data)


def test_a_set_in_memory_at_another_end_frame_uses_it(chain, params):
    """A set measured at 'flange' calibrates at 'flange' (as a file's '# end_frame:' does)."""
    flange = cp.load_chain("irb120", "flange")
    data, _ = cp.simulate(flange, cp.parameter_model(flange), 30, seed=2)
    assert data.end_frame == "flange"
    assert cp.prepare("irb120", data).chain.end_frame == "flange"
    with pytest.raises(cp.DataError, match="end frame 'flange', not 'tool0'"):
        cp.prepare("irb120", data, end_frame="tool0")


def test_validation_session_with_another_setup_is_refused(cable, tmp_path):
    """A session whose own anchor (tool, offset) contradicts the calibration's is refused in
    one line naming the file, the key and both values; the same set-up is scored."""
    moved = dataclasses.replace(cable, anchor=cable.anchor + [0.05, 0, 0], source="t.csv")
    with pytest.raises(cp.DataError, match=r"t\.csv: anchor_mm: the validation session has 650, 200, -100 mm, "
                                           r"the calibration 600, 200, -100 mm"):
        cp.calibrate("irb120", cable, method="lm", test_data=moved)
    offset = dataclasses.replace(cable, length_offset=0.0125, source="")
    with pytest.raises(cp.DataError, match="length_offset_mm"):
        cp.calibrate("irb120", cable, method="lm", test_data=offset)
    with pytest.raises(cp.DataError, match=r"the calibration 610, 200, -100 mm \(given\)"):
        check_same_setup(cable, cable, {"anchor_mm": (610.0, 200.0, -100.0)})
    check_same_setup(dataclasses.replace(cable, anchor=None, tool=None), cable, {})  # the session does not say
    check_same_setup(dataclasses.replace(cable, anchor=cable.anchor + 4e-10), cable, {})  # within rounding
    first = cable.subset(np.arange(10))  # read again at the same poses, with the same set-up
    again = first.values + np.random.default_rng(0).normal(0.0, 5e-5, len(first))
    result = cp.calibrate("irb120", cable, method="lm",
                          test_data=dataclasses.replace(first, values=again, source="same"))
    assert result.test_source == "same" and result.metrics["test"]["after"].rmse_mm < 0.2


def test_the_training_set_as_its_own_validation_session_is_refused(cable, tmp_path):
    """A test on the training rows scored the fit as if it were new poses (exit 0): the
    same set, in memory or as one file under two names (or a copy), is refused."""
    with pytest.raises(cp.DataError, match="holds the training set's own rows"):
        cp.calibrate("irb120", cable, method="lm", test_data=dataclasses.replace(cable, source=""))
    path = tmp_path / "s.csv"
    cp.write_measurements(path, cable)
    with pytest.raises(cp.DataError, match=r"s\.csv: holds the training set's own rows"):
        cp.calibrate("irb120", path, method="lm", test_data=tmp_path / "." / "s.csv")


def test_a_set_of_lists_is_a_set_of_arrays(chain, cable):
    """A MeasurementSet made by hand with lists (q, values, anchor, tool) calibrates as
    the same set of arrays (it raised numpy's TypeError); a ragged list is refused naming q."""
    listed = dataclasses.replace(cable, q=cable.q.tolist(), values=cable.values.tolist(),
                                 anchor=tuple(cable.anchor), tool=list(cable.tool))
    assert isinstance(listed.q, np.ndarray) and isinstance(listed.anchor, np.ndarray)
    expected = cp.calibrate("irb120", cable, method="lm", test_fraction=0.0).x
    np.testing.assert_allclose(cp.calibrate("irb120", listed, method="lm", test_fraction=0.0).x, expected)
    ragged = cable.q.tolist()
    ragged[2] = ragged[2][:5]
    with pytest.raises(cp.DataError, match=r"data: q: joint angles of shape \(30,\) \(object\)"):
        check_measurements(chain, dataclasses.replace(cable, q=ragged, source=""))


def test_a_validation_session_from_another_device_placement_is_refused(positions):
    """Scored with the calibration's device frame, a session measured after the tracker
    was moved 10 mm gave every row 10 mm of error (exit 0): refused, naming the shift; the
    same placement is scored."""
    train, test = positions.subset(np.arange(24)), positions.subset(np.arange(24, 36))
    result = cp.calibrate("irb120", train, method="lm", test_data=test)
    assert result.metrics["test"]["after"].rmse_mm < 0.2
    moved = dataclasses.replace(test, values=test.values + [0.0, 0.01, 0.0], source="v.csv")
    with pytest.raises(cp.DataError, match=r"v\.csv: device frame: the session's own is 10 mm \(RMS over its points\) "
                                           "from the calibration's"):
        cp.calibrate("irb120", train, method="lm", test_data=moved)


def test_a_nan_quaternion_component_of_a_6d_set_is_named(chain):
    """A NaN in a hand-made 6-D set's quaternion is refused naming its column (an index past
    the position columns raised IndexError)."""
    from calib_pin.simulation import simulate_poses

    data, _ = simulate_poses(chain, cp.parameter_model(chain), 5, seed=2)
    values = np.array(data.values, dtype=float)
    values[2, 4] = np.nan
    with pytest.raises(cp.DataError, match=r"row 2 \(0-based\): nan is not a finite pose reading") as refused:
        check_measurements(chain, dataclasses.replace(data, values=values, lines=None))
    assert refused.value.field == "qx"


def test_a_limit_margin_accepts_a_row_beyond_the_urdf_and_names_it(chain, cable, tmp_path):
    """A row 0.5 deg beyond joint_1's URDF limit: refused, pointing at the margin; accepted
    with limit_margin_deg, which names the row; still refused beyond the margin."""
    from calib_pin.measurements.checks import beyond_urdf_limits

    over = changed(cable, q=(4, 0, chain.upper[0] + np.radians(0.5)), source="s.csv", lines=np.arange(10, 40))
    with pytest.raises(cp.DataError, match=re.escape("s.csv:14: q1: 165.5 deg is outside the limits of joint_1 "
                                                     "[-165, 165] deg (the URDF's; a controller that allows more: "
                                                     "calibrate --limit-margin-deg)")):
        cp.prepare("irb120", over)
    calibration = cp.prepare("irb120", over, limit_margin_deg=1.0)
    assert beyond_urdf_limits(calibration.chain, calibration.data) == ["line 14: joint_1 165.5 deg"]
    with pytest.raises(cp.DataError, match=re.escape("[-165.2, 165.2] deg (the URDF's, widened by 0.2 deg)")):
        cp.prepare("irb120", over, limit_margin_deg=0.2)
    with pytest.raises(cp.ArgumentError, match="limit_margin_deg"):
        cp.prepare("irb120", over, limit_margin_deg=45)

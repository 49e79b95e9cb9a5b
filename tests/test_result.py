"""CalibrationResult.predict: any number of poses, checked arguments, point labels."""

from __future__ import annotations

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.robot.poses import random_poses


@pytest.fixture(scope="module")
def one_marker(chain, params):
    """A one-marker position calibration on 20 poses and its truth."""
    data, truth = cp.simulate_positions(chain, params, 20, seed=4, noise_mm=0.0, markers_mm=[[0.0, 0.0, 50.0]])
    return cp.calibrate("irb120", data, method="lm", test_fraction=0.0), truth


@pytest.fixture(scope="module")
def three_markers(chain, params):
    data, truth = cp.simulate_positions(chain, params, 20, seed=5, noise_mm=0.0)
    return cp.calibrate("irb120", data, method="lm", test_fraction=0.0), truth


def test_predict_takes_any_number_of_poses(chain, params, one_marker, three_markers):
    """One marker: every pose predicts it (here 7 poses after 20 calibrated); several:
    with point_ids (one label for all, or one per pose); cable: a reading per pose."""
    q = random_poses(chain, 7, np.random.default_rng(0))
    result, truth = one_marker
    expected = truth.model(chain, params).predict(truth.x, q)
    predicted = result.predict(q)
    assert predicted.shape == (7, 3)
    np.testing.assert_allclose(predicted, expected, atol=1e-6)
    assert result.predict(q[0]).shape == (1, 3)
    result, truth = three_markers
    np.testing.assert_allclose(result.predict(q, 2), truth.model(chain, params).predict(truth.x, q, np.full(7, 1)),
                               atol=1e-6)
    assert result.predict(q, [1, 2, 3, 1, 2, 3, 1]).shape == (7, 3)
    cable = cp.calibrate("irb120", method="lm")
    assert cable.predict(q).shape == (7,) and cable.predict(q[:1]).shape == (1,)


def test_predict_asks_for_point_ids_with_several_markers(chain, three_markers):
    result, _ = three_markers
    with pytest.raises(cp.CalibPinError, match=r"point_ids: this calibration has 3 markers \(1, 2, 3\)"):
        result.predict(np.zeros((4, 6)))
    with pytest.raises(cp.CalibPinError, match=r"point_ids: 3 labels for 4 poses"):
        result.predict(np.zeros((4, 6)), [1, 2, 3])
    with pytest.raises(cp.CalibPinError, match=r"point_id 1.5 is not a marker label"):
        result.predict(np.zeros((1, 6)), [1.5])
    np.testing.assert_array_equal(result.predict(np.zeros((2, 6)), ["2", 2.0]), result.predict(np.zeros((2, 6)), 2))


@pytest.mark.parametrize(
    "q, message",
    [
        (np.zeros((4, 5)), r"q: shape \(4, 5\), expected \(n_poses, 6\)"),
        (np.zeros((2, 3, 6)), r"q: shape \(2, 3, 6\), expected \(n_poses, 6\)"),
        (np.zeros((0, 6)), r"q: no poses"),
        (np.full((2, 6), np.nan), r"q: not finite"),
        ([["a"] * 6], r"q: not numbers"),
        # degrees given as radians: predict answered for an arm turned 57 times too far
        (np.rad2deg([[0.5, 0.3, -0.2, 0.1, 0.4, 1.0]]), r"argument q: q\[0, 0\] = 28.6479 rad is outside the "
         r"limits of joint_1 .*looks like degrees"),
        ([[0.0, 2.5, 0.0, 0.0, 0.0, 0.0]], r"argument q: q\[0, 1\] = 2.5 rad is outside the limits of joint_2"),
    ],
)
def test_predict_checks_q(one_marker, q, message):
    result, _ = one_marker
    with pytest.raises(cp.CalibPinError, match=message):
        result.predict(q)


def test_point_ids_of_a_sensor_of_one_point_are_refused_not_ignored():
    """A drawstring calibration has no markers: labels given to predict would be ignored silently."""
    result = cp.calibrate("irb120", method="lm")
    q = result.data.q[:3]
    assert result.predict(q).shape == (3,)
    with pytest.raises(cp.CalibPinError, match="point_ids: .*leave point_ids out"):
        result.predict(q, point_ids=["T1", "T1", "T1"])


def test_a_sanity_refusal_blames_only_the_setup_its_sets_take():
    """A drawstring's refusal may blame its anchor, tool point or offset; a 6-D pose set's, having
    none to give, a unit or order mistake in its data."""
    from types import SimpleNamespace

    from calib_pin.calibration.result import _setup_hint
    from calib_pin.sensors import CableModel, ContactModel, PoseModel, PositionModel

    assert CableModel.setup_keys() == ("anchor_mm", "tool_mm", "length_offset_mm")
    assert ContactModel.setup_keys() == ("tool_mm",) and PoseModel.setup_keys() == PositionModel.setup_keys() == ()
    pose = object.__new__(PoseModel)
    cable = object.__new__(CableModel)
    assert _setup_hint(SimpleNamespace(parts=(pose,))) == "a unit or order mistake in the data"
    assert _setup_hint(SimpleNamespace(parts=(pose, cable))) == "a wrong anchor_mm/tool_mm/length_offset_mm or unit"

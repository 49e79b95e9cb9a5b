"""plan-poses --sensor camera: poses that keep the board in view and in focus, and see more than random ones."""

from __future__ import annotations

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.analysis.planning import plan_poses
from calib_pin.cli.poses import plan_poses_main
from calib_pin.sensors import CameraModel, CameraSetup
from calib_pin.sensors.camera_view import MIN_SEEN, board_distance, seen


@pytest.mark.parametrize(("robot", "mount", "focus"), [("irb120", "eye-in-hand", None),
                                                       ("ur5", "eye-to-hand", (400.0, 1000.0))])
def test_planned_camera_poses_see_the_board_in_focus_and_beat_random_ones(robot, mount, focus):
    """Every planned pose sees 12 corners or more with the board's middle in the focus range, and the plan's O1
    (the measure every planner is judged by) is above that of as many random poses that see the board."""
    chain = cp.load_chain(robot)
    model = CameraModel.planning_model(chain, cp.parameter_model(chain), CameraSetup(camera_mount=mount), focus)
    plan = plan_poses(model, 20, 1000, seed=1)
    near, far = model.focus_mm
    assert (near, far) == (focus or ((225.0, 900.0) if mount == "eye-in-hand" else (350.0, 1400.0)))
    visible = seen(model, None, plan.q)
    assert visible.sum(axis=1).min() >= MIN_SEEN
    np.testing.assert_array_equal(visible, plan.points)
    distance = board_distance(model, None, plan.q)
    assert near <= distance.min() and distance.max() <= far
    assert plan.o1 > plan.random_o1
    assert plan.reach is not None and plan.reach < 20


def test_plan_poses_for_a_camera_writes_a_pose_list(tmp_path, capsys):
    """The command plans for the camera's mount, board and focus range, and says what the poses see."""
    out = tmp_path / "plan.csv"
    assert plan_poses_main(["irb120", "--sensor", "camera", "--camera-mount", "eye-to-hand", "--focus-mm", "300,1200",
                            "--n", "15", "--candidates", "1200", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "corners in view per planned pose:" in text and "(eye-to-hand, charuco 9x7" in text
    assert len(cp.read_measurements(out, cp.load_chain("irb120"), readings=False)) == 15
    assert plan_poses_main(["irb120", "--sensor", "camera", "--n", "15", "--candidates", "20", "--out",
                            str(tmp_path / "few.csv")]) == 2
    assert "candidates see 12 corners or more of the board" in capsys.readouterr().err

"""Rendered images, detected and calibrated: the robot as good as an oracle, the camera's pose near the truth,
the intrinsics within their reported sigma, the joint fit nearer the truth than OpenCV's best hand-eye."""

from __future__ import annotations

import dataclasses

import pytest

from calib_pin.studies import camera_images
from calib_pin.studies.camera_images import POSE_GOAL, RATIO_GOAL, SIGMA_GOAL, ImagesRow, compare

pytest.importorskip("cv2")

CASES = (("irb120", "eye-in-hand"), ("ur5", "eye-to-hand"))
_ROWS: dict[tuple[str, str], ImagesRow] = {}

def _row(robot: str, mount: str) -> ImagesRow:
    """The case's row, computed once (seed 1, 40 poses, the robot's deviations)."""
    if (robot, mount) not in _ROWS:
        _ROWS[robot, mount] = compare(robot, mount, "deviations", seed=1)
    return _ROWS[robot, mount]


@pytest.mark.parametrize(("robot", "mount"), CASES)
def test_the_robot_is_as_good_as_the_oracle_on_the_detected_corners(robot, mount):
    """Gauge-free fresh error at the flange origin and at the camera within 1.2 x the oracle's (LM from the
    truth on the same detected corners); nearly every image used, its corners within 0.05 px RMS of the true
    projection."""
    row = _row(robot, mount)
    assert row.images == 40 and row.used >= 38 and row.detected > 0.7 * row.visible
    assert row.detect_px < 0.05
    assert row.flange[0] <= RATIO_GOAL * row.flange[1]
    assert row.at_camera[0] <= RATIO_GOAL * row.at_camera[1]


@pytest.mark.parametrize(("robot", "mount"), CASES)
def test_the_camera_pose_at_fresh_poses_is_near_the_truth(robot, mount):
    """The board's pose in the camera frame (T_CW) at fresh poses within 0.05 mm and 0.01 deg RMS of the truth."""
    row = _row(robot, mount)
    assert row.pose_fit[0] < POSE_GOAL[0] and row.pose_fit[1] < POSE_GOAL[1]


@pytest.mark.parametrize(("robot", "mount"), CASES)
def test_the_intrinsics_are_within_their_reported_sigma(robot, mount):
    """Started 6, 5, 4 px and 0.01 off, fx, fy, cx, cy, k1, k2 end within 3 of their reported std."""
    assert _row(robot, mount).lens_sigma < SIGMA_GOAL


@pytest.mark.parametrize(("robot", "mount"), CASES)
def test_the_joint_fit_is_nearer_the_truth_than_opencvs_best_hand_eye(robot, mount):
    """With the robot's deviations, T_CW at fresh poses by the joint fit nearer the truth than by OpenCV's best
    hand-eye method on the nominal robot, in translation and rotation."""
    row = _row(robot, mount)
    assert row.pose_fit[0] < row.pose_opencv[0] and row.pose_fit[1] < row.pose_opencv[1]


def test_benchmark_images_prints_the_table_the_detection_time_and_the_goals(monkeypatch, capsys):
    """benchmark --images --robots irb120 --repeats 1: one row per mount and case, the detection time, the goals,
    the oracle and the gauge sentence (the cases' rows those computed above); --opencv-corners says whose corners."""
    from calib_pin.cli.benchmark import benchmark_main

    asked = []

    def canned(robot: str, mount: str, case: str, seed: int = 1, opencv_corners: bool = False) -> ImagesRow:
        asked.append(opencv_corners)
        row = dataclasses.replace(_row(robot, "eye-in-hand"), mount=mount, case=case, seed=seed)
        return row if case == "deviations" else dataclasses.replace(row, hand_eye_fit=(0.1, 0.01),
                                                                    hand_eye_opencv=(2.0, 0.2))

    monkeypatch.setattr(camera_images, "compare", canned)
    assert benchmark_main(["--images", "--robots", "irb120", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert out.count("| irb120 |") == 4 and "| 0.1000 / 0.01000 vs 2.0000 / 0.20000 |" in out
    assert "detection time per image" in out and "ms" in out and out.count("goal:") == 4
    assert "oracle: Levenberg-Marquardt started from the true robot" in out.replace("Oracle", "oracle")
    assert "shares a gauge with the last link's deviations" in out
    assert "found by find_corners" in out and "refined clear of the markers" in out and not any(asked)
    assert benchmark_main(["--images", "--robots", "irb120", "--repeats", "1", "--opencv-corners"]) == 0
    out = capsys.readouterr().out
    assert "its own corners, not refined again clear of the markers" in out and all(asked[4:]) and len(asked) == 8


@pytest.mark.parametrize("flag", ["--images", "--hand-eye"])
def test_a_camera_study_of_another_robot_is_refused_in_one_line(flag, capsys):
    """benchmark --images (or --hand-eye) --robots panda: one error line naming the robots studied, exit 2."""
    from calib_pin.cli.benchmark import benchmark_main

    assert benchmark_main([flag, "--robots", "irb120,panda"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == f"error: --robots: {flag} studies irb120 and ur5, not 'panda'"


def test_opencv_corners_without_images_is_refused_in_one_line(capsys):
    """benchmark --opencv-corners alone: one error line saying it needs --images, exit 2."""
    from calib_pin.cli.benchmark import benchmark_main

    assert benchmark_main(["--opencv-corners"]) == 2
    assert capsys.readouterr().err.strip() == "error: --opencv-corners: it chooses the corners of --images; give --images too"

"""A camera's intrinsics in OpenCV's and ROS's camera_info YAML: read, refused in one line, written back alike."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.sensors import CameraSetup, Intrinsics
from calib_pin.sensors.lens_file import intrinsics_argument, intrinsics_text, read_intrinsics

cv2 = pytest.importorskip("cv2")

LENS = Intrinsics(1000.0, 990.0, 641.5, 509.25, 1280, 1024, -0.08, 0.05, 0.0005, -0.0003, 0.002)

ROS = """image_width: 1280
image_height: 1024
camera_name: wrist_camera
camera_matrix:
  rows: 3
  cols: 3
  data: [1000, 0, 641.5, 0, 990, 509.25, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.08, 0.05, 0.0005, -0.0003, 0.002]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [1000, 0, 641.5, 0, 0, 990, 509.25, 0, 0, 0, 1, 0]
"""


def _opencv_file(path, k: Intrinsics = LENS, distortion=None) -> None:
    """An OpenCV camera file as cv2.FileStorage writes it."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", k.width)
    fs.write("image_height", k.height)
    fs.write("camera_matrix", k.matrix())
    fs.write("distortion_coefficients", k.distortion().reshape(-1, 1) if distortion is None else distortion)
    fs.release()


def test_an_opencv_file_and_a_ros_camera_info_file_read_as_the_same_lens(tmp_path):
    """cv2.FileStorage's file (its old '%YAML:1.0' header too) and ROS's camera_info give the same intrinsics,
    each remembering its layout and ROS's camera name."""
    _opencv_file(tmp_path / "cv.yaml")
    (tmp_path / "old.yaml").write_text((tmp_path / "cv.yaml").read_text().replace("%YAML 1.2", "%YAML:1.0", 1))
    (tmp_path / "ros.yaml").write_text(ROS)
    for name, fmt in (("cv.yaml", "opencv"), ("old.yaml", "opencv"), ("ros.yaml", "ros")):
        k = read_intrinsics(tmp_path / name)
        assert k == LENS, name
        assert k.source.format == fmt
    assert read_intrinsics(tmp_path / "ros.yaml").source.camera_name == "wrist_camera"


def test_more_opencv_coefficients_are_taken_when_the_extra_terms_are_zero(tmp_path):
    """OpenCV's 8 coefficients with k4 = k5 = k6 = 0 are the plumb bob; 4 coefficients leave k3 zero."""
    _opencv_file(tmp_path / "eight.yaml", distortion=np.r_[LENS.distortion(), 0, 0, 0])
    assert read_intrinsics(tmp_path / "eight.yaml") == LENS
    _opencv_file(tmp_path / "four.yaml", distortion=LENS.distortion()[:4])
    assert read_intrinsics(tmp_path / "four.yaml").k3 == 0.0


@pytest.mark.parametrize("fmt", ["opencv", "ros"])
def test_written_intrinsics_read_back_exactly_and_opencv_reads_them(tmp_path, fmt):
    """intrinsics_text's file reads back to the same numbers, by calib-pin and (OpenCV's layout) by cv2.FileStorage;
    ROS's projection matrix is OpenCV's optimal new camera matrix at alpha 0."""
    path = tmp_path / "k.yaml"
    path.write_text(intrinsics_text(LENS, fmt, "wrist_camera", ["a note"]))
    assert read_intrinsics(path) == LENS and read_intrinsics(path).source.format == fmt
    assert path.read_text().splitlines()[0 if fmt == "ros" else 2] == "# a note"
    if fmt == "opencv":
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
        np.testing.assert_array_equal(fs.getNode("camera_matrix").mat(), LENS.matrix())
        np.testing.assert_array_equal(fs.getNode("distortion_coefficients").mat().ravel(), LENS.distortion())
        assert fs.getNode("image_width").real() == 1280
    else:
        import yaml

        doc = yaml.safe_load(path.read_text())
        new = cv2.getOptimalNewCameraMatrix(LENS.matrix(), LENS.distortion(), (1280, 1024), 0.0)[0]
        np.testing.assert_allclose(np.reshape(doc["projection_matrix"]["data"], (3, 4))[:, :3], new)
        assert doc["camera_name"] == "wrist_camera" and doc["distortion_model"] == "plumb_bob"


def _swap(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new)


@pytest.mark.parametrize(("content", "fragment"), [
    (_swap(ROS, "image_height: 1024\n", ""), "k.yaml: image_height: missing (a ROS camera_info file has"),
    (_swap(ROS, "distortion_model: plumb_bob\n", ""), "k.yaml: distortion_model: missing"),
    (_swap(ROS, "plumb_bob", "equidistant"), "k.yaml:8: distortion_model: 'equidistant' is not a distortion model"),
    (_swap(ROS, "  data: [1000, 0, 641.5, 0, 990, 509.25, 0, 0, 1]", "  data: [1000, 0, 641.5, 0, 990, 509.25]"),
     "k.yaml:4: camera_matrix: rows 3 x cols 3 is not the 6 numbers of its data"),
    (_swap(ROS, "  rows: 3\n  cols: 3\n  data: [1000", "  rows: 2\n  cols: 3\n  data: [1000").replace(
        "990, 509.25, 0, 0, 1]", "990, 509.25]", 1), "k.yaml:4: camera_matrix: expected a 3x3 matrix, got 2x3"),
    (_swap(ROS, "data: [1000, 0, 641.5,", "data: [1000, 5, 641.5,"), "camera_matrix: not a pinhole camera matrix"),
    (_swap(ROS, "data: [-0.08, 0.05, 0.0005, -0.0003, 0.002]", "data: [-0.08, 0.05, 0.0005]"),
     "k.yaml:9: distortion_coefficients: rows 1 x cols 5 is not the 3 numbers"),
    (_swap(ROS, "image_width: 1280", "image_width: 1280.5"), "k.yaml:1: image_width: expected a whole number of pixels"),
    (_swap(ROS, "camera_matrix:\n  rows", "camera_matrix: [\n  rows"), "k.yaml:6: not valid YAML: expected"),
    ("- 1\n- 2\n", "k.yaml: not a camera file: expected keys"),
])
def test_a_bad_lens_file_is_one_line_naming_the_file_and_key(tmp_path, content, fragment):
    """A missing key, an unknown distortion model, a matrix of the wrong shape, a skewed camera, not YAML."""
    (tmp_path / "k.yaml").write_text(content)
    with pytest.raises(cp.DataError) as e:
        read_intrinsics(tmp_path / "k.yaml")
    assert fragment in str(e.value).replace(str(tmp_path) + "/", "")


def test_opencv_distortion_beyond_the_plumb_bob_is_refused(tmp_path):
    """k4 not zero: a rational lens, which calib-pin's is not: named."""
    _opencv_file(tmp_path / "k.yaml", distortion=np.r_[LENS.distortion(), 0.01, 0, 0])
    with pytest.raises(cp.DataError, match="distortion_coefficients: coefficients beyond k1, k2, p1, p2, k3 are not"):
        read_intrinsics(tmp_path / "k.yaml")


def test_the_intrinsics_option_takes_a_lens_file_or_the_numbers(tmp_path):
    """--intrinsics (and CameraSetup's intrinsics) read a .yaml/.yml file, else the numbers; a bad file is the
    argument's one line naming the file and key."""
    (tmp_path / "k.yml").write_text(ROS)
    assert CameraSetup(intrinsics=str(tmp_path / "k.yml")).intrinsics == LENS
    assert intrinsics_argument(LENS.spec()) == LENS and intrinsics_argument(LENS.spec()).source is None
    (tmp_path / "bad.yaml").write_text(ROS.replace("image_width: 1280\n", ""))
    with pytest.raises(argparse.ArgumentTypeError, match=r"bad.yaml: image_width: missing"):
        intrinsics_argument(str(tmp_path / "bad.yaml"))
    with pytest.raises(argparse.ArgumentTypeError, match=r"nothere.yaml: cannot read the camera's intrinsics"):
        intrinsics_argument(str(tmp_path / "nothere.yaml"))


def test_a_board_file_reads_as_its_spec(tmp_path):
    """--board board.yaml gives the board its spec text gives; a chessboard's file needs no marker."""
    from calib_pin.sensors.lens import board_spec
    from calib_pin.sensors.lens_file import board_argument, read_board

    path = tmp_path / "board.yaml"
    path.write_text("kind: charuco\ncolumns: 9\nrows: 7\nsquare_mm: 30\nmarker_mm: 22\ndictionary: DICT_4X4_50\n")
    assert read_board(path) == board_spec("charuco,9x7,30,22,DICT_4X4_50") == board_argument(str(path))
    path.write_text("kind: chessboard\ncolumns: 8\nrows: 6\nsquare_mm: 25.5\n")
    assert read_board(path) == board_spec("chessboard,8x6,25.5")

"""Starting from a robot's own kinematics (calibrate --nominal, calib_pin.calibration.start):
a UR default_kinematics.yaml (read back by calib_pin.export.yaml.read_ur_kinematics_yaml)
or a calib-pin calibration file; checked against the simulator's truth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.calibration.record import write_calibration
from calib_pin.calibration.start import load_start
from calib_pin.cli import command
from calib_pin.export.calibration_file import calibration_path
from calib_pin.export.yaml import write_ur_kinematics_yaml
from calib_pin.measurements.pose_list import read_pose_list
from calib_pin.robot.kinematics import Kinematics
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import CableModel

ROOT = Path(__file__).resolve().parents[1]
WU = str(ROOT / "robots" / "irb120_wu2015.csv")


@pytest.fixture(scope="module")
def ur5():
    chain = cp.load_chain("ur5")
    params = cp.parameter_model(chain)
    data, truth = cp.simulate(chain, params, 60, seed=2, noise_mm=0.02)
    return chain, params, data, truth


def _fk(chain, params, x, q):
    kin = Kinematics(chain)
    kin.set_perturbation(params.delta_matrices(x))
    return kin.frames(q)


def _fresh_rmse_mm(result, chain, params, truth) -> float:
    q = random_poses(chain, 300, np.random.default_rng(8))
    true = CableModel(chain, params, truth.sensor).predict(truth.x, q)
    return float(np.sqrt(np.mean((result.predict(q) - true) ** 2)) * 1e3)


def test_ur5_from_a_perturbed_factory_calibration(ur5, tmp_path):
    """Issue 25: a UR5 calibrated from a perturbed start (its default_kinematics.yaml: the
    truth off by ~0.2 mm / 0.4 mrad per parameter) reaches the fresh-pose error of the
    catalogue start; the blind directions keep the start's values, and 'before' is the
    start's error."""
    chain, params, data, truth = ur5
    rng = np.random.default_rng(3)
    factory = truth.x + rng.normal(0.0, 1.0, len(truth.x)) * np.where(
        np.array([u == "m" for u in params.units]), 2e-4, 4e-4)
    path = tmp_path / "default_kinematics.yaml"
    write_ur_kinematics_yaml(chain, params.deltas(factory), path)
    catalogue = cp.calibrate("ur5", data, method="lm", test_fraction=0)
    started = cp.calibrate("ur5", data, method="lm", test_fraction=0, nominal=str(path))
    e_catalogue = _fresh_rmse_mm(catalogue, chain, params, truth)
    e_started = _fresh_rmse_mm(started, chain, params, truth)
    assert e_catalogue < 0.05 and abs(e_started - e_catalogue) < 1e-3, (e_catalogue, e_started)
    assert started.start.kind == "ur-kinematics-yaml" and started.start.fit_m < 1e-12
    before = started.metrics["train"]["before"].rmse_mm
    assert started.metrics["train"]["after"].rmse_mm < before < catalogue.metrics["train"]["before"].rmse_mm  # the start is nearer than the catalogue
    assert not np.allclose(started.x[:len(params.names)], catalogue.x[:len(params.names)], atol=1e-6)


def test_yaml_round_trip_reproduces_the_calibrated_kinematics(ur5, tmp_path, capsys):
    """Issue 25: --export yaml, then --nominal of that file: the start's forward
    kinematics is the calibrated one to 1e-9 m (and 1e-8 rad); the report names the start."""
    chain, params, data, _ = ur5
    sim = tmp_path / "ur5.csv"
    cp.write_measurements(sim, data)
    calibrate = command("calibrate")
    out = tmp_path / "out"
    assert calibrate(["ur5", "--data", str(sim), "--method", "lm", "--export", "urdf,yaml", "--no-html",
                      "--out", str(out)]) == 0
    calibrated = cp.load_calibration(out)
    start = load_start(out / "ur5_default_kinematics.yaml", chain, params)
    q = random_poses(chain, 200, np.random.default_rng(4))
    rot_a, trans_a, _ = _fk(chain, params, calibrated.deviations, q)
    rot_b, trans_b, _ = _fk(chain, params, start.robot_x, q)
    assert np.abs(trans_a - trans_b).max() < 1e-9 and np.abs(rot_a - rot_b).max() < 1e-8
    capsys.readouterr()
    again = tmp_path / "again"
    assert calibrate(["ur5", "--data", str(sim), "--method", "lm", "--no-html", "--nominal",
                      str(out / "ur5_default_kinematics.yaml"), "--out", str(again)]) == 0
    assert "start: ur5_default_kinematics.yaml (UR default_kinematics.yaml" in capsys.readouterr().out
    report = json.loads((again / "report.json").read_text())
    assert report["start"]["kind"] == "ur-kinematics-yaml"
    moved = np.abs(list(report["start"]["deviations_from_start"].values())).max()
    assert moved < 0.05  # mm / deg: the start was this calibration already


def test_start_from_a_calibration_file_and_bad_starts(tmp_path, capsys):
    """A calib-pin calibration file as the start: the same fit again (deviations from the
    start near zero), its compliances too; another model, robot or file refused in one line."""
    first = cp.calibrate("irb120", WU, method="lm", compliance="joint_2,joint_3")
    write_calibration(first, calibration_path(tmp_path, "irb120"))
    again = cp.calibrate("irb120", WU, method="lm", compliance="joint_2,joint_3",
                         nominal=str(calibration_path(tmp_path, "irb120")))
    assert again.start.kind == "calibration" and again.start.compliance is not None
    assert abs(again.metrics["test"]["after"].rmse_mm - first.metrics["test"]["after"].rmse_mm) < 1e-4
    assert abs(again.metrics["train"]["before"].rmse_mm - first.metrics["train"]["after"].rmse_mm) < 0.05
    held = cp.calibrate("irb120", WU, method="lm", fix="a_2", nominal=str(calibration_path(tmp_path, "irb120")))
    i = held.problem.model.names.index("a_2")
    assert held.x[i] == first.x[i] != 0.0  # --fix holds the start's value
    calibrate = command("calibrate")
    (tmp_path / "bad.yaml").write_text("kinematics:\n  shoulder: {x: 0, y: 0}\n")
    for argv, message in ((["--model", "placement"], "deviations of the dh model; give --model dh"),
                          ([], "no such start file"), ([], "kinematics.shoulder needs numbers")):
        start = {"no such start file": str(tmp_path / "none.json"),
                 "kinematics.shoulder needs numbers": str(tmp_path / "bad.yaml")}.get(
            message, str(calibration_path(tmp_path, "irb120")))
        assert calibrate(["irb120", "--data", WU, "--nominal", start, *argv, "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and message in err, err


def test_compensate_against_the_robots_own_model(chain, params, tmp_path, capsys):
    """compensate --nominal: the targets are poses of the controller's own model. A rigid
    arm whose own model is its calibration needs no correction; a deflecting one only its
    sag, and the commands put it on the own model's poses."""
    x = np.random.default_rng(6).normal(0.0, 1.0, len(params.names)) * 2e-4
    arm = cp.CalibratedRobot(chain, params, x)
    q = random_poses(chain, 6, np.random.default_rng(7))
    q = q[np.abs(q[:, 4]) > 0.3]
    arm.set_reference(x)
    assert np.abs(arm.solve(q).q - q).max() < 1e-9
    first = cp.calibrate("irb120", WU, method="lm", compliance="joint_2,joint_3")
    path = write_calibration(first, calibration_path(tmp_path, "irb120"))
    program = ROOT / "robots" / "irb120_program.csv"
    compensate = command("compensate")
    assert compensate(["irb120", "--calibration", str(path), "--targets", str(program), "--out",
                       str(tmp_path / "own.csv"), "--nominal", str(path)]) == 0
    assert "targets: poses of the model irb120_calibration.json (calib-pin calibration file)" in capsys.readouterr().out
    robot = cp.load_calibration(path)
    own = read_pose_list(tmp_path / "own.csv", chain).q
    targets = read_pose_list(program, chain).q
    robot.set_reference(robot.deviations)
    for command_q, target in zip(own, targets, strict=True):
        assert np.linalg.norm(robot.forward(command_q).translation - robot.nominal(target).translation) < 1e-6
    assert 1e-4 < np.rad2deg(np.abs(own - targets)).max() < 1.0  # the sag only, not the 2 deg of geometry


def test_a_calibrate_output_folder_is_a_start(tmp_path, capsys):
    """--nominal takes the calibrate --out folder as compensate --calibration does (its
    calibration file); a folder without one is refused saying what to give, and that folder
    as --out is refused: its calibration file is an input."""
    calibrate = command("calibrate")
    first = tmp_path / "first"
    assert calibrate(["irb120", "--data", WU, "--method", "lm", "--no-html", "--out", str(first)]) == 0
    assert calibrate(["irb120", "--data", WU, "--method", "lm", "--no-html", "--nominal", str(first),
                      "--out", str(tmp_path / "again")]) == 0
    assert "start: irb120_calibration.json (calib-pin calibration file)" in capsys.readouterr().out
    report = json.loads((tmp_path / "again" / "report.json").read_text())
    assert report["start"]["source"] == str(first / "irb120_calibration.json")
    (tmp_path / "empty").mkdir()
    for folder, message in ((tmp_path / "empty", "empty: no *_calibration.json in this folder (--nominal: a calibrate "
                                                 "output folder, a calib-pin calibration .json or a UR"),
                            (first, "irb120_calibration.json is an input of this command (--nominal)")):
        code = calibrate(["irb120", "--data", WU, "--method", "lm", "--no-html", "--nominal", str(folder),
                          "--out", str(first)])
        err = capsys.readouterr().err
        assert code == 2 and len(err.strip().splitlines()) == 1 and message in err, err
    assert load_start(first, cp.load_chain("irb120"), cp.parameter_model(cp.load_chain("irb120"))).kind == "calibration"

"""Compensation: commands that put the calibrated (deflecting) arm's end frame on the
nominal targets, checked against a simulated true arm; its failures; the CLI."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.calibration.record import write_calibration
from calib_pin.cli import command
from calib_pin.export.calibration_file import calibration_path
from calib_pin.export.compensation import CalibratedRobot
from calib_pin.measurements import write_measurements
from calib_pin.measurements.csv_writer import write_poses
from calib_pin.measurements.pose_list import read_pose_list
from calib_pin.robot.deflection import ComplianceSpec
from calib_pin.robot.poses import random_poses

ROOT = Path(__file__).resolve().parents[1]
SPEC = ComplianceSpec(("joint_2", "joint_3"))
TRUE_C = np.array([2.5e-5, 4e-5])


def _regular_targets(chain, n: int, seed: int) -> np.ndarray:
    """Random targets away from the IRB120's wrist (q5 = 0) and elbow (q3 = -77 deg)
    singularities, where small end-frame corrections need small joint corrections."""
    q = random_poses(chain, 8 * n, np.random.default_rng(seed))
    deg = np.rad2deg(q)
    return q[(np.abs(deg[:, 4]) > 20) & ((deg[:, 2] < -100) | (deg[:, 2] > -55))][:n]


@pytest.fixture(scope="module")
def calibrated(chain, params, tmp_path_factory):
    """A drawstring set (anchor and tool known) from a true arm with compliant joints 2, 3,
    calibrated by LM with compliance, written and read back."""
    data, truth = cp.simulate(chain, params, 150, seed=9, compliance=SPEC, true_compliance=TRUE_C)
    result = cp.calibrate("irb120", data, method="lm", compliance=SPEC.joints, test_fraction=0)
    folder = tmp_path_factory.mktemp("calibration")
    write_calibration(result, calibration_path(folder, "irb120"))
    return cp.load_calibration(folder), truth, folder


def _pose_error(a: pin.SE3, b: pin.SE3) -> tuple[float, float]:
    return float(np.linalg.norm(a.translation - b.translation)), float(np.linalg.norm(pin.log3(a.rotation.T @ b.rotation)))


def test_compensated_true_arm_reaches_nominal_targets(calibrated, chain, params):
    """The calibrated arm at the commands is on the nominal targets to 1 um / 1 urad; the
    TRUE arm there misses them only by the calibration's own error (tens of um), against
    about 3 mm without compensation."""
    robot, truth, _ = calibrated
    q = _regular_targets(chain, 40, 1)
    q_c = robot.compensate(q)
    assert q_c.shape == q.shape and np.abs(q_c - q).max() > 1e-4
    for real, target in zip(robot.forward(q_c), robot.nominal(q), strict=True):
        position, orientation = _pose_error(real, target)
        assert position < 1e-6 and orientation < 1e-6
    true_arm = CalibratedRobot(chain, params, truth.x, SPEC, TRUE_C)
    tool = truth.sensor.tool  # what the drawstring saw: the tool point

    def tool_at(arm, commands):
        return np.array([f.act(tool) for f in arm.forward(commands)])

    target = np.array([f.act(tool) for f in robot.nominal(q)])
    compensated = np.linalg.norm(tool_at(true_arm, q_c) - target, axis=1)
    uncompensated = np.linalg.norm(tool_at(true_arm, q) - target, axis=1)
    model_error = np.linalg.norm(tool_at(true_arm, q_c) - tool_at(robot, q_c), axis=1)
    assert np.abs(compensated - model_error).max() < 1e-6  # within what the calibration allows
    assert compensated.max() < 0.15e-3 and uncompensated.mean() > 2e-3
    assert compensated.mean() < 0.05 * uncompensated.mean()


def test_deflection_is_compensated(chain, params):
    """A rigid-geometry arm that only sags: the commands lift it back onto the targets,
    and leaving the deflection out of the model would leave the sag."""
    arm = CalibratedRobot(chain, params, np.zeros(len(params.names)), SPEC, np.array([6.6e-5, 2.9e-4]))
    q = _regular_targets(chain, 20, 2)
    q_c = arm.compensate(q)
    sag = [_pose_error(a, b)[0] for a, b in zip(arm.forward(q), arm.nominal(q), strict=True)]
    left = [_pose_error(a, b)[0] for a, b in zip(arm.forward(q_c), arm.nominal(q), strict=True)]
    assert max(sag) > 5e-4 and max(left) < 1e-6
    assert np.allclose(arm.compensate(q[0]), q_c[0], atol=1e-9)  # one target: shape (n_joints,)


def test_joint_limit_and_unreachable_targets(chain, params):
    """A target at a joint limit whose 6-D solution lies beyond it: the joint is held at
    the limit and the position met by the others (position-only); a target the shorter
    real arm cannot reach: refused, and it does not stop the next target."""
    x = np.zeros(len(params.names))
    x[params.names.index("theta_1")] = 0.01  # the real joint 1 sits 10 mrad off
    arm = CalibratedRobot(chain, params, x)
    q = _regular_targets(chain, 1, 3)[0]
    shift = arm.compensate(q)[0] - q[0]
    assert abs(abs(shift) - 0.01) < 1e-6
    q[0] = chain.upper[0] if shift > 0 else chain.lower[0]
    result = arm.solve(q)
    assert result.status == ("position-only",) and "joint_1 held at its limit" in result.reasons[0]
    assert chain.lower[0] - 1e-12 <= result.q[0, 0] <= chain.upper[0] + 1e-12
    real, target = arm.forward(result.q[0]), arm.nominal(q)
    assert _pose_error(real, target)[0] < 1e-6 and abs(_pose_error(real, target)[1] - result.orientation_error_rad[0]) < 1e-12
    assert result.orientation_error_rad[0] > 1e-4  # the limit costs orientation, and it is reported
    with pytest.raises(cp.CalibPinError, match="target 1: position-only: joint_1 held at its limit"):
        arm.compensate(q)
    assert np.allclose(arm.compensate(q, position_only=True), result.q[0])
    x = np.zeros(len(params.names))
    x[params.names.index("a_2")] = -0.005  # 5 mm shorter upper arm: no longer reaches stretched poses
    short = CalibratedRobot(chain, params, x)
    # stretched with the flange along the forearm (q5 = 0): the farthest the arm reaches, now out of
    # reach; stretched with the wrist bent (q5 = 40 deg): the flange still reaches it, the wrist
    # bending about 5 deg further (position-only; it was refused as out of reach before the
    # trust-region fallback of the position-first solve)
    stretched = np.deg2rad([[0.0, 30.0, -77.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 40.0, 0.0],
                            [0.0, 30.0, -77.0, 0.0, 40.0, 0.0]])
    result = short.solve(stretched)
    assert result.status == ("refused", "ok", "position-only")
    assert result.position_error_m[2] < 1e-6 and np.abs(result.q[2] - stretched[2]).max() < np.deg2rad(6.0)
    assert _pose_error(short.forward(result.q[2]), short.nominal(stretched[2]))[0] < 1e-6
    stretched = stretched[:2]
    assert result.reasons[0].startswith("out of reach") and result.position_error_m[0] > 1e-4
    assert result.problems == (result.reasons[0], "", "")
    with pytest.raises(cp.CalibPinError, match="target 1: refused: out of reach"):
        short.compensate(stretched)


@pytest.fixture(scope="module")
def wu_calibrated(tmp_path_factory):
    """The real Wu set calibrated by LM with the compliance of joints 2 and 3, written and read back."""
    result = cp.calibrate("irb120", str(ROOT / "robots" / "irb120_wu2015.csv"), method="lm",
                          compliance="joint_2,joint_3")
    folder = tmp_path_factory.mktemp("wu")
    write_calibration(result, calibration_path(folder, "irb120"))
    return folder


def _wu_targets(chain) -> np.ndarray:
    """The 120 shipped IRB120 poses and 40 random targets within 60 % of the joint ranges,
    15 of them with q5 within +-2 deg of 0 (the wrist singularity)."""
    shipped = read_pose_list(ROOT / "robots" / "irb120_default.csv", chain).q
    rng = np.random.default_rng(25)
    middle, half = (chain.lower + chain.upper) / 2, 0.6 * (chain.upper - chain.lower) / 2
    random = middle + half * rng.uniform(-1.0, 1.0, (40, 6))
    random[:15, 4] = np.deg2rad(rng.uniform(-2.0, 2.0, 15))
    return np.vstack([shipped, random])


def test_every_target_of_a_real_calibration_is_compensated(wu_calibrated, chain):
    """Issue 25: after the Wu calibration with compliance, every shipped pose and every
    random target (wrist-singular ones included) is ok or position-only; the calibrated arm
    (load_calibration(...).forward) at the commands is within 2 um of the nominal target
    position (Pinocchio on the nominal URDF), ok rows within 2 urad in orientation too;
    every command within the URDF limits."""
    robot = cp.load_calibration(wu_calibrated)
    q = _wu_targets(chain)
    result = robot.solve(q)
    assert set(result.status) <= {"ok", "position-only"}
    assert result.status.count("ok") > 140 and result.status.count("position-only") >= 3
    model = pin.buildModelFromUrdf(str(ROOT / "robots" / "irb120.urdf"))
    data, frame = model.createData(), model.getFrameId("tool0")
    for k, status in enumerate(result.status):
        pin.framesForwardKinematics(model, data, q[k])
        target = data.oMf[frame]
        real = robot.forward(result.q[k])
        position, orientation = _pose_error(real, target)
        assert position < 2e-6, (k, position)
        if status == "ok":
            assert orientation < 2e-6, (k, orientation)
        else:
            assert abs(orientation - result.orientation_error_rad[k]) < 1e-9
            assert "position met" in result.reasons[k]
    assert np.all(result.q >= chain.lower - 1e-12) and np.all(result.q <= chain.upper + 1e-12)
    wrist = np.abs(np.rad2deg(q[:, 4])) < 2.0
    assert wrist.sum() >= 15  # the wrist-singular targets are among them, and none refused


def _check_at_the_commands(robot, urdf, q, result) -> None:
    """The calibrated arm (load_calibration(...).forward) at the commands against Pinocchio on
    the nominal URDF: within 2 um of the target position, ok rows within 2 urad in orientation
    too; every command within the URDF limits."""
    model = pin.buildModelFromUrdf(str(urdf))
    data, frame = model.createData(), model.getFrameId("tool0")
    for k, status in enumerate(result.status):
        pin.framesForwardKinematics(model, data, q[k])
        position, orientation = _pose_error(robot.forward(result.q[k]), data.oMf[frame])
        assert position < 2e-6, (k, position)
        assert orientation < 2e-6 if status == "ok" else abs(orientation - result.orientation_error_rad[k]) < 1e-9
    assert np.all(result.q >= robot.chain.lower - 1e-12) and np.all(result.q <= robot.chain.upper + 1e-12)


def test_every_target_of_a_basis_model_calibration_is_compensated(tmp_path_factory):
    """The Wu set calibrated with --compliance joint_2,joint_3 on the IRB120 URDF without its
    inertias (the gravity basis model, the placement parameter model): the same 160 targets
    as for the CAD model are all ok or position-only, checked at the commands against
    Pinocchio on that nominal URDF. (Before, stage 1's Levenberg-Marquardt never retried a
    rejected step and the position-first solve crawled near the stretched elbow: 4 shipped
    poses were refused as out of reach, 30-160 um off, though a command within 2 deg of them
    meets them.)"""
    from test_gravity_basis import strip_inertias

    folder = tmp_path_factory.mktemp("basis")
    bare = strip_inertias(ROOT / "robots" / "irb120.urdf", folder, "irb120")
    result = cp.calibrate(str(bare), str(ROOT / "robots" / "irb120_wu2015.csv"), method="lm",
                          compliance="joint_2,joint_3")
    write_calibration(result, calibration_path(folder, "irb120"))
    robot = cp.load_calibration(folder)
    assert robot.compliance_spec.model == "basis" and robot.params.name == "placement"
    q = _wu_targets(robot.chain)
    solved = robot.solve(q)
    assert set(solved.status) <= {"ok", "position-only"}, [r for r in solved.reasons if r.startswith(("out", "joint"))]
    assert solved.status.count("ok") > 130
    _check_at_the_commands(robot, bare, q, solved)


def _shoulder_singular_targets(chain, n: int, seed: int) -> np.ndarray:
    """Targets with the wrist centre (joint_5's origin) within 3 mm of axis 1, q5 away from 0."""
    model = chain.model
    data, wrist = model.createData(), model.getJointId("joint_5")
    rng = np.random.default_rng(seed)
    found = []
    while len(found) < n:
        q = rng.uniform(0.6 * chain.lower, 0.6 * chain.upper)
        for _ in range(20):  # Gauss-Newton on q2, q3: the wrist centre onto axis 1
            pin.computeJointJacobians(model, data, q)
            xy = data.oMi[wrist].translation[:2]
            jac = pin.getJointJacobian(model, data, wrist, pin.LOCAL_WORLD_ALIGNED)[:2, 1:3]
            q[1:3] -= np.linalg.lstsq(jac, xy, rcond=None)[0]
        pin.forwardKinematics(model, data, q)
        radius = np.linalg.norm(data.oMi[wrist].translation[:2])
        if radius < 3e-3 and np.all((q > chain.lower) & (q < chain.upper)) and abs(q[4]) > np.deg2rad(10):
            found.append(q)
    return np.array(found)


def test_shoulder_singular_targets_keep_joint_1_near_the_target(wu_calibrated, chain):
    """Wrist centre on axis 1 (the shoulder singularity): the position is met with small joint
    changes, and the orientation residual reported, instead of swinging joint_1 (and the upper
    arm and forearm with it) to the 10 deg bound for tens of mrad of orientation, as the
    position-first solve did when a joint's change cost 1e-4 of its orientation gain. A
    position-only row names its largest joint change."""
    robot = cp.load_calibration(wu_calibrated)
    q = _shoulder_singular_targets(chain, 10, 3)
    solved = robot.solve(q)
    assert set(solved.status) <= {"ok", "position-only"} and solved.status.count("position-only") >= 5
    _check_at_the_commands(robot, ROOT / "robots" / "irb120.urdf", q, solved)
    position_only = np.array([s == "position-only" for s in solved.status])
    change = np.rad2deg(np.abs(solved.q - q))[position_only]
    assert change[:, :3].max() < 3.0 and change.max() < 5.0, change.max(axis=0)  # was 10 deg (joint_1, 4, 6)
    assert np.all(solved.orientation_error_rad[position_only] < 0.1)
    for reason, row in zip(np.array(solved.reasons)[position_only], change, strict=True):
        joint = chain.joint_names[int(np.argmax(row))]
        assert re.search(rf"largest joint change {joint} [-+][0-9.]+ deg", reason), reason


def test_cli(calibrated, chain, tmp_path, capsys):
    robot, _, folder = calibrated
    q = _regular_targets(chain, 6, 4)
    program = tmp_path / "program.csv"
    write_poses(program, q, robot="irb120")
    out = tmp_path / "corrected.csv"
    compensate = command("compensate")
    assert compensate(["irb120", "--calibration", str(folder), "--targets", str(program), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "6 targets compensated" in text and "remaining: position" in text
    corrected = read_pose_list(out, chain)  # the same columns: a pose list again
    assert np.abs(corrected.q - robot.compensate(q)).max() < 1e-9
    assert corrected.notes.get("compensated", "").startswith("irb120_calibration.json")
    header = [line for line in out.read_text().splitlines() if line.startswith("pose")][0]
    assert header.endswith("q6_deg,status,position_error_mm,orientation_error_urad")
    # a measurement set works as a program too (its angle columns)
    write_measurements(tmp_path / "set.csv", cp.simulate(chain, cp.parameter_model(chain), 0, seed=1, poses=q)[0])
    assert compensate(["irb120", "--calibration", str(folder), "--targets", str(tmp_path / "set.csv"),
                       "--out", str(tmp_path / "c2.csv")]) == 0
    assert np.allclose(read_pose_list(tmp_path / "c2.csv", chain).q, corrected.q, atol=1e-12)
    capsys.readouterr()
    for argv, message in (
        (["irb120", "--calibration", str(tmp_path / "none"), "--targets", str(program)], "no such calibration file"),
        (["ur5", "--calibration", str(folder), "--targets", str(program)], "not 'ur5'"),
    ):
        assert compensate([*argv, "--out", str(tmp_path / "bad.csv")]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1
        assert re.search(message, err), err
    assert not (tmp_path / "bad.csv").exists()


def test_cli_refuses_its_own_output_as_targets(calibrated, chain, tmp_path, capsys):
    """compensate's output (its '# compensated:' line) given back as targets was corrected a
    second time, exit 0: refused naming the file and that line; nothing written."""
    _, _, folder = calibrated
    program, once = tmp_path / "program.csv", tmp_path / "once.csv"
    write_poses(program, _regular_targets(chain, 4, 5), robot="irb120")
    compensate = command("compensate")
    assert compensate(["irb120", "--calibration", str(folder), "--targets", str(program), "--out", str(once)]) == 0
    line = next(k for k, text in enumerate(once.read_text().splitlines(), 1) if text.startswith("# compensated:"))
    capsys.readouterr()
    assert compensate(["irb120", "--calibration", str(folder), "--targets", str(once),
                       "--out", str(tmp_path / "twice.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"once.csv:{line}: compensated: 'irb120_calibration.json" in err[0]
    assert "these targets are compensate's own output, already corrected" in err[0]
    assert not (tmp_path / "twice.csv").exists()


def test_cli_status_per_target_and_exit_codes(calibrated, chain, tmp_path, capsys):
    """A target held at a joint limit is written position-only (exit 3); a target the
    arm cannot reach is refused, named in the output and left out, and the others are
    still written (exit 4)."""
    robot, _, folder = calibrated
    q = _regular_targets(chain, 4, 4)
    q[2, 0] = chain.upper[0] if robot.compensate(q[2])[0] > q[2, 0] else chain.lower[0]
    program = tmp_path / "program.csv"
    write_poses(program, q, robot="irb120")
    compensate = command("compensate")
    out = tmp_path / "corrected.csv"
    assert compensate(["irb120", "--calibration", str(folder), "--targets", str(program), "--out", str(out)]) == 3
    text = capsys.readouterr().out
    assert "status: 3 ok, 1 position-only, 0 refused" in text
    assert re.search(r"pose 3 \(line 5\): position-only: joint_1 held at its limit", text)
    corrected = read_pose_list(out, chain)
    assert len(corrected) == 4 and np.all(np.abs(corrected.q[:, 0]) <= chain.upper[0] + 1e-9)
    rows = [line.split(",") for line in out.read_text().splitlines() if line[:1].isdigit()]
    assert [r[7] for r in rows] == ["ok", "ok", "position-only", "ok"]
    # a 5 mm shorter upper arm cannot reach a stretched pose
    doc = json.loads(calibration_path(folder, "irb120").read_text())
    doc["deviations_si"]["a_2"], doc["deviations"]["a_2_mm"] = -0.005, -5.0
    short = tmp_path / "short" / "irb120_calibration.json"
    short.parent.mkdir()
    short.write_text(json.dumps(doc))
    q[2] = np.deg2rad([0.0, 30.0, -77.0, 0.0, 0.0, 0.0])
    write_poses(program, q, robot="irb120")
    for fmt, name in (("csv", "c.csv"), ("rapid", "c.mod")):
        assert compensate(["irb120", "--calibration", str(short), "--targets", str(program), "--out",
                           str(tmp_path / name), "--format", fmt]) == 4
        text = capsys.readouterr().out
        assert "0 position-only, 1 refused" in text and "pose 3 (line 5): refused: out of reach" in text
    corrected = read_pose_list(tmp_path / "c.csv", chain)
    np.testing.assert_array_equal(corrected.pose_ids, [1, 2, 4])
    assert corrected.notes["refused_pose_3"].startswith("pose 3 (line 5): out of reach")
    rapid = (tmp_path / "c.mod").read_text()
    assert "jt_3:=" not in rapid and "! refused pose 3 (line 5): out of reach" in rapid


def test_cli_keeps_the_programs_other_columns(calibrated, chain, tmp_path, capsys):
    """A robot program's speed, zone and name columns and its notes are copied to the
    compensated file as they were (they were dropped), and read back the same."""
    robot, _, folder = calibrated
    q = _regular_targets(chain, 3, 5)
    program = tmp_path / "program.csv"
    write_poses(program, q, robot="irb120", notes={"program": "pick and place"})
    lines = program.read_text().splitlines()
    head = next(k for k, line in enumerate(lines) if line.startswith("pose"))
    lines[head] += ",speed,name"
    for k, extra in enumerate(["100,home", ",\"pick, left\"", "25.5,place"], start=head + 1):
        lines[k] += "," + extra
    program.write_text("\n".join(lines) + "\n")
    out = tmp_path / "corrected.csv"
    assert command("compensate")(["irb120", "--calibration", str(folder), "--targets", str(program),
                                  "--out", str(out)]) == 0
    assert "note: columns speed, name of program.csv: copied to the output" in capsys.readouterr().err
    corrected = read_pose_list(out, chain)
    assert np.abs(corrected.q - robot.compensate(q)).max() < 1e-9
    np.testing.assert_array_equal(corrected.extra["speed"], [100.0, np.nan, 25.5])
    assert list(corrected.extra["name"]) == ["home", "pick, left", "place"]
    assert corrected.notes["program"] == "pick and place"

"""The Pinocchio chain: URDF matches the DH table, perturbations rebuild from nominal."""

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.parameters import dh_transforms
from calib_pin.robot.kinematics import cross_matrices
from calib_pin.robot.poses import random_poses


def test_irb120_chain(chain):
    """The IRB120 chain has joint_1..joint_6, tool0 at the wrist, ROS-I limits in rad."""
    assert chain.joint_names == tuple(f"joint_{i}" for i in range(1, 7))
    assert np.allclose(np.rad2deg(chain.upper), [165, 110, 70, 160, 120, 400])
    assert np.allclose(np.rad2deg(chain.lower), [-165, -110, -110, -160, -120, -400])
    data = chain.model.createData()
    pin.framesForwardKinematics(chain.model, data, np.zeros(6))
    tool0 = data.oMf[chain.frame_id]
    assert np.allclose(tool0.translation, [0.374, 0.0, 0.630], atol=1e-12)
    assert np.allclose(tool0.rotation[:, 2], [1, 0, 0], atol=1e-12)  # z out of the flange, along +x


def test_urdf_fk_equals_dh_chain(chain):
    """tool0 of the URDF equals DH frame 6 of the published table at random poses."""
    rng = np.random.default_rng(0)
    data = chain.model.createData()
    for q in random_poses(chain, 20, rng):
        pin.framesForwardKinematics(chain.model, data, q)
        dh6 = dh_transforms(chain.description.dh, q)[-1]
        assert np.allclose(data.oMf[chain.frame_id].homogeneous, dh6.homogeneous, atol=1e-12)


def test_zero_perturbation_reproduces_urdf(chain, params):
    """Zero deviation gives the URDF's FK to 1e-12 m."""
    q = random_poses(chain, 50, np.random.default_rng(1))
    kin = cp.Kinematics(chain)
    kin.set_perturbation(params.delta_matrices(np.zeros(params.n_params)))
    ours, _ = kin.points(q, np.zeros(3))
    data = chain.model.createData()
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(chain.model, data, qk)
        assert np.linalg.norm(ours[k] - data.oMf[chain.frame_id].translation) < 1e-12


def test_perturbation_is_rebuilt_not_accumulated(chain, params):
    """Setting the same perturbation twice, or after another, gives the same FK."""
    q = random_poses(chain, 5, np.random.default_rng(2))
    x = np.random.default_rng(3).normal(size=params.n_params) * params.scale
    kin = cp.Kinematics(chain)
    kin.set_perturbation(params.delta_matrices(x))
    first, _ = kin.points(q, np.zeros(3))
    kin.set_perturbation(params.delta_matrices(-x))
    kin.set_perturbation(params.delta_matrices(x))
    again, _ = kin.points(q, np.zeros(3))
    kin.set_perturbation(None)
    nominal, _ = kin.points(q, np.zeros(3))
    assert np.array_equal(first, again)
    assert np.abs(first - nominal).max() > 1e-4
    # The placements are written into the working copy only, never into the chain's model.
    fresh, _ = cp.Kinematics(chain).points(q, np.zeros(3))
    assert np.array_equal(fresh, nominal)


def test_perturbed_model_matches_kinematics(chain, params):
    """The standalone corrected pin.Model and the working FK path agree."""
    x = np.random.default_rng(4).normal(size=params.n_params) * params.scale
    q = random_poses(chain, 5, np.random.default_rng(5))
    kin = cp.Kinematics(chain)
    kin.set_perturbation(params.delta_matrices(x))
    ours, _ = kin.points(q, np.zeros(3))
    model = chain.perturbed_model(params.deltas(x))
    data = model.createData()
    fid = model.getFrameId("tool0")
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(model, data, qk)
        assert np.allclose(data.oMf[fid].translation, ours[k], atol=1e-12)


@pytest.mark.parametrize("robot, end, n", [("ur5", None, 6), ("panda", "panda_hand", 7)])
def test_other_robots_load_and_run_fk(robot, end, n):
    """example-robot-data arms load, reduce to their chain and run FK."""
    chain = cp.load_chain(robot, end)
    assert chain.n_joints == n
    q = random_poses(chain, 3, np.random.default_rng(0))
    points, _ = cp.Kinematics(chain).points(q, np.zeros(3))
    assert points.shape == (3, 3) and np.all(np.isfinite(points))


def test_missing_end_frame_is_named():
    """A robot without tool0 asks for --end-frame and lists frames."""
    with pytest.raises(cp.RobotError, match="no frame 'tool0'.*--end-frame.*panda_hand"):
        cp.load_chain("panda")
    with pytest.raises(cp.RobotError, match="no frame 'nosuch'"):
        cp.load_chain("irb120", "nosuch")


MIXED_URDF = """<?xml version="1.0"?>
<robot name="mixed">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/><link name="tool0"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3" rpy="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.1 0 0.2" rpy="0.2 0 0"/><axis xyz="0 0.6 0.8"/><limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="j3" type="continuous"><parent link="l2"/><child link="l3"/>
    <origin xyz="0 0.1 0.2" rpy="0 0.3 0"/><axis xyz="1 0 0"/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/>
    <origin xyz="0.2 0 0" rpy="0.1 0.2 0.3"/><axis xyz="0 2 2"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="jt" type="fixed"><parent link="l4"/><child link="tool0"/><origin xyz="0 0 0.1" rpy="0 0 0"/></joint>
</robot>
"""


SINGLE_URDF = """<?xml version="1.0"?>
<robot name="single"><link name="base"/><link name="l1"/><link name="tool0"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3" rpy="0.1 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="jt" type="fixed"><parent link="l1"/><child link="tool0"/><origin xyz="0.2 0 0.1"/></joint>
</robot>
"""

#: A side branch (joint js) that the chain to tool0 does not pass through.
BRANCH_URDF = """<?xml version="1.0"?>
<robot name="branch"><link name="base"/><link name="l1"/><link name="side"/><link name="tool0"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="js" type="revolute"><parent link="l1"/><child link="side"/><origin xyz="0 0.2 0"/>
    <axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="jt" type="fixed"><parent link="l1"/><child link="tool0"/><origin xyz="0 0 0.1"/></joint>
</robot>
"""


@pytest.mark.parametrize("robot", ["irb120", "ur5", "mixed", "single"])
def test_batched_positions_match_pinocchio(robot, tmp_path):
    """The batched positions equal Pinocchio's forward kinematics of the perturbed model
    to 1e-12 m, for revolute, prismatic, continuous and off-axis joints, one point or
    one point per pose; so do the positions of the derivative path."""
    if robot in ("mixed", "single"):
        (tmp_path / f"{robot}.urdf").write_text(MIXED_URDF if robot == "mixed" else SINGLE_URDF)
        robot = str(tmp_path / f"{robot}.urdf")
    chain = cp.load_chain(robot)
    if robot.endswith("mixed.urdf"):
        assert chain.joint_kinds == ("JointModelRZ", "JointModelPrismaticUnaligned", "JointModelRUBX",
                                     "JointModelRevoluteUnaligned")
    rng = np.random.default_rng(4)
    params = cp.parameter_model(chain, "placement")
    x = rng.normal(size=len(params.names)) * params.scale
    deltas = params.delta_matrices(x)
    model = chain.perturbed_model([pin.SE3(d) for d in deltas], full=False)
    data = model.createData()
    q = random_poses(chain, 20, rng)
    kin = cp.Kinematics(chain)
    kin.set_perturbation(deltas)
    points = rng.normal(size=(20, 3)) * 0.1
    one, _ = kin.points(q, points[0])
    each, _ = kin.points(q, points)
    each_d, d = kin.points(q, points, jacobian=True)
    assert d is not None
    for k, qk in enumerate(chain.configuration(q)):
        pin.framesForwardKinematics(model, data, qk)
        placement = data.oMf[chain.frame_id]
        assert np.abs(one[k] - placement.act(points[0])).max() < 1e-12
        assert np.abs(each[k] - placement.act(points[k])).max() < 1e-12
        assert np.abs(each_d[k] - placement.act(points[k])).max() < 1e-12


@pytest.mark.parametrize("robot", ["irb120", "mixed", "single"])
def test_point_derivatives_equal_the_per_pose_product(robot, tmp_path):
    """The derivative path (regressors copied per pose, the lever products batched) gives
    the numbers, to the bit, of the plain per-pose products: Pinocchio's FK, regressor and
    frame Jacobian per pose, the lever L = [R, -R [p]x] and [L @ regressor | L | L @ frame
    Jacobian]; for one point and one point per pose, with and without the joint columns,
    and for a one-joint chain (whose frame Jacobian Pinocchio returns as a vector)."""
    if robot != "irb120":
        (tmp_path / f"{robot}.urdf").write_text(MIXED_URDF if robot == "mixed" else SINGLE_URDF)
        robot = str(tmp_path / f"{robot}.urdf")
    chain = cp.load_chain(robot)
    rng = np.random.default_rng(6)
    params = cp.parameter_model(chain, "placement")
    deltas = params.delta_matrices(rng.normal(size=len(params.names)) * params.scale)
    model = chain.model.copy()  # placed as the FK path places it: nominal @ delta, in one batched product
    targets = [model.jointPlacements[j] for j in range(1, model.njoints)] + [model.frames[chain.frame_id].placement]
    placements = np.array([m.homogeneous for m in targets]) @ deltas
    for j, placement in enumerate(placements[:-1], start=1):
        model.jointPlacements[j] = pin.SE3(placement)
    model.frames[chain.frame_id].placement = pin.SE3(placements[-1])
    data = model.createData()
    q = random_poses(chain, 7, rng)
    kin = cp.Kinematics(chain)
    kin.set_perturbation(deltas)
    for point in (rng.normal(size=3) * 0.1, rng.normal(size=(7, 3)) * 0.1):
        for joints in (False, True):
            positions, d = kin.points(q, point, jacobian=True, joints=joints)
            assert d is not None
            for k, qk in enumerate(chain.configuration(q)):
                (pin.computeJointJacobians if joints else pin.forwardKinematics)(model, data, qk)
                regressor = pin.computeFrameKinematicRegressor(model, data, chain.frame_id, pin.LOCAL)
                rot = np.ascontiguousarray(data.oMf[chain.frame_id].rotation)  # row-major, as the path holds it
                p = point if point.ndim == 1 else point[k]
                lever = np.hstack([rot, rot @ cross_matrices(p)])
                parts = [lever @ regressor, lever]
                if joints:
                    parts.append(lever @ pin.getFrameJacobian(model, data, chain.frame_id, pin.LOCAL).reshape(6, -1))
                assert np.array_equal(d[k], np.hstack(parts))
                assert np.array_equal(positions[k], data.oMf[chain.frame_id].translation + rot @ p)


def test_positions_follow_joint_angles_changed_in_place(chain):
    """The batched path keeps the last poses' joint terms; changing the same array in
    place must not give the old poses' positions."""
    rng = np.random.default_rng(5)
    q = random_poses(chain, 4, rng)
    kin = cp.Kinematics(chain)
    before, _ = kin.points(q, np.zeros(3))
    q[:] = random_poses(chain, 4, rng)
    after, _ = kin.points(q, np.zeros(3))
    fresh, _ = cp.Kinematics(chain).points(q, np.zeros(3))
    assert np.array_equal(after, fresh)
    assert np.abs(after - before).max() > 1e-3


def test_side_branch_chain_perturbs_its_reduced_model(tmp_path):
    """A URDF with a joint off the chain: the reduced model (that joint locked) takes the
    end frame's correction like the full one."""
    (tmp_path / "branch.urdf").write_text(BRANCH_URDF)
    chain = cp.load_chain(str(tmp_path / "branch.urdf"))
    assert chain.joint_names == ("j1",)
    delta = pin.SE3(np.eye(3), np.array([0.001, 0.0, 0.0]))
    for full in (True, False):
        model = chain.perturbed_model([pin.SE3.Identity(), delta], full=full)
        source = chain.full_model if full else chain.model
        fid = source.getFrameId("tool0")
        assert np.allclose(model.frames[fid].placement.translation,
                           (source.frames[fid].placement * delta).translation, atol=1e-15)


def test_screw_joint_is_refused(chain):
    """A chain built by hand with a helical joint: its batched positions would be wrong,
    so Kinematics refuses it in one line."""
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelHelicalUnaligned(np.array([0.0, 0.0, 1.0]), 0.01),
                           pin.SE3.Identity(), "screw")
    model.addFrame(pin.Frame("tool0", joint, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    screw = dataclasses.replace(chain, model=model, frame_id=model.getFrameId("tool0"), joint_names=("screw",),
                                lower=np.array([-1.0]), upper=np.array([1.0]))
    with pytest.raises(cp.CalibPinError, match="joint 'screw' .* both turns and slides"):
        cp.Kinematics(screw)


def test_points_many_of_no_perturbation_is_empty(chain):
    """points_many with no perturbation (k = 0) gives shape (0, n_poses, 3), from a list or a stacked array."""
    q = random_poses(chain, 5, np.random.default_rng(8))
    kin = cp.Kinematics(chain)
    for deltas in ([], np.empty((0, chain.n_joints + 1, 4, 4))):
        many = kin.points_many(deltas, q, [])
        assert many.shape == (0, 5, 3) and many.dtype == float
    assert kin.points_many([], q[0], []).shape == (0, 1, 3)


def test_a_limit_margin_widens_the_revolute_joints_of_every_chain_of_the_robot(chain):
    """A description's limit_margin [rad] widens each revolute joint's limits both ways, in
    every chain loaded from it (another end frame too)."""
    wide = dataclasses.replace(chain.description, limit_margin=np.radians(2.0))
    for end in ("tool0", "link_6"):
        widened = cp.load_chain(wide, end)
        n = widened.n_joints
        np.testing.assert_allclose(widened.lower, chain.lower[:n] - np.radians(2.0))
        np.testing.assert_allclose(widened.upper, chain.upper[:n] + np.radians(2.0))

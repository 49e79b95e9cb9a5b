"""Export formats: each file, reloaded, reproduces the calibrated forward kinematics."""

import tomllib

import numpy as np
import pinocchio as pin
import pytest
import xacro
import yaml
from lxml import etree

from calib_pin import CalibPinError, Kinematics, load_chain, parameter_model
from calib_pin.export.dh import write_dh_table
from calib_pin.export.yaml import (
    UR_KEYS,
    joint_origins,
    ur_kinematics,
    write_joint_origins_yaml,
    write_ur_kinematics_yaml,
)
from calib_pin.parameters.dh import dh_transforms
from calib_pin.robot.description import _read_dh

XACRO_NS = "http://www.ros.org/wiki/xacro"
TOL = 1e-9


def _deviations(params, seed=3, size=2.0):
    """Seeded random deviations a few typical sizes large (mm, mrad)."""
    return np.random.default_rng(seed).normal(size=len(params.names)) * params.scale * size


def _poses(chain, n=25, seed=7):
    rng = np.random.default_rng(seed)
    lo, hi = np.maximum(chain.lower, -np.pi), np.minimum(chain.upper, np.pi)
    return rng.uniform(lo, hi, size=(n, chain.n_joints))


def _frames(model, config):
    data = model.createData()
    pin.framesForwardKinematics(model, data, config)
    return {model.frames[i].name: data.oMf[i].copy() for i in range(len(model.frames))}


def _gap(a: pin.SE3, b: pin.SE3) -> float:
    """Largest of the translation gap [m] and rotation-matrix entry gap."""
    return max(np.abs(a.translation - b.translation).max(), np.abs(a.rotation - b.rotation).max())


def _xacro_with_yaml(urdf, yaml_path, names, out):
    """The robot's URDF as a xacro whose listed joint origins come from the YAML."""
    root = etree.parse(str(urdf)).getroot()
    xroot = etree.Element("robot", nsmap={"xacro": XACRO_NS}, attrib=dict(root.attrib))
    xroot.append(etree.Element(f"{{{XACRO_NS}}}property", name="cal",
                               value=f"${{xacro.load_yaml('{yaml_path}')}}"))
    for child in root:
        if child.tag == "joint" and child.get("name") in names:
            n = child.get("name")
            origin = child.find("origin")
            if origin is None:
                origin = etree.SubElement(child, "origin")
            origin.set("xyz", " ".join(f"${{cal['{n}']['{k}']}}" for k in ("x", "y", "z")))
            origin.set("rpy", " ".join(f"${{cal['{n}']['{k}']}}" for k in ("roll", "pitch", "yaw")))
        xroot.append(child)
    out.write_bytes(etree.tostring(xroot))
    return pin.buildModelFromXML(xacro.process_file(str(out)).toxml())


@pytest.mark.parametrize(("robot", "model"), [("irb120", "dh"), ("irb120", "hayati"), ("ur5", "placement")])
def test_joint_yaml_through_xacro_reproduces_calibrated_fk(tmp_path, robot, model):
    chain = load_chain(robot)
    params = parameter_model(chain, model)
    deltas = params.deltas(_deviations(params))
    path = write_joint_origins_yaml(chain, deltas, tmp_path / "calibration.yaml")
    loaded = yaml.safe_load(path.read_text())  # xacro.load_yaml reads it in the xacro below
    names = list(loaded)
    assert names[: chain.n_joints] == list(chain.joint_names) and len(names) == chain.n_joints + 1
    assert set(loaded[names[0]].keys()) == {"x", "y", "z", "roll", "pitch", "yaw"}
    rebuilt = _xacro_with_yaml(chain.description.urdf, path, names, tmp_path / "robot.xacro")
    calibrated = chain.perturbed_model(deltas)
    nominal = chain.full_model
    worst = moved = 0.0
    for q in _poses(chain):
        config = chain.configuration(q)
        want, got, before = _frames(calibrated, config), _frames(rebuilt, config), _frames(nominal, config)
        worst = max(worst, *(_gap(want[name], got[name]) for name in want))
        moved = max(moved, _gap(want[chain.end_frame], before[chain.end_frame]))
    assert worst < TOL
    assert moved > 1e-4  # the deviations are real: the rebuilt robot is not the nominal one


def test_yaml_origins_are_the_urdf_exports(tmp_path):
    """One convention: the YAML holds exactly the origins the corrected URDF gets."""
    from calib_pin.export.urdf import origin_of, write_calibrated_urdf

    chain = load_chain("irb120")
    params = parameter_model(chain, "dh")
    deltas = params.deltas(_deviations(params, seed=11))
    urdf = etree.parse(str(write_calibrated_urdf(chain, deltas, tmp_path / "c.urdf"))).getroot()
    for name, origin in joint_origins(chain, deltas).items():
        assert _gap(origin_of(urdf.find(f"joint[@name='{name}']")), origin) < 1e-12


UR_XACRO = """<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="ur">
  <xacro:property name="kin" value="${{xacro.load_yaml('{path}')['kinematics']}}"/>
  <link name="base_link"/><link name="base_link_inertia"/>
  <joint name="base_link-base_link_inertia" type="fixed"><parent link="base_link"/>
    <child link="base_link_inertia"/><origin xyz="0 0 0" rpy="0 0 ${{pi}}"/></joint>
  <xacro:macro name="j" params="name parent child key">
    <link name="${{child}}"/>
    <joint name="${{name}}" type="revolute"><parent link="${{parent}}"/><child link="${{child}}"/>
      <origin xyz="${{kin[key]['x']}} ${{kin[key]['y']}} ${{kin[key]['z']}}"
              rpy="${{kin[key]['roll']}} ${{kin[key]['pitch']}} ${{kin[key]['yaw']}}"/>
      <axis xyz="0 0 1"/><limit lower="-6.3" upper="6.3" effort="1" velocity="1"/></joint>
  </xacro:macro>
  <xacro:j name="shoulder_pan_joint" parent="base_link_inertia" child="shoulder_link" key="shoulder"/>
  <xacro:j name="shoulder_lift_joint" parent="shoulder_link" child="upper_arm_link" key="upper_arm"/>
  <xacro:j name="elbow_joint" parent="upper_arm_link" child="forearm_link" key="forearm"/>
  <xacro:j name="wrist_1_joint" parent="forearm_link" child="wrist_1_link" key="wrist_1"/>
  <xacro:j name="wrist_2_joint" parent="wrist_1_link" child="wrist_2_link" key="wrist_2"/>
  <xacro:j name="wrist_3_joint" parent="wrist_2_link" child="wrist_3_link" key="wrist_3"/>
  <link name="flange"/><link name="tool0"/>
  <joint name="wrist_3-flange" type="fixed"><parent link="wrist_3_link"/><child link="flange"/>
    <origin xyz="0 0 0" rpy="0 ${{-pi/2.0}} ${{-pi/2.0}}"/></joint>
  <joint name="flange-tool0" type="fixed"><parent link="flange"/><child link="tool0"/>
    <origin xyz="0 0 0" rpy="${{pi/2.0}} 0 ${{pi/2.0}}"/></joint>
</robot>
"""


def _ur_description_tool0(tmp_path, deltas):
    """tool0 placements of ur_description's joint/frame chain (ur_macro.xacro's kinematic
    part) built from the written default_kinematics.yaml, and the calibrated ones."""
    chain = load_chain("ur5")
    path = tmp_path / "default_kinematics.yaml"
    rest = write_ur_kinematics_yaml(chain, deltas, path)
    (tmp_path / "ur.xacro").write_text(UR_XACRO.format(path=path))
    ur = pin.buildModelFromXML(xacro.process_file(str(tmp_path / "ur.xacro")).toxml())
    calibrated = chain.perturbed_model(deltas)
    pairs = []
    for q in _poses(chain):
        pairs.append((_frames(calibrated, chain.configuration(q))["tool0"], _frames(ur, q)["tool0"]))
    return path, rest, pairs


def test_ur_layout_nominal_is_ur_descriptions_ur5():
    """Nominal UR5 -> ur_description's DH values (d1, a2, a3, d4, d5, d6 of the UR5)."""
    chain = load_chain("ur5")
    origins, rest = ur_kinematics(chain, [pin.SE3.Identity()] * 7)
    d1, a2, a3, d4, d5, d6 = 0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823
    def rx(a):
        return pin.rpy.rpyToMatrix(a, 0.0, 0.0)

    expected = {
        "shoulder": pin.SE3(np.eye(3), np.array([0, 0, d1])),
        "upper_arm": pin.SE3(rx(np.pi / 2), np.zeros(3)),
        "forearm": pin.SE3(np.eye(3), np.array([a2, 0, 0])),
        "wrist_1": pin.SE3(np.eye(3), np.array([a3, 0, d4])),
        "wrist_2": pin.SE3(rx(np.pi / 2), np.array([0, -d5, 0])),
        "wrist_3": pin.SE3(pin.rpy.rpyToMatrix(np.pi / 2, np.pi, np.pi), np.array([0, d6, 0])),
    }
    assert list(origins) == list(UR_KEYS)
    for key, want in expected.items():
        assert _gap(origins[key], want) < 1e-9, key  # the URDF's pi/2 has 11 digits
    assert _gap(rest, pin.SE3.Identity()) < 1e-9


def test_ur_layout_reproduces_calibrated_tool0(tmp_path):
    chain = load_chain("ur5")
    params = parameter_model(chain, "placement")
    x = _deviations(params, seed=5)
    x[-6:] = 0.0  # end frame uncorrected: the layout holds everything
    path, rest, pairs = _ur_description_tool0(tmp_path, params.deltas(x))
    assert _gap(rest, pin.SE3.Identity()) < TOL
    assert max(_gap(want, got) for want, got in pairs) < TOL
    written = yaml.safe_load(path.read_text())["kinematics"]
    assert list(written) == [*UR_KEYS, "hash"] and written["hash"].startswith("calib_pin_")
    assert set(written["wrist_2"]) == {"x", "y", "z", "roll", "pitch", "yaw"}


def test_ur_layout_absorbs_an_axis_6_screw_and_returns_the_rest(tmp_path):
    chain = load_chain("ur5")
    params = parameter_model(chain, "placement")
    x = _deviations(params, seed=6)
    x[-6:] = [0, 0, 0.8e-3, 0, 0, 3e-3]  # tool0's z is axis 6: a screw about it
    _, rest, pairs = _ur_description_tool0(tmp_path, params.deltas(x))
    assert _gap(rest, pin.SE3.Identity()) < TOL
    assert max(_gap(want, got) for want, got in pairs) < TOL
    x[-6:] = [0.5e-3, -0.3e-3, 0.8e-3, 2e-3, -1e-3, 3e-3]  # a general tool0 correction
    path, rest, pairs = _ur_description_tool0(tmp_path, params.deltas(x))
    assert _gap(rest, pin.SE3.Identity()) > 1e-4
    assert max(_gap(want, got * rest) for want, got in pairs) < TOL
    assert "tool0 correction this layout cannot hold" in path.read_text()


def test_ur_layout_refuses_other_robots(tmp_path):
    chain = load_chain("irb120")
    with pytest.raises(CalibPinError, match="UR's six joints"):
        write_ur_kinematics_yaml(chain, [pin.SE3.Identity()] * 7, tmp_path / "k.yaml")


def _dh_chain(table, beta, q):
    """End frame (DH frame n) of a DH chain with optional Hayati tilts Ry(beta_i)."""
    frame = pin.SE3.Identity()
    for i in range(table.n_joints):
        step = dh_transforms(
            type(table)(table.a[i : i + 1], table.d[i : i + 1], table.alpha[i : i + 1],
                        table.theta_offset[i : i + 1]), q[i : i + 1])[-1]
        frame = frame * step * pin.SE3(pin.rpy.rpyToMatrix(0.0, beta[i], 0.0), np.zeros(3))
    return frame


@pytest.mark.parametrize("model", ["dh", "hayati"])
def test_dh_table_reproduces_calibrated_fk(tmp_path, model):
    chain = load_chain("irb120")
    params = parameter_model(chain, model)
    x = _deviations(params, seed=9)
    path = write_dh_table(params, x, tmp_path / "irb120_dh.toml")
    spec = tomllib.loads(path.read_text())
    table = _read_dh(spec["dh"], path)  # the same reader as robots/<name>.toml
    beta = np.deg2rad(np.asarray(spec["dh"].get("beta_deg", np.zeros(chain.n_joints))))
    assert ("beta_deg" in spec["dh"]) == (model == "hayati")
    calibrated = chain.perturbed_model(params.deltas(x), full=False)
    data = calibrated.createData()
    worst = without_beta = 0.0
    for q in _poses(chain):
        pin.framesForwardKinematics(calibrated, data, chain.configuration(q))
        want = data.oMf[chain.frame_id]
        worst = max(worst, _gap(_dh_chain(table, beta, q), want))
        without_beta = max(without_beta, _gap(dh_transforms(table, q)[-1], want))
    assert worst < TOL
    if model == "hayati":
        assert without_beta > 1e-5  # beta matters: a 4-column reader would be wrong
        assert "beta_deg (Hayati)" in path.read_text()


def test_dh_table_nominal_is_the_robot_file(tmp_path):
    chain = load_chain("irb120")
    params = parameter_model(chain, "dh")
    path = write_dh_table(params, np.zeros(len(params.names)), tmp_path / "t.toml")
    table = _read_dh(tomllib.loads(path.read_text())["dh"], path)
    for column in ("a", "d", "alpha", "theta_offset"):
        np.testing.assert_allclose(getattr(table, column), getattr(chain.description.dh, column), atol=1e-15)


def test_dh_table_refuses_the_placement_model(tmp_path):
    chain = load_chain("irb120")
    params = parameter_model(chain, "placement")
    with pytest.raises(CalibPinError) as err:
        write_dh_table(params, np.zeros(len(params.names)), tmp_path / "t.toml")
    assert "\n" not in str(err.value) and "placement model has no DH table" in str(err.value)
    assert not (tmp_path / "t.toml").exists()


def test_kinematics_and_dh_agree_on_the_end_position(tmp_path):
    """The DH file's end position equals the one FK path the estimators use."""
    chain = load_chain("irb120")
    params = parameter_model(chain, "dh")
    x = _deviations(params, seed=2)
    path = write_dh_table(params, x, tmp_path / "t.toml")
    table = _read_dh(tomllib.loads(path.read_text())["dh"], path)
    kin = Kinematics(chain)
    kin.set_perturbation(params.delta_matrices(x))
    q = _poses(chain, n=10)
    points, _ = kin.points(q, np.zeros(3))
    via_dh = np.array([dh_transforms(table, qi)[-1].translation for qi in q])
    assert np.abs(points - via_dh).max() < TOL

"""Corrected URDF: only joint origins change, and it reloads to the calibrated FK."""

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy
from lxml import etree

import calib_pin as cp
from calib_pin.robot.poses import random_poses


@pytest.fixture(scope="module")
def exported(tmp_path_factory, session):
    data, _ = session
    result = cp.calibrate("irb120", data, method="lm")
    path = result.to_urdf(tmp_path_factory.mktemp("urdf") / "irb120_calibrated.urdf")
    return result, path


def test_reloaded_fk_equals_calibrated_model(exported):
    """Pinocchio reloads the file; tool0 and every joint frame match to 1e-9 m."""
    result, path = exported
    reloaded = pin.buildModelFromUrdf(str(path))
    model = result.model
    d1, d2 = model.createData(), reloaded.createData()
    for q in random_poses(result.chain, 20, np.random.default_rng(0)):
        pin.framesForwardKinematics(model, d1, q)
        pin.framesForwardKinematics(reloaded, d2, q)
        for name in ("tool0", "flange", "link_3"):
            a, b = d1.oMf[model.getFrameId(name)], d2.oMf[reloaded.getFrameId(name)]
            assert np.linalg.norm(a.translation - b.translation) < 1e-9
            assert np.abs(a.rotation - b.rotation).max() < 1e-9


def test_only_joint_origins_change(exported):
    """Names, limits, inertias, axes and comments are those of the input."""
    result, path = exported

    def strip_origins(file):
        root = etree.parse(str(file)).getroot()
        for joint in root.iter("joint"):
            for origin in joint.findall("origin"):
                joint.remove(origin)
        return etree.tostring(root)

    assert strip_origins(path) == strip_origins(result.chain.description.urdf)
    assert path.read_text().splitlines()[:2] == result.chain.description.urdf.read_text().splitlines()[:2]
    changed = [j.get("name") for j in etree.parse(str(path)).getroot().iter("joint")]
    assert "joint_1" in changed


def test_yourdfpy_loads_it(exported):
    """yourdfpy reads the corrected file with the same joints and limits."""
    _, path = exported
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=False)
    assert [j for j in urdf.actuated_joint_names] == [f"joint_{i}" for i in range(1, 7)]
    assert urdf.joint_map["joint_3"].limit.upper == pytest.approx(np.deg2rad(70))


def test_exported_model_is_the_calibrated_one(exported, fresh):
    """Readings predicted through the reloaded URDF equal the calibration's predictions."""
    result, path = exported
    chain = cp.load_chain(str(path))
    q = fresh[0][:50]
    kin = cp.Kinematics(chain)
    via_file = np.linalg.norm(kin.points(q, result.sensor.tool)[0] - result.sensor.anchor, axis=1)
    np.testing.assert_allclose(via_file + result.sensor.length_offset, result.predict(q), atol=1e-9)


def test_the_files_made_in_memory_are_the_files_written(exported, tmp_path):
    """write_outputs makes the URDF and the calibration file in memory (issue 24): the same
    text as result.to_urdf and write_calibration write to disk."""
    from calib_pin.calibration.record import calibration_text, write_calibration
    from calib_pin.export.urdf import calibrated_urdf
    from calib_pin.report.bundle import render_outputs

    result, path = exported
    assert calibrated_urdf(result.chain, result.deltas, notes=result.determination_notes()) == path.read_bytes()
    written = write_calibration(result, tmp_path / "c.json")
    assert calibration_text(result) == written.read_text(encoding="utf-8")
    rendered = render_outputs(result, html=False)
    assert rendered.files["irb120_calibrated.urdf"] == path.read_text(encoding="utf-8")
    assert rendered.files["irb120_calibration.json"] == written.read_text(encoding="utf-8")


def test_an_end_frame_without_a_fixed_joint_is_refused_before_a_fit():
    """link_6 is joint_6's own link: no URDF or yaml can hold its correction, which the
    check says up front; tool0 (fixed joints after joint_6) passes."""
    from calib_pin.export.urdf import check_end_frame_writable
    from calib_pin.report.bundle import check_exportable

    check_end_frame_writable(cp.load_chain("irb120"))
    link6 = cp.load_chain("irb120", "link_6")
    with pytest.raises(cp.RobotError, match="end frame 'link_6' is the link of joint 'joint_6'"):
        check_end_frame_writable(link6)
    with pytest.raises(cp.RobotError, match="link_6"):
        check_exportable(("urdf",), link6)
    check_exportable(("dh",), link6)  # a DH table holds it
    check_exportable(("urdf",), link6, kinematic=False)  # rbf writes no robot

"""The gravity basis deflection model (no inertias): its terms, its Jacobian columns against
finite differences, recovery of a true CAD deflection with a payload on a UR5 whose URDF
has no inertias, the calibration file round trip, and the CLI on a stripped IRB120."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from calib_pin.estimators import run_estimator
from calib_pin.parameters import parameter_model
from calib_pin.robot import load_chain
from calib_pin.robot.deflection import ComplianceSpec, Payload, compliance_spec, has_inertial_data
from calib_pin.robot.gravity_basis import GravityBasis
from calib_pin.robot.poses import random_poses
from calib_pin.sensors.position import PositionModel, fit_device
from calib_pin.sensors.problem import SetProblem
from calib_pin.simulation import simulate_positions

ROOT = Path(__file__).resolve().parents[1]


def strip_inertias(urdf: str | Path, folder: Path, name: str) -> Path:
    """A copy of ``urdf`` without its <inertial> elements, as ``folder/<name>.urdf``."""
    text = Path(urdf).read_text(encoding="utf-8")
    out = folder / f"{name}.urdf"
    out.write_text(re.sub(r"<inertial>.*?</inertial>", "", text, flags=re.S), encoding="utf-8")
    return out


@pytest.fixture(scope="module")
def bare_irb120(tmp_path_factory) -> Path:
    return strip_inertias(ROOT / "robots" / "irb120.urdf", tmp_path_factory.mktemp("bare"), "irb120")


@pytest.fixture(scope="module")
def ur5_pair(tmp_path_factory):
    chain = load_chain("ur5")
    bare = load_chain(str(strip_inertias(chain.description.urdf, tmp_path_factory.mktemp("ur5"), "ur5")))
    return chain, bare


def test_terms_come_from_the_kinematics():
    """A vertical base joint carries no gravity torque (no term); the shoulder pitch of a
    6R arm gets the few terms of its upper arm and forearm; each term is in the span of
    the true torque's regressor (the CAD torque is a combination of the terms)."""
    chain = load_chain("irb120")
    basis = GravityBasis(chain, chain.joint_names)
    assert basis.terms[0] == 0
    assert 4 <= basis.terms[1] <= 6
    q = random_poses(chain, 200, np.random.default_rng(1))
    from calib_pin.robot.deflection import StaticTorque

    tau = StaticTorque(chain)(q)
    for i, j in enumerate(chain.joint_names[1:3], start=1):
        b = basis.values(q)[:, basis.columns == i]
        coef, *_ = np.linalg.lstsq(b, tau[:, i], rcond=None)
        assert np.linalg.norm(b @ coef - tau[:, i]) < 0.05 * np.linalg.norm(tau[:, i]), j


def test_default_model_follows_the_inertias(bare_irb120):
    """cad with inertias, basis without; cad is refused on a URDF without inertias."""
    chain, bare = load_chain("irb120"), load_chain(str(bare_irb120))
    assert has_inertial_data(chain) and not has_inertial_data(bare)
    assert compliance_spec(chain, "joint_2").model == "cad"
    assert compliance_spec(bare, "joint_2").model == "basis"
    with pytest.raises(Exception, match="inertial data"):
        compliance_spec(bare, "joint_2", model="cad")
    with pytest.raises(Exception, match="cable tension needs the CAD"):
        compliance_spec(bare, "joint_2", cable_tension_n=5.0)


def test_basis_jacobian_matches_finite_differences(ur5_pair):
    """The basis coefficients' analytic Jacobian columns against central differences."""
    _, bare = ur5_pair
    params = parameter_model(bare, "placement")
    spec = compliance_spec(bare, "shoulder_lift_joint,elbow_joint")
    data, geo = simulate_positions(bare, params, 12, seed=2)
    model = PositionModel(bare, params, geo.sensor, compliance=spec)
    markers = np.searchsorted(geo.sensor.labels, data.point_ids)
    problem = SetProblem(model, data.q, data.values, markers)
    x = np.random.default_rng(0).normal(size=model.n_params) * model.scale * 0.5
    jac = problem.jacobian(x)
    cols = range(model.n_robot, model.sensor_start)
    assert len(cols) == model.deflection.n > 0
    for c in cols:
        h = 1e-7
        e = np.zeros_like(x)
        e[c] = h
        fd = (problem.residual(x + e) - problem.residual(x - e)) / (2 * h)
        assert np.allclose(jac[:, c], fd, atol=1e-6 * max(1.0, np.abs(fd).max())), model.names[c]


def test_basis_recovers_a_cad_deflection_with_payload(ur5_pair):
    """A UR5 whose joints 2, 3 deflect (true CAD compliances, gravity and a 3 kg payload),
    calibrated from its inertia-free URDF: the basis model predicts 1000 fresh poses within
    10 % of the deflection's size; the geometry alone is off by about the deflection."""
    full, bare = ur5_pair
    joints = "shoulder_lift_joint,elbow_joint"
    params = parameter_model(full, "placement")
    spec = ComplianceSpec(tuple(joints.split(",")), Payload(3.0, np.array([0.0, 0.02, 0.08])))
    true_c = np.array([1.2e-5, 2.0e-5])
    data, geo = simulate_positions(full, params, 80, seed=4, noise_mm=0.0)
    truth = PositionModel(full, params, geo.sensor, estimate=(), compliance=spec)
    x_true = np.concatenate([geo.x, true_c])
    markers = np.searchsorted(geo.sensor.labels, data.point_ids)
    rng = np.random.default_rng(7)
    positions = truth.predict(x_true, data.q, markers) + rng.normal(size=(len(data.q), 3)) * 1e-5
    q_fresh = random_poses(full, 1000, rng)
    m_fresh = rng.integers(0, len(geo.sensor.labels), 1000)
    true_fresh = truth.predict(x_true, q_fresh, m_fresh)
    rigid = np.concatenate([geo.x, np.zeros(2)])
    size = np.sqrt(np.mean(np.sum((true_fresh - truth.predict(rigid, q_fresh, m_fresh)) ** 2, axis=1)))
    assert size > 3e-4  # the deflection is worth modelling: 0.3 mm RMS or more
    bare_params = parameter_model(bare, "placement")
    errors = {}
    for name, compliance in (("geometric", None), ("basis", compliance_spec(bare, joints))):
        start = fit_device(bare, bare_params, data.q, positions, markers, geo.sensor.labels)
        model = PositionModel(bare, bare_params, start, compliance=compliance)
        problem = SetProblem(model, data.q, positions, markers)
        x = run_estimator("lm", problem, np.zeros(model.n_params)).x
        diff = model.predict(x, q_fresh, m_fresh) - true_fresh
        errors[name] = np.sqrt(np.mean(np.sum(diff**2, axis=1)))
    assert errors["basis"] < 0.1 * size
    assert errors["geometric"] > 0.5 * size


def test_cli_basis_on_stripped_irb120_and_calibration_file(bare_irb120, tmp_path, capsys):
    """--compliance joint_2,joint_3 on the Wu set with a URDF without inertias runs the basis
    model, reports each joint's peak deflection and end-frame effect, says a given payload is
    in the basis, and writes a calibration file that loads with the same deflection (and is
    refused when its basis is not the robot's)."""
    from calib_pin import load_calibration
    from calib_pin.cli import main

    out = tmp_path / "out"
    code = main(["calibrate", str(bare_irb120), "--data", str(ROOT / "robots" / "irb120_wu2015.csv"),
                 "--method", "lm", "--compliance", "joint_2,joint_3", "--payload-kg", "2", "--out", str(out),
                 "--no-html"])
    captured = capsys.readouterr()
    printed = captured.out
    assert code == 0
    assert "basis model" in printed and "mm at the end frame" in printed
    assert "warning: the payload given is not used: the gravity basis already holds" in captured.err
    report = json.loads((out / "report.json").read_text())
    soft = report["compliance"]
    assert soft["compliance_model"] == "basis"
    assert set(soft["peak_deflection_urad"]) == {"joint_2", "joint_3"}
    assert 100 < soft["peak_deflection_urad"]["joint_2"] < 10_000
    assert report["test"]["after"]["mean_mm"] < 0.25  # the geometry alone: 0.27 on split 0
    robot = load_calibration(out)
    assert robot.compliance_spec.model == "basis"
    q = np.deg2rad(np.array([[10.0, 30.0, 20.0, 5.0, 40.0, 0.0]]))
    shifted = robot.joint_angles(q) - q
    assert np.abs(shifted[0, 1]) > 1e-5 and shifted[0, 0] == 0.0
    path = next(out.glob("*_calibration.json"))
    doc = json.loads(path.read_text())
    doc["compliance"]["basis_directions"]["joint_3"]["directions"][0][0] += 0.5  # another URDF's basis
    path.write_text(json.dumps(doc))
    with pytest.raises(Exception, match="compliance.basis_directions.joint_3"):
        load_calibration(out)


def test_compare_models_on_the_wu_set(bare_irb120):
    """compare --models on the Wu set: the README's geometric vs compliance table, with the
    paired difference and its standard error; over the same 10 splits the basis model on
    the URDF without inertias comes within 0.01 mm of the CAD model's held-out mean."""
    from calib_pin.studies.model_comparison import compare_models

    wu = ROOT / "robots" / "irb120_wu2015.csv"
    cad = compare_models("irb120", wu, models="placement,compliance:joint_2+joint_3", parameters="placement",
                         trials=10)
    basis = compare_models(str(bare_irb120), wu, models="geometric,compliance:joint_2+joint_3", trials=10)
    rows_cad, rows_basis = cad.rows(), basis.rows()
    assert rows_cad[1]["fits"].endswith("(cad model)") and rows_basis[1]["fits"].endswith("(basis model)")
    geometric, soft = rows_cad[0]["mean_mm"][0], rows_cad[1]["mean_mm"][0]
    assert 0.25 < geometric < 0.29 and 0.15 < soft < 0.175  # README: 0.269 and 0.162
    d, se = rows_cad[1]["paired_mean_mm"]
    assert d < -5 * se < 0  # compliance is better, well beyond the splits' noise
    assert abs(rows_basis[1]["mean_mm"][0] - soft) < 0.01
    assert "paired diff" in cad.format_table()


def test_compliance_all_bounds_and_names_rigid_joints(tmp_path, capsys):
    """--compliance all with a payload (the README example, with lm): no negative compliance in the
    calibration file, the printout names the joints bounded at zero."""
    from calib_pin.cli import main

    out = tmp_path / "out"
    code = main(["calibrate", "irb120", "--method", "lm", "--compliance", "all", "--payload-kg", "1.5",
                 "--payload-com-mm", "0,0,60", "--out", str(out), "--no-html"])
    captured = capsys.readouterr()
    printed = captured.out
    assert code == 0
    doc = json.loads(next(out.glob("*_calibration.json")).read_text())
    values = doc["compliance"]["compliance_rad_per_Nm"]
    assert all(v >= 0 for v in values.values())
    bounded = json.loads((out / "report.json").read_text())["compliance"]["bounded_at_zero"]
    assert bounded and all(f"{j} 0.0 urad/Nm (rigid, bounded at zero" in printed for j in bounded)
    assert "warning: compliance bounded at zero: " + ", ".join(bounded) in captured.err


def test_gravity_agreement_flags_a_lift():
    """A true CAD sag expressed in the basis agrees with gravity's sign pattern (cosine near
    +1); the same deflection reversed (the arm lifted against gravity) is flagged (< 0)."""
    from calib_pin.robot.deflection import StaticTorque

    chain = load_chain("irb120")
    basis = GravityBasis(chain, ("joint_2", "joint_3"))
    q = random_poses(chain, 200, np.random.default_rng(2))
    sag = -StaticTorque(chain)(q)[:, [1, 2]] * np.array([3e-5, 6e-5])
    b = basis.values(q)
    beta = np.concatenate([np.linalg.lstsq(b[:, basis.columns == j], sag[:, i], rcond=None)[0]
                           for i, j in enumerate((1, 2))])
    assert np.all(basis.gravity_agreement(q, beta) > 0.8)
    assert np.all(basis.gravity_agreement(q, -beta) < -0.8)

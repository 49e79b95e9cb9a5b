"""Joint compliance: static torques against Pinocchio's RNEA and potential energies, the
sign of the sag, the small-deflection approximation, the compliance Jacobian columns
against finite differences, and recovery of known compliances from simulated data."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest

import calib_pin as cp
from calib_pin.estimators import run_estimator
from calib_pin.exceptions import CalibPinError, RobotError
from calib_pin.report.build import build_report
from calib_pin.robot import Kinematics, load_chain
from calib_pin.robot.deflection import (
    CablePull,
    Compliance,
    ComplianceSpec,
    Deflection,
    Payload,
    StaticTorque,
    fixed_point_angles,
    stiffness,
)
from calib_pin.robot.poses import random_poses
from calib_pin.sensors.cable import CableModel, Drawstring
from calib_pin.sensors.position import PositionModel, fit_device
from calib_pin.sensors.problem import SetProblem
from calib_pin.simulation import simulate, simulate_positions

JOINTS_23 = ("joint_2", "joint_3")
#: True compliances of joints 2 and 3 [rad/Nm]: up to 0.5 mrad, 0.4 mm at the tool.
TRUE_C = np.array([2.5e-5, 4e-5])
PAYLOAD = Payload(1.5, np.array([0.01, -0.02, 0.06]))


@pytest.fixture(scope="module")
def poses(chain):
    return random_poses(chain, 25, np.random.default_rng(3))


def test_gravity_torque_is_rnea_at_rest(chain, poses):
    data = chain.model.createData()
    zero = np.zeros(chain.model.nv)
    expected = np.array([pin.rnea(chain.model, data, q, zero, zero) for q in poses])
    assert np.abs(StaticTorque(chain)(poses) - expected).max() < 1e-10
    assert np.abs(expected[:, 1]).max() > 5.0  # joint 2 carries several Nm


def _potential_gradient(chain, q: np.ndarray, potential, h: float = 1e-6) -> np.ndarray:
    """Central differences of potential(q) -> scalar [J] with respect to q, [Nm]."""
    out = np.empty(len(q))
    for j in range(len(q)):
        e = np.zeros(len(q))
        e[j] = h
        out[j] = (potential(q + e) - potential(q - e)) / (2 * h)
    return out


def test_payload_and_cable_torques_are_potential_gradients(chain, poses):
    """tau = dV/dq: V = -m g.r(q) for the payload, V = T |h(q) - P0| for the cable."""
    kin = Kinematics(chain)
    cable = CablePull(4.0, np.array([0.02, 0.01, 0.05]), np.array([0.6, -0.4, -0.1]))
    links = StaticTorque(chain)(poses)
    with_payload = StaticTorque(chain, payload=PAYLOAD)(poses) - links
    with_cable = StaticTorque(chain, cable=cable)(poses) - links
    g = chain.model.gravity.linear

    def payload_v(q):
        return -PAYLOAD.mass_kg * g @ kin.points(q[None], PAYLOAD.com_m)[0][0]

    def cable_v(q):
        return cable.tension_n * np.linalg.norm(kin.points(q[None], cable.hook_m)[0][0] - cable.anchor_m)

    for k in range(5):
        assert np.allclose(with_payload[k], _potential_gradient(chain, poses[k], payload_v), atol=1e-7)
        assert np.allclose(with_cable[k], _potential_gradient(chain, poses[k], cable_v), atol=1e-7)
    assert np.abs(with_payload).max() > 1.0 and np.abs(with_cable).max() > 0.5


def test_horizontal_upper_arm_sags(chain):
    """q_2 = +90 deg puts the upper arm horizontal along +x: the tool must move down."""
    soft = Deflection(chain, ComplianceSpec(JOINTS_23))
    q = np.array([[0.0, np.pi / 2, -np.pi / 2, 0.0, 0.0, 0.0]])
    q_eff, minus_tau = soft.joint_angles(q, TRUE_C)
    assert minus_tau[0, 0] > 10.0  # tau_2 < 0: the motor holds against gravity's +y pull
    kin = Kinematics(chain)
    drop = kin.points(q_eff, np.zeros(3))[0][0] - kin.points(q, np.zeros(3))[0][0]
    assert drop[2] < -2e-4 and abs(drop[1]) < 1e-9


def test_small_deflection_approximation_is_negligible(chain):
    """Torques at q instead of the fixed point q_eff = q - c tau(q_eff): < 1 um at the tool."""
    q = random_poses(chain, 300, np.random.default_rng(1), margin=0.0)
    soft = Deflection(chain, ComplianceSpec(JOINTS_23))
    c = np.array([3e-5, 3e-5])
    one_step = soft.joint_angles(q, c)[0]
    exact = fixed_point_angles(soft, q, c)
    kin = Kinematics(chain)
    p0, p1, pf = (kin.points(a, np.zeros(3))[0] for a in (q, one_step, exact))
    assert np.linalg.norm(p1 - p0, axis=1).max() > 3e-4  # a few tenths of a mm of sag
    assert np.linalg.norm(p1 - pf, axis=1).max() < 1e-6


def _check_jacobian(predict, predict_with_jacobian, model, x):
    values, jac = predict_with_jacobian(x)
    assert np.allclose(values, predict(x), atol=1e-12)
    for i in range(model.n_params):
        h = model.scale[i] * 1e-3
        e = np.zeros_like(x)
        e[i] = h
        fd = (predict(x + e) - predict(x - e)) / (2 * h)
        assert np.abs(jac[..., i] - fd).max() < 1e-6 * max(1.0, np.abs(fd).max()), model.names[i]


def test_cable_jacobian_with_compliance(chain, params, poses):
    spec = ComplianceSpec(("joint_2", "joint_3", "joint_5"), PAYLOAD, cable_tension_n=5.0)
    sensor = Drawstring(np.array([0.5, 0.3, -0.2]), np.array([0.01, 0.0, 0.03]), 0.1)
    model = CableModel(chain, params, sensor, ("anchor", "offset"), spec)
    assert model.names[model.n_robot : model.sensor_start] == tuple(f"compliance_{j}" for j in spec.joints)
    x = np.random.default_rng(0).normal(size=model.n_params) * model.scale
    _check_jacobian(lambda x: model.predict(x, poses), lambda x: model.predict_with_jacobian(x, poses), model, x)


def test_position_jacobian_with_compliance(chain, params, poses):
    rng = np.random.default_rng(2)
    device = simulate_positions(chain, params, 8, seed=2)[1].sensor
    model = PositionModel(chain, params, device, compliance=ComplianceSpec(JOINTS_23, PAYLOAD))
    markers = rng.integers(0, 3, len(poses))
    x = rng.normal(size=model.n_params) * model.scale
    _check_jacobian(lambda x: model.predict(x, poses, markers),
                    lambda x: model.predict_with_jacobian(x, poses, markers), model, x)


def test_refusals(chain, tmp_path):
    text = chain.description.urdf.read_text()
    bare = tmp_path / "massless.urdf"
    bare.write_text(re.sub(r"<inertial>.*?</inertial>", "", text, flags=re.DOTALL))
    with pytest.raises(RobotError, match="no inertial data"):
        Deflection(load_chain(str(bare)), ComplianceSpec(JOINTS_23))
    with pytest.raises(RobotError, match="no chain joint 'joint_9'"):
        Deflection(chain, ComplianceSpec(("joint_9",)))
    with pytest.raises(CalibPinError, match="drawstring"):
        Deflection(chain, ComplianceSpec(JOINTS_23, cable_tension_n=3.0))
    assert np.allclose(stiffness([2e-5, 0.0]), [5e4, np.inf])


def _fresh_error_mm(model, x, q, markers, truth_model, x_true) -> float:
    """Mean Euclidean error [mm] of model's positions at fresh poses against the truth."""
    diff = model.predict(x, q, markers) - truth_model.predict(x_true, q, markers)
    return float(np.linalg.norm(diff, axis=1).mean() * 1e3)


def test_positions_recover_true_compliance(chain, params):
    """Simulated positions with compliant joints 2, 3: fitting c reaches the floor of LM
    started from the truth; the geometric model alone does not."""
    rng = np.random.default_rng(5)
    data, geo = simulate_positions(chain, params, 50, seed=5)
    x_geo, device = geo.x, geo.sensor
    spec = ComplianceSpec(JOINTS_23, PAYLOAD)
    truth = PositionModel(chain, params, device, estimate=(), compliance=spec)
    x_true = np.concatenate([x_geo, TRUE_C])
    markers = np.searchsorted(device.labels, data.point_ids)
    positions = truth.predict(x_true, data.q, markers) + rng.normal(size=(len(data.q), 3)) * 5e-5
    q_fresh = random_poses(chain, 300, rng)
    m_fresh = rng.integers(0, 3, 300)
    errors = {}
    for name, compliance in (("geometric", None), ("compliant", spec)):
        start = fit_device(chain, params, data.q, positions, markers, device.labels)
        model = PositionModel(chain, params, start, compliance=compliance)
        problem = SetProblem(model, data.q, positions, markers)
        x = run_estimator("lm", problem, np.zeros(model.n_params)).x
        errors[name] = _fresh_error_mm(model, x, q_fresh, m_fresh, truth, x_true)
        if compliance is not None:
            assert np.allclose(model.compliance(x), TRUE_C, rtol=0.1)
    reference = PositionModel(chain, params, device, compliance=spec)
    problem = SetProblem(reference, data.q, positions, markers)
    x0 = np.concatenate([x_true, np.zeros(reference.n_params - len(x_true))])
    floor = _fresh_error_mm(reference, run_estimator("lm", problem, x0).x, q_fresh, m_fresh, truth, x_true)
    assert errors["compliant"] < 1.1 * floor
    assert errors["geometric"] > 3 * floor


def test_cable_recovers_true_compliance(chain, params):
    """Simulated drawstring with a 5 N pull and compliant joints 2, 3: same as positions."""
    data, truth = simulate(chain, params, 150, seed=9, noise_mm=0.05)
    spec = ComplianceSpec(JOINTS_23, cable_tension_n=5.0)
    true_model = CableModel(chain, params, truth.sensor, compliance=spec)
    x_true = np.concatenate([truth.x, TRUE_C])
    rng = np.random.default_rng(9)
    readings = true_model.predict(x_true, data.q) + rng.normal(size=len(data.q)) * 5e-5
    q_fresh = random_poses(chain, 300, rng)
    true_fresh = true_model.predict(x_true, q_fresh)
    errors = {}
    for name, compliance, x0 in (("geometric", None, np.zeros(len(truth.x))),
                                 ("compliant", spec, np.zeros(len(x_true))),
                                 ("from truth", spec, x_true)):
        model = CableModel(chain, params, truth.sensor, compliance=compliance)
        x = run_estimator("lm", SetProblem(model, data.q, readings), x0).x
        errors[name] = float(np.sqrt(np.mean((model.predict(x, q_fresh) - true_fresh) ** 2)) * 1e3)
        if name == "compliant":
            assert np.allclose(model.compliance(x), TRUE_C, rtol=0.25)
    assert errors["compliant"] < 1.1 * errors["from truth"]
    assert errors["geometric"] > 2 * errors["from truth"]


def test_real_irb120_compliance_lowers_held_out_error():
    """Must hold (issue 11): on the real IRB120 laser-tracker set, compliance of joints 2
    and 3 lowers the held-out mean error by >= 30 % over the same 10 splits (LM)."""
    from calib_pin.studies.comparison import compare

    data = "robots/irb120_wu2015.csv"
    geometric = compare("irb120", data, methods=["lm"], trials=10).rows()[1]["mean_mm"][0]
    compliant = compare("irb120", data, methods=["lm"], trials=10,
                        compliance=("joint_2", "joint_3")).rows()[1]["mean_mm"][0]
    assert compliant < 0.7 * geometric


def test_calibrate_reports_compliance_and_refuses_bad_options():
    import calib_pin as cp

    result = cp.calibrate("irb120", "robots/irb120_wu2015.csv", method="lm", compliance="joint_2,joint_3")
    soft = build_report(result)["compliance"]
    assert soft["in_urdf"] is False and set(soft["compliance_rad_per_Nm"]) == set(JOINTS_23)
    c2 = soft["compliance_rad_per_Nm"]["joint_2"]
    assert 1e-6 < c2 < 1e-3 and np.isclose(soft["stiffness_Nm_per_rad"]["joint_2"], 1 / c2)
    assert np.isclose(result.compliances["compliance_joint_2_urad_per_Nm"], c2 * 1e6)
    for make, message in ((lambda: "joint_9", "no chain joint"),
                          (lambda: cp.Compliance("all", payload_kg=-1.0), "payload_kg"),
                          (lambda: cp.Compliance(payload_kg=1.0), "needs compliant joints"),
                          (lambda: cp.Compliance("all", cable_tension_n=2.0), "drawstring data only")):
        with pytest.raises(CalibPinError, match=message):
            cp.prepare("irb120", "robots/irb120_wu2015.csv", compliance=make())


def test_simulated_truth_with_compliance_through_the_pipeline(chain, params, tmp_path):
    """simulate(compliance=...) carries the true compliances; calibrating with them brings
    the fresh-pose error to the floor, without them it stays several times higher."""
    from calib_pin import prepare
    from calib_pin.simulation import Truth
    from calib_pin.studies.comparison import fresh_scorer

    spec = ComplianceSpec(JOINTS_23, cable_tension_n=5.0)
    data, truth = simulate(chain, params, 150, seed=9, compliance=spec, true_compliance=TRUE_C)
    truth.to_json(tmp_path / "t.json")
    assert np.allclose(Truth.from_json(tmp_path / "t.json", params).x_model, truth.x_model)
    fresh = {}
    for name, joints in (("geometric", None), ("compliant", JOINTS_23)):
        setup = prepare("irb120", data, compliance=Compliance(joints, cable_tension_n=5.0) if joints else None)
        result = cp.solve(setup, "lm")
        fresh[name] = fresh_scorer(setup, [truth], 0)(result, False)
    assert fresh["compliant"] < 0.05 and fresh["geometric"] > 3 * fresh["compliant"]

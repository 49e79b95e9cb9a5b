"""Planned poses see the parameters better than random ones of the same count."""

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.analysis.planning import plan_poses
from calib_pin.cli.poses import plan_poses_main
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import CableModel


def _fresh_error(chain, params, truth, q, rng, fresh):
    """Calibrate (LM) on readings of the true robot at poses q; error on fresh poses [mm]."""
    model = CableModel(chain, params, truth.sensor)
    readings = model.predict(truth.x, q) + rng.normal(scale=truth.noise, size=len(q))
    data = cp.MeasurementSet(q=q, values=readings, anchor=truth.sensor.anchor, tool=truth.sensor.tool,
                             robot="irb120")
    result = cp.calibrate("irb120", data, method="lm", test_fraction=0.0)
    fresh_q, true_fresh = fresh
    return float(np.sqrt(np.mean((result.predict(fresh_q) - true_fresh) ** 2)) * 1e3)


def test_planned_poses_beat_random_ones(chain, params, session, fresh):
    """40 planned poses give a lower fresh-pose error than 40 random ones, on the same true
    robot, in each of 3 seeded draws; and a higher O1 and O3."""
    _, truth = session
    model = CableModel(chain, params, truth.sensor)
    for seed in range(3):
        plan = plan_poses(model, 40, 2000, seed=seed)
        assert plan.o1 > plan.random_o1 and plan.o3 > plan.random_o3
        assert plan.reach is not None and plan.reach < 40
        rng = np.random.default_rng(seed)
        pool = random_poses(chain, 400, np.random.default_rng(100 + seed))
        random_q = pool[model.tool_positions(None, pool)[:, 2] > 0][:40]
        planned = _fresh_error(chain, params, truth, plan.q, rng, fresh)
        random = _fresh_error(chain, params, truth, random_q, rng, fresh)
        assert planned < random, (seed, planned, random)


def test_plan_poses_command(tmp_path, capsys, chain):
    out = tmp_path / "plan.csv"
    assert plan_poses_main(["irb120", "--n", "30", "--candidates", "1000", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "observability O1" in text and "reached by the first" in text
    poses = cp.read_measurements(out, chain, readings=False)
    assert len(poses) == 30 and poses.pose_ids.tolist() == list(range(1, 31))
    assert plan_poses_main(["irb120", "--n", "50", "--candidates", "10", "--out", str(out)]) == 2


def test_planning_works_for_any_sensor(chain, params):
    """The planner asks only the measurement-model interface: for markers seen by a
    tracker it picks poses with more information than random ones too."""
    import pinocchio as pin

    device = cp.PositionDevice(pin.SE3.Identity(), np.array([[0.06, 0, 0.04], [-0.03, 0.05, 0.04]]), (1, 2))
    plan = plan_poses(cp.PositionModel(chain, params, device), 12, candidates=300, seed=1)
    assert plan.q.shape == (12, 6) and plan.o1 > plan.random_o1


def _positions(chain, params, truth, q, rng):
    """Tracker readings of the true robot at poses q (every marker), as a set."""
    model = cp.PositionModel(chain, params, truth.sensor, estimate=())
    k = len(truth.sensor.labels)
    rows, index = np.repeat(np.arange(len(q)), k), np.tile(np.arange(k), len(q))
    values = model.predict(truth.x, q[rows], index) + rng.normal(scale=truth.noise, size=(len(rows), 3))
    return cp.MeasurementSet(q=q[rows], values=values, kind="position", robot="irb120",
                             pose_ids=rows + 1, point_ids=np.array(truth.sensor.labels)[index])


def test_planned_tracker_poses_calibrate_better_than_random(chain, params):
    """plan-poses for a position device (its planning model: the simulator's 3 markers):
    15 planned poses predict 300 fresh poses of the true robot better than 15 random ones."""
    from calib_pin.sensors import PositionModel

    _, truth = cp.simulate_positions(chain, params, 5, seed=3, noise_mm=0.05)
    plan = plan_poses(PositionModel.planning_model(chain, params, None), 15, candidates=400, seed=2)
    assert plan.o1 > plan.random_o1 and plan.identifiability.rank >= 30
    fresh_q = random_poses(chain, 300, np.random.default_rng(9))
    true_model = cp.PositionModel(chain, params, truth.sensor, estimate=())
    errors = []
    for q in (plan.q, random_poses(chain, 15, np.random.default_rng(2))):
        result = cp.calibrate("irb120", _positions(chain, params, truth, q, np.random.default_rng(1)), method="lm",
                              test_fraction=0.0)
        points = np.zeros(len(fresh_q), dtype=int)  # marker 1 (index 0 of the true model)
        predicted = result.predict(fresh_q, np.ones(len(fresh_q), dtype=int))
        true = true_model.predict(truth.x, fresh_q, points)
        errors.append(float(np.sqrt(np.mean(np.sum((predicted - true) ** 2, axis=1)))))
    assert errors[0] < errors[1], errors


def test_sensor_mix_jacobian_and_plan(chain, params):
    """A drawstring and a tracker at every pose: the stacked, weighted Jacobian equals
    central differences; the plan beats random poses and sees more than the drawstring alone."""
    from calib_pin.analysis.planning import SensorMix
    from calib_pin.sensors import CableModel, PositionModel

    cable = CableModel.planning_model(chain, params, None)
    tracker = PositionModel.planning_model(chain, params, None)
    mix = SensorMix([cable, tracker], [0.05e-3, 0.02e-3])
    assert mix.names[: params.n_params] == tuple(params.names) and mix.names[-1] == "position:marker3_z"
    np.testing.assert_allclose(mix.weights, [1.0, 2.5])
    q = random_poses(chain, 4, np.random.default_rng(0))
    x = np.random.default_rng(1).normal(size=mix.n_params) * mix.scale
    values, jac = mix.predict_with_jacobian(x, q)
    assert values.shape == (4, 10) and jac.shape == (4, 10, mix.n_params)
    np.testing.assert_allclose(values[:, 0], cable.predict(x[: cable.n_params], q))  # weight 1
    fd = np.stack([(mix.predict(x + 1e-7 * e, q) - mix.predict(x - 1e-7 * e, q)) / 2e-7
                   for e in np.eye(mix.n_params)], axis=-1)
    np.testing.assert_allclose(jac, fd, atol=1e-6)
    plan = plan_poses(mix, 20, candidates=300, seed=0)
    alone = plan_poses(cable, 20, candidates=300, seed=0)
    assert plan.o1 > plan.random_o1
    assert "theta_6" in alone.identifiability.unidentifiable and "theta_6" not in plan.identifiability.unidentifiable
    with pytest.raises(cp.ArgumentError, match="noise"):
        SensorMix([cable, tracker], [0.05e-3])


def test_plan_poses_command_for_a_mix(tmp_path, capsys):
    """--sensor cable,position --noise-mm 0.05,0.02 plans for both and says what the poses identify."""
    out = tmp_path / "mix.csv"
    argv = ["irb120", "--n", "20", "--candidates", "300", "--out", str(out)]
    assert plan_poses_main(argv + ["--sensor", "cable,position", "--noise-mm", "0.05,0.02"]) == 0
    text = capsys.readouterr().out
    assert "sensors at every pose: cable: drawstring sensor" in text and "(weight 2.5)" in text
    assert "the planned poses identify 37 of 39 directions" in text
    assert "drawstring and the position device sensors" in out.read_text()
    assert plan_poses_main(argv + ["--force", "--sensor", "position", "--anchor-mm", "1,2,3"]) == 2
    assert plan_poses_main(argv + ["--force", "--sensor", "cable,position", "--noise-mm", "0.05"]) == 2
    with pytest.raises(SystemExit) as refused:  # argparse's own one line
        plan_poses_main(argv + ["--force", "--sensor", "laser"])
    assert refused.value.code == 2 and "expected sensor kinds" in capsys.readouterr().err

"""Planned poses see the parameters better than random ones of the same count."""

import numpy as np

import calib_pin as cp
from calib_pin.cli.poses import plan_poses_main
from calib_pin.analysis.planning import plan_poses
from calib_pin.sensors import CableModel
from calib_pin.robot.poses import random_poses


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

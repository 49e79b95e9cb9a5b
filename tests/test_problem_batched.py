"""CalibrationProblem.residuals / costs: a search's candidate points in one batched
forward-kinematics pass, the same numbers to the bit as one residual per point."""

import numpy as np
import pytest

import calib_pin as cp
from calib_pin import prepare
from calib_pin.estimators import run_estimator
from calib_pin.estimators.base import Tracker
from calib_pin.estimators.robust import RobustProblem
from calib_pin.robot.deflection import Compliance


def _points(problem, k=4, seed=0):
    rng = np.random.default_rng(seed)
    return [0.5 * problem.scale * rng.standard_normal(problem.n_params) for _ in range(k)]


def _check(problem):
    xs = _points(problem)
    batched = problem.residuals(xs)
    assert batched.shape == (len(xs), problem.n_values)
    for x, r in zip(xs, batched, strict=True):
        assert np.array_equal(r, problem.residual(x))
    assert problem.costs(xs) == [problem.cost(x) for x in xs]
    assert problem.costs([]) == []


def test_cable_rows_batched_to_the_bit(session):
    data, _ = session
    _check(prepare("irb120", data).problem_on(np.arange(96)))


def test_position_rows_batched_to_the_bit():
    chain = cp.load_chain("ur5")
    data, _ = cp.simulate_positions(chain, cp.parameter_model(chain), 30, seed=2, noise_mm=0.05,
                                    markers_mm=((60.0, 0.0, 40.0), (0.0, 50.0, 30.0)))
    problem = prepare("ur5", data).problem_on(np.arange(len(data)))
    assert problem.points is not None and len(set(problem.points)) == 2  # rows of two markers
    _check(problem)


def test_with_compliances_each_point_on_its_own_deflection(session):
    data, _ = session
    problem = prepare("irb120", data, compliance=Compliance(("joint_2", "joint_3"), cable_tension_n=5.0)).problem_on(np.arange(96))
    assert problem.model.deflection is not None
    _check(problem)


def test_a_robust_cost_is_never_batched_as_the_plain_one(session):
    data, _ = session
    problem = prepare("irb120", data).problem_on(np.arange(96))
    robust = RobustProblem(problem, "huber", 1e-4)
    xs = _points(problem)
    track = Tracker(robust, None)
    assert track.costs(xs) == [robust.cost(x) for x in xs] != problem.costs(xs)
    assert track.nfev == len(xs)


def test_qibas_reaches_the_truth_with_batched_antennae(session, fresh):
    data, _ = session
    problem = prepare("irb120", data).problem_on(np.arange(96)).subset(np.arange(96))
    result = run_estimator("qibas", problem, np.zeros(problem.n_params), seed=0)
    q, true_readings = fresh
    assert np.sqrt(np.mean((problem.model.predict(result.x, q) - true_readings) ** 2)) * 1e3 < 0.06


def test_costs_in_bounded_passes_are_the_same(session, monkeypatch):
    from calib_pin.sensors import problem as problem_module

    data, _ = session
    problem = prepare("irb120", data).problem_on(np.arange(96))
    xs = _points(problem, k=5)
    whole = problem.costs(xs)
    monkeypatch.setattr(problem_module, "BATCH_ROWS", 2 * 96)  # two points a pass: 2 + 2 + 1
    assert problem.costs(xs) == whole == [problem.cost(x) for x in xs]


@pytest.mark.parametrize("example", ["irb120_pose_example.csv", "irb120_contact_example.csv", "irb120_default.csv"])
def test_batched_costs_are_each_sensors_own_cost(example):
    """The searches' batched costs equal the problem's own cost point by point for every
    shipped sensor: a 6-D pose (whitened rotation vector) and a contact set (touches and
    distances) have their own residual, which the plain batch must not replace."""
    from pathlib import Path

    problem = prepare("irb120", Path(__file__).parent.parent / "robots" / example).problem
    rng = np.random.default_rng(3)
    xs = [rng.normal(size=problem.n_params) * problem.scale * 0.1 for _ in range(3)]
    assert problem.costs(xs) == [problem.cost(x) for x in xs]


def test_pose_rows_batched_costs_are_the_weighted_pose_cost():
    """A 6-D pose set's residual is its weighted pose error, not predicted minus the 7
    numbers read: BAS/QIBAS/PSO's batched costs are that residual's."""
    from calib_pin.simulation import simulate_sessions

    chain = cp.load_chain("irb120")
    (data,), _ = simulate_sessions(chain, cp.parameter_model(chain), [20], seed=3, kinds=("pose",))
    problem = prepare("irb120", data).problem_on(np.arange(len(data))).parts[0]
    assert type(problem).__name__ == "PoseProblem"
    _check(problem)


def test_contact_rows_batched_costs_keep_the_distance_rows():
    from calib_pin.simulation import simulate_contacts

    chain = cp.load_chain("irb120")
    data, _ = simulate_contacts(chain, cp.parameter_model(chain), 6, seed=11, noise_mm=0.05)
    problem = prepare("irb120", data).problem_on(np.arange(len(data))).parts[0]
    assert type(problem).__name__ == "ContactProblem"
    _check(problem)


class _OneByOne:
    """The same problem with no batched ``costs``: a search evaluates it one call per
    point (no look-ahead), the reference for the batched and look-ahead path."""

    def __init__(self, problem):
        self._problem = problem

    def __getattr__(self, name):
        if name == "costs":
            raise AttributeError(name)
        return getattr(self._problem, name)


@pytest.mark.parametrize("method", ["qibas", "ekf-qibas", "bas"])
@pytest.mark.parametrize("sensor", ["cable", "position"])
def test_look_ahead_search_is_the_one_by_one_search(session, method, sensor):
    """QIBAS evaluates the next antennae with its interpolated point in one batched call
    (counted only when the beetle moves there): the estimate, iterations, evaluations and
    history are those of the search that evaluates every point on its own, to the bit."""
    if sensor == "cable":
        problem = prepare("irb120", session[0]).problem_on(np.arange(96))
    else:
        chain = cp.load_chain("ur5")
        data, _ = cp.simulate_positions(chain, cp.parameter_model(chain), 40, seed=2, noise_mm=0.05)
        problem = prepare("ur5", data).problem_on(np.arange(len(data)))
    x0 = np.zeros(problem.n_params)
    fast = run_estimator(method, problem, x0, seed=1)
    slow = run_estimator(method, _OneByOne(problem), x0, seed=1)
    assert Tracker(problem).batched and not Tracker(_OneByOne(problem)).batched
    assert np.array_equal(fast.x, slow.x)
    assert (fast.iterations, fast.nfev, fast.stages) == (slow.iterations, slow.nfev, slow.stages)
    assert fast.history == slow.history and fast.evaluations == slow.evaluations


def test_look_ahead_makes_one_call_per_iteration(session, monkeypatch):
    """The look-ahead is used: after the start, QIBAS calls the batched costs once per
    iteration (not twice) while the beetle keeps moving to its interpolated point."""
    problem = prepare("irb120", session[0]).problem_on(np.arange(96))
    calls = []
    batched = type(problem).costs
    monkeypatch.setattr(type(problem), "costs", lambda self, xs: calls.append(len(xs)) or batched(self, xs))
    result = run_estimator("qibas", problem, np.zeros(problem.n_params), seed=0, history=False)
    assert calls[0] == 2 and set(calls[1:]) == {3}  # the first antennae, then z_qi with the next antennae
    assert len(calls) == result.iterations + 1


@pytest.mark.parametrize("robot", ["irb120", "ur5"])
def test_points_many_is_points_one_by_one(robot):
    """Kinematics.points_many (several perturbations in one pass, stacked products) equals
    points under each perturbation to the bit: nominal (None) among them, one point or one
    per pose, one pose or many."""
    chain = cp.load_chain(robot)
    params = cp.parameter_model(chain, "placement")
    rng = np.random.default_rng(7)
    kin = cp.Kinematics(chain)
    for n in (1, 2, 37):
        q = rng.uniform(-2.0, 2.0, size=(n, chain.n_joints))
        deltas = [params.delta_matrices(rng.normal(size=len(params.names)) * params.scale) for _ in range(3)] + [None]
        for points in ([rng.normal(size=3) * 0.1 for _ in deltas], [rng.normal(size=(n, 3)) * 0.1 for _ in deltas],
                       [rng.normal(size=3) * 0.1, rng.normal(size=(n, 3)) * 0.1, np.zeros(3), np.ones((n, 3))]):
            many = kin.points_many(deltas, q, points)
            for delta, point, got in zip(deltas, points, many, strict=True):
                kin.set_perturbation(delta)
                assert np.array_equal(got, kin.points(q, point)[0])


# --- the faster paths of the position searches (EKF-QIBAS), against their references, to the bit ---


def _position_problem(markers_mm=((60.0, 0.0, 40.0), (0.0, 50.0, 30.0)), n=20, seed=3):
    chain = cp.load_chain("ur5")
    data, _ = cp.simulate_positions(chain, cp.parameter_model(chain), n, seed=seed, noise_mm=0.05,
                                    markers_mm=markers_mm)
    return prepare("ur5", data).problem_on(np.arange(len(data))).parts[0]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def test_interpolated_point_is_the_reference_vertex_to_the_bit():
    from calib_pin.estimators.qibas import _vertex_about_best, interpolated_point, parabola_vertex

    rng = np.random.default_rng(5)
    for t in range(3000):
        b = rng.standard_normal(int(rng.integers(1, 40)))
        b /= np.linalg.norm(b)
        if t % 5 == 0:  # exact zeros of both signs and components at the distinctness threshold
            b[rng.integers(len(b))] = rng.choice([0.0, -0.0, 1e-10, -1e-10, 5e-10, 1e-9])
        f = [float(rng.choice([rng.random(), 1.0, 0.0, 1e-12 * rng.random(), 1.0 + rng.random()])) for _ in range(3)]
        with np.errstate(all="ignore"):
            reference = parabola_vertex(-b, b, 0.0, *f)
            fast = _vertex_about_best(b, *f)
        assert _same(reference[0], fast[0]) and _same(reference[1], fast[1])
        z, z_bas, m = rng.standard_normal(len(b)), rng.standard_normal(len(b)), float(rng.random())
        unit = f[2] if f[2] > 0 else 1.0
        with np.errstate(all="ignore"):
            vertex, valid = parabola_vertex(-b, b, 0.0, f[0] / unit, f[1] / unit, f[2] / unit)
            assert _same(interpolated_point(z, m, b, f[2], f[0], f[1], z_bas), np.where(valid, z + m * vertex, z_bas))


def test_stacked_deltas_and_points_are_the_listed_ones_to_the_bit():
    problem = _position_problem()
    model, kin = problem.model, problem.model._kin
    xs = _points(problem, k=3, seed=4)
    robot = [model.robot(x) for x in xs]
    stacked = model.params.delta_matrices_many(robot)
    assert _same(stacked, np.array([model.params.delta_matrices(r) for r in robot]))
    rows = [model.device.markers[problem.points] + 1e-3 * j for j in range(3)]
    listed = kin.points_many(list(stacked), problem.q, rows)
    assert _same(kin.points_many(stacked, problem.q, np.array(rows)), listed)
    assert _same(kin.points_many(stacked, problem.q, np.array([r[0] for r in rows])),
                 kin.points_many(list(stacked), problem.q, [r[0] for r in rows]))
    for delta, row, got in zip(stacked, rows, listed, strict=True):
        kin.set_perturbation(delta)
        assert _same(kin.points(problem.q, row)[0], got)


def test_position_geometries_of_many_points_are_geometry_at_to_the_bit():
    from calib_pin.sensors.position import PositionModel

    problem = _position_problem()
    fitted = problem.model
    index = problem.points
    for estimate in (("device", "markers"), ("device",), ("markers",), ()):
        model = PositionModel(fitted.chain, fitted.params, fitted.device, estimate=estimate)
        xs = [0.5 * model.scale * np.random.default_rng(j).standard_normal(model.n_params) for j in range(3)]
        for given in (xs, np.array(xs), [xs[0], None, xs[2]]):  # a list, stacked, a nominal point among them
            rotations_t, translations, rows = model._geometries_many(given, index)
            for x, rotation_t, translation, row in zip(given, rotations_t, translations, rows, strict=True):
                device = model.geometry_at(x)
                assert _same(rotation_t, device.frame.rotation.T) and _same(translation, device.frame.translation)
                assert _same(row, device.markers[index])
        assert [_same(a, model.predict(x, problem.q, index)) for a, x in
                zip(model.predict_many(xs, problem.q, index), xs, strict=True)] == [True] * 3


def test_position_problem_starts_from_the_fit_to_the_bit():
    from calib_pin.sensors.position import PositionModel, fit_device

    problem = _position_problem()
    model = problem.model
    device = fit_device(model.chain, model.params, problem.q, problem.readings, problem.points, model.device.labels)
    assert _same(model.device.frame.homogeneous, device.frame.homogeneous) and _same(model.device.markers, device.markers)
    fresh = cp.SetProblem(PositionModel(model.chain, model.params, device), problem.q, problem.readings,
                                  problem.points)
    assert fresh.model.names == model.names and _same(fresh.scale, model.scale)
    for x in [np.zeros(problem.n_params), *_points(problem, k=2)]:
        assert _same(problem.residual(x), fresh.residual(x)) and _same(problem.jacobian(x), fresh.jacobian(x))


def test_best_candidate_is_the_one_min_picks():
    """BAS/QIBAS's best candidate (bas._best, without the list and key calls) is the one
    min(candidates, key=cost) picks: the first of the lowest, ties and NaNs included; the
    BAS point appended after is the min of the four."""
    from calib_pin.estimators.bas import _best

    rng = np.random.default_rng(9)
    values = [0.0, 1.0, 1.0, 2.0, float("nan"), float("inf"), -0.0]
    for _ in range(2000):
        costs = [float(rng.choice(values)) if rng.random() < 0.5 else float(rng.random()) for _ in range(4)]
        points = [np.full(2, j) for j in range(4)]
        for n in (2, 3, 4):
            candidates = list(zip(costs[:n], points[:n], strict=True))
            f, z = _best(*[v for c in candidates for v in c])
            f_ref, z_ref = min(candidates, key=lambda c: c[0])
            assert z is z_ref and (f == f_ref or (np.isnan(f) and np.isnan(f_ref)))
        three = list(zip(costs[:3], points[:3], strict=True))
        f3, z3 = _best(*[v for c in three for v in c])
        assert _best(f3, z3, costs[3], points[3])[1] is min([*three, (costs[3], points[3])], key=lambda c: c[0])[1]


def test_zero_measurement_as_a_number_is_the_zero_vector_to_the_bit():
    """The EKF hands filterpy its zero measurement as 0.0: the update (innovation 0.0 - h(x),
    gain, state, covariance) has the bits of the update with zeros((m, 1)), for rows of 1 and 3 values."""
    from calib_pin.estimators.ekf import ExtendedKalmanFilter

    rng = np.random.default_rng(2)
    for m in (1, 3):
        h, r = rng.normal(size=(m, 5)), rng.normal(size=(m, 1))
        filters = []
        for zero in (0.0, np.zeros((m, 1))):
            kf = ExtendedKalmanFilter(dim_x=5, dim_z=m)
            kf.x, kf.P = np.full((5, 1), 0.1), np.eye(5) * 2.0
            for _ in range(3):
                kf.update(zero, HJacobian=lambda z: h, Hx=lambda z: r + h @ z, R=np.eye(m) * 1e-2)
            filters.append(kf)
        assert _same(filters[0].x, filters[1].x) and _same(filters[0].P, filters[1].P)
        assert _same(filters[0].y, filters[1].y) and _same(filters[0].K, filters[1].K)

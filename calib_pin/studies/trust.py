"""Do a calibration's numbers hold against the truth? (``benchmark.py --trust``).

Simulated arms whose true deviations are drawn from the stated prior, each sensor alone
and mixed, each fitted by several methods over several seeds:

- **gauge**: along the directions the data determines, the exported robot against the
  truth moved to the same gauge (its sensor refitted with the true robot, then
  :func:`~calib_pin.calibration.gauge.resolve_gauge`), in noise standard deviations
  (``z``: about 1); along those it does not, the robot's distance from its start in prior
  units (``off``: about 0);
- **methods**: the RMS distance at a 150 mm tool between each method's robot and LM's, in
  units of the predicted noise part there (about 1 or less: the same robot within the noise);
- **accuracy**: the predicted RMS error at three points (the measured one, the flange
  origin, a 150 mm tool) against the true error at 1000 fresh poses, base frame;
- **intervals**: over many seeds, the share of the 95 % intervals (deviations determined
  alone, and combinations) that hold the truth in the gauge.

Every number comes from a seeded run; nothing is written into the repository.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..analysis.uncertainty import Z95
from ..calibration.gauge import resolve_gauge
from ..calibration.prepare import prepare
from ..calibration.result import CalibrationResult
from ..calibration.sets import FitSet
from ..calibration.solve import solve
from ..estimators.active_set import Fixed
from ..parameters import parameter_model
from ..parameters.prior import Prior
from ..robot import load_chain
from ..robot.kinematics import Kinematics
from ..robot.poses import random_poses
from ..sensors import sensor_for
from ..sensors.cable import DEFAULT_ANCHOR_MM, Drawstring
from ..sensors.contact import default_fixtures
from ..simulation.simulator import simulate_set

#: Fresh poses the true error is measured at.
FRESH = 1000
#: The tool point every case also predicts at, end frame [mm].
TOOL_MM = (0.0, 0.0, 150.0)
#: Reading noise of the simulated sets, 1 sigma [mm].
NOISE_MM = 0.05


@dataclass(frozen=True)
class SetSpec:
    """One simulated set of a case: its sensor kind, poses and geometry (None: the sensor's default)."""

    kind: str
    poses: int
    geometry: Any = None


@dataclass(frozen=True)
class Case:
    """A robot and its sets."""

    name: str
    robot: str
    sets: tuple[SetSpec, ...]
    end_frame: str | None = None


def _hook(tool_mm: Sequence[float]) -> Drawstring:
    return Drawstring(np.asarray(DEFAULT_ANCHOR_MM) * 1e-3, np.asarray(tool_mm, dtype=float) * 1e-3, 0.0)


def _moved_plate() -> Any:
    """The default contact fixtures moved 250 mm along y and turned 20 deg about z (a second placement)."""
    fx = default_fixtures()
    c, s = np.cos(np.radians(20.0)), np.sin(np.radians(20.0))
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    shift = np.array([0.0, 0.25, 0.0]) * np.sign(-fx.points[:, 1].mean() or 1.0)
    normals = fx.normals @ turn.T
    offsets = fx.offsets + normals @ shift
    return dataclasses.replace(fx, points=fx.points @ turn.T + shift, normals=normals, offsets=offsets)


def cases(robots: Sequence[str] = ("irb120", "ur5", "panda")) -> list[Case]:
    """The study's cases for each robot.

    The study's cases for each robot: a cable hooked at the flange and at 50 mm, three
    tracker markers, 6-D poses, contact fixtures at one placement and at two, and a cable
    with markers in one fit.
    """
    out = []
    for robot in robots:
        end = "panda_hand_tcp" if robot == "panda" else None
        out += [
            Case(f"{robot} cable at flange", robot, (SetSpec("cable", 120, _hook((0, 0, 0))),), end),
            Case(f"{robot} cable at 50 mm", robot, (SetSpec("cable", 120, _hook((0, 0, 50))),), end),
            Case(f"{robot} markers", robot, (SetSpec("position", 60),), end),
            Case(f"{robot} 6-D poses", robot, (SetSpec("pose", 60),), end),
            Case(f"{robot} contact, one placement", robot, (SetSpec("contact", 60),), end),
            Case(f"{robot} contact, two placements", robot,
                 (SetSpec("contact", 40), SetSpec("contact", 40, _moved_plate())), end),
            Case(f"{robot} cable + markers", robot, (SetSpec("cable", 80, _hook((0, 0, 50))), SetSpec("position", 40)),
                 end),
        ]
    return out


@dataclass(frozen=True)
class Run:
    """One case fitted by one method on one seed.

    Attributes:
        case, method, seed: What ran.
        test_rmse: Held-out error (pooled when the units agree), [mm].
        z: RMS over the determined directions of (estimate - truth in the gauge) in noise
            standard deviations (about 1).
        off: Largest distance of the robot from its start along the directions not
            determined, in prior units (about 0).
        points: Per point (name, predicted RMS, true RMS, predicted registered, true
            registered, determined), [mm].
        tool_x: The robot's deviations (for the methods' agreement), SI.
        tool_noise: The predicted noise part at the 150 mm tool, [mm].
        covered, intervals: Intervals holding the truth in the gauge, and intervals shown.
    """

    case: str
    method: str
    seed: int
    test_rmse: float
    z: float
    off: float
    points: tuple[tuple[str, float, float, float, float, bool], ...]
    tool_x: np.ndarray = field(repr=False)
    tool_noise: float = 0.0
    covered: int = 0
    intervals: int = 0


def _positions(chain: Any, params: Any, x: np.ndarray, q: np.ndarray, point: np.ndarray) -> np.ndarray:
    kin = Kinematics(chain)
    kin.set_perturbation(params.delta_matrices(x))
    return kin.points(q, point)[0]


def _registered(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a`` (n, 3) moved by the best rigid motion onto ``b``."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    return (a - ca) @ (vt.T @ np.diag([1.0, 1.0, d]) @ u.T).T + cb


def _truth_in_gauge(result: CalibrationResult, true_x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The true robot with its sensors refitted, and that moved to the calibration's gauge.

    The true robot with each sensor's unknowns fitted to the training rows with it held,
    and that moved to the calibration's gauge, SI (n_params,) each.
    """
    training = result.problem.subset(result.train)
    model = training.model
    x = np.zeros(training.n_params)
    x[: len(true_x)] = true_x
    sensor = np.arange(model.sensor_start, training.n_params)
    if len(sensor):
        from scipy.optimize import least_squares

        part = Fixed(training, sensor, x)
        x = part.expand(least_squares(part.residual, x[sensor], jac=part.jacobian, method="lm",
                                      x_scale=part.scale).x)
    held = result.estimate.extras.get("fixed", ())
    free = np.setdiff1d(np.arange(training.n_params), np.asarray(held, dtype=int))
    moved, _ = resolve_gauge(training, x, np.asarray(result.x0), free, result.prior, result.noise)
    return x, moved


def _coverage(result: CalibrationResult, truth: np.ndarray) -> tuple[int, int]:
    """(intervals holding ``truth``, intervals) of the identified deviations and the combinations."""
    u = result.uncertainty
    assert u is not None
    hits = total = 0
    for i in range(result.problem.model.sensor_start):
        if u.status[i] == "identified":
            total += 1
            hits += int(abs(truth[i] - u.x[i]) <= Z95 * u.std[i])
    for c in u.combinations:
        true = sum(k * truth[i] for i, k in c.terms)
        total += 1
        hits += int(abs(true - c.value) <= Z95 * c.std)
    return hits, total


def run_case(case: Case, method: str, seed: int, prior: Prior | None = None) -> Run:
    """Simulate ``case`` (truth drawn from ``prior``), fit it with ``method``, score it."""
    prior = Prior() if prior is None else prior
    chain = load_chain(case.robot, end_frame=case.end_frame)
    params = parameter_model(chain)
    rng = np.random.default_rng(10_000 + seed)
    true_x = rng.normal(size=len(params.names)) * prior.sigma(params.units, params.scale)
    sets = []
    for k, spec in enumerate(case.sets):
        data, _ = simulate_set(sensor_for(spec.kind), chain, params, spec.poses, seed * 10 + k, spec.geometry,
                               noise_mm=NOISE_MM, true_x=true_x)
        sets.append(FitSet(data, label=f"s{k + 1}"))
    calibration = prepare(case.robot, sets if len(sets) > 1 else sets[0].data, end_frame=chain.end_frame,
                          prior=prior)
    result = solve(calibration, method, seed=seed)
    true_full, truth = _truth_in_gauge(result, true_x)
    split = result.determined
    d = (result.x[split.robot] - truth[split.robot]) / split.sigma
    along = split.vt[: split.rank] @ d * split.singular_values[: split.rank] / split.noise
    start = np.asarray(result.x0)
    off = np.abs(split.vt[split.rank:] @ ((result.x[split.robot] - start[split.robot]) / split.sigma))
    q = random_poses(chain, FRESH, np.random.default_rng(seed + 77))
    accuracy = result.accuracy
    tool = dataclasses.replace(result, tcp=(np.asarray(TOOL_MM) * 1e-3,)).accuracy
    assert accuracy is not None and tool is not None
    n = len(params.names)
    first = result.sets[0]
    true_point = first.model.measured_points(result.problem.model.part_x(true_full, 0))[0][1]
    flange = next(p for p in accuracy.points if not np.any(p.point))
    rows = []
    for name, p, at_truth in (("measured point", accuracy.points[0], true_point), ("flange origin", flange, None),
                              ("150 mm tool", tool.points[0], None)):
        est = _positions(chain, params, result.x[:n], q, p.point)
        true = _positions(chain, params, true_x, q, p.point if at_truth is None else at_truth)
        rows.append((name, p.rms * 1e3, float(np.sqrt(np.mean(np.sum((est - true) ** 2, axis=1)))) * 1e3,
                     p.registered * 1e3, float(np.sqrt(np.mean(np.sum((_registered(est, true) - true) ** 2,
                                                                        axis=1)))) * 1e3, p.determined))
    hits, total = _coverage(result, truth)
    test = result.metrics.get("test", {}).get("after")
    return Run(case.name, method, seed, test.rmse_mm if test is not None else float("nan"),
               float(np.sqrt(np.mean(along**2))) if len(along) else 0.0, float(off.max(initial=0.0)),
               tuple(rows), result.x[:n].copy(), tool.points[0].noise * 1e3, hits, total)


def agreement(runs: Sequence[Run], case: Case) -> dict[tuple[str, int], float]:
    """Per (method, seed): the distance at the 150 mm tool from LM's robot, in noise units.

    Per (method, seed): the RMS distance at the 150 mm tool from LM's robot of the same
    seed, in units of the predicted noise part there.
    """
    chain = load_chain(case.robot, end_frame=case.end_frame)
    params = parameter_model(chain)
    q = random_poses(chain, 300, np.random.default_rng(5))
    tool = np.asarray(TOOL_MM) * 1e-3
    lm = {r.seed: r for r in runs if r.method == "lm"}
    out = {}
    for r in runs:
        if r.method == "lm" or r.seed not in lm:
            continue
        a = _positions(chain, params, r.tool_x, q, tool)
        b = _positions(chain, params, lm[r.seed].tool_x, q, tool)
        out[(r.method, r.seed)] = float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1)))) * 1e3 / max(r.tool_noise,
                                                                                                   1e-12)
    return out


def study(robots: Sequence[str] = ("irb120", "ur5", "panda"), methods: Sequence[str] = ("lm", "ekf-qibas", "de"),
          seeds: int = 5, coverage_seeds: int = 20,
          notify: Callable[[str], Any] | None = None) -> list[str]:
    """The study's table, one line per case and method, then the summary lines."""
    lines = ["| case | method | test mm | z determined (~1) | off undetermined (~0) | methods vs LM "
             "(noise units) | measured pred/true mm | flange pred/true mm | 150 mm tool pred/true mm |",
             "|---|---|---|---|---|---|---|---|---|"]
    ratios: list[float] = []
    every: list[float] = []
    flagged = unflagged = 0
    worst_off, worst_agree = 0.0, 0.0
    hits = total = 0
    for case in cases(robots):
        runs = []
        for method in methods:
            for seed in range(seeds):
                runs.append(run_case(case, method, seed))
                if notify is not None:
                    notify(f"{case.name}, {method}, seed {seed}")
        agree = agreement(runs, case)
        for method in methods:
            mine = [r for r in runs if r.method == method]
            cells = []
            for k in range(3):
                pred = np.array([r.points[k][1] for r in mine])
                true = np.array([r.points[k][2] for r in mine])
                determined = all(r.points[k][5] for r in mine)
                rms_pred, rms_true = float(np.sqrt(np.mean(pred**2))), float(np.sqrt(np.mean(true**2)))
                cells.append(f"{rms_pred:.3f}/{rms_true:.3f}" + ("" if determined else " (not determined)"))
                every.append(rms_pred / rms_true)
                if determined:
                    ratios.append(rms_pred / rms_true)
                else:
                    flagged += 1
                unflagged += int(determined)
            vs = [v for (m, _), v in agree.items() if m == method]
            worst_off = max(worst_off, max(r.off for r in mine))
            worst_agree = max([worst_agree, *vs])
            lines.append(f"| {case.name} | {method} | {np.mean([r.test_rmse for r in mine]):.4f} | "
                         f"{np.mean([r.z for r in mine]):.2f} | {max(r.off for r in mine):.1e} | "
                         f"{max(vs):.2f} | " if vs else
                         f"| {case.name} | {method} | {np.mean([r.test_rmse for r in mine]):.4f} | "
                         f"{np.mean([r.z for r in mine]):.2f} | {max(r.off for r in mine):.1e} | — | ")
            lines[-1] += " | ".join(cells) + " |"
        for seed in range(coverage_seeds):
            r = next((r for r in runs if r.method == "lm" and r.seed == seed), None) or run_case(case, "lm", seed)
            hits, total = hits + r.covered, total + r.intervals
    within = sum(1 for v in ratios if 1 / 1.5 <= v <= 1.5)
    all_within = sum(1 for v in every if 1 / 1.5 <= v <= 1.5)
    lines += ["", f"accuracy: predicted/true RMS within a factor 1.5 for {within} of {len(ratios)} determined "
              f"(case, method, point) cells (ratios {min(ratios, default=1):.2f} to {max(ratios, default=1):.2f}); "
              f"{flagged} cells read 'not determined'; over every cell {all_within} of {len(every)} within 1.5 "
              f"(ratios {min(every):.2f} to {max(every):.2f})",
              f"gauge: the robot's largest distance from its start along what the data does not determine "
              f"{worst_off:.1e} prior units; the methods' largest distance from LM at the 150 mm tool "
              f"{worst_agree:.2f} times the predicted noise there",
              f"intervals: {hits} of {total} 95 % intervals ({100 * hits / max(total, 1):.1f} %) hold the truth "
              f"in the gauge over {coverage_seeds} seeds per case (LM)"]
    return lines


def wu_splits(splits: int = 10, compliance: Sequence[str] = ("joint_2", "joint_3")) -> list[str]:
    """On the real IRB120 set: the predicted error of a fresh reading against the held-out error.

    On the real IRB120 set (robots/irb120_wu2015.csv, compliance of ``compliance``): the
    predicted error of a fresh tracker reading (the markers' registered prediction and the
    tracker's repeatability) against the held-out error, per split.
    """
    from pathlib import Path

    wu = Path(__file__).resolve().parents[2] / "robots" / "irb120_wu2015.csv"
    calibration = prepare("irb120", str(wu), compliance=list(compliance))
    lines = ["| split | held-out RMSE mm | predicted mm | ratio | repeatability mm (from) |", "|---|---|---|---|---|"]
    ratios = []
    for seed in range(splits):
        result = solve(calibration, "lm", seed=seed)
        accuracy = result.predict_accuracy(held_out=False)  # the held-out rows check the prediction
        assert accuracy is not None
        markers = [p for p in accuracy.points if p.name.startswith("marker")]
        robot = float(np.sqrt(np.mean([p.registered**2 for p in markers])))
        rep = accuracy.sets[0].repeatability
        reading = float(np.sqrt(robot**2 + 3 * (rep.sigma or 0.0) ** 2)) * 1e3
        held = result.metrics["test"]["after"].rmse_mm
        ratios.append(reading / held)
        lines.append(f"| {seed} | {held:.4f} | {reading:.4f} | {reading / held:.2f} | "
                     f"{(rep.sigma or float('nan')) * 1e3:.4f} ({rep.source}) |")
    lines.append(f"\nratio predicted/held-out: {min(ratios):.2f} to {max(ratios):.2f} over {splits} splits "
                 f"(median {float(np.median(ratios)):.2f})")
    return lines

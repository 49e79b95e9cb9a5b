"""The joint calibration against hand-eye alone, on the same simulated camera data (``benchmark.py --hand-eye``).

Each case simulates a camera set (40 poses, 0.1 px) of a robot, eye in hand or eye to hand,
with the robot's deviations (``deviations``), with its last link nominal (``last link
nominal``: the last joint's and the end frame's deviations zero) or with none (``nominal``).
On it:

- **joint**: calib-pin's fit of the robot and both placements (``lm``, every row);
- **OpenCV**: each of OpenCV's hand-eye methods (``cv2.calibrateRobotWorldHandEye``: Shah,
  Li; ``cv2.calibrateHandEye``: Tsai, Park, Horaud, Andreff, Daniilidis) on PnP's board
  poses and the nominal robot, the best against the truth kept (the most favourable choice
  for it);
- **polished**: the joint fit's start, the best of them refined on the pixels with the
  nominal robot (hand-eye alone done as well as it can be).

Each predicts the camera's pose relative to the board at fresh poses (those the true robot's
camera sees 12 corners or more at): the board's pose in the camera frame, T_CW, what PnP
reads of an image; the figures are the RMS translation [mm] and rotation [deg] against the
truth. The placement on the flange (the camera eye in hand, the board eye
to hand) shares a gauge with the last link's deviations, so it is compared with the truth
only on a robot whose last link is nominal: those rows only.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..calibration.solve import calibrate
from ..parameters import ParameterModel, parameter_model
from ..robot import Chain, load_chain
from ..robot.poses import random_poses
from ..sensors import SENSORS
from ..sensors.camera_view import MIN_SEEN, seen
from ..simulation.simulator import simulate_set

#: The robot cases (module docstring).
CASES = ("deviations", "last link nominal", "nominal")
#: Poses and pixel noise [px] of each simulated set; fresh poses the predictions are scored at.
POSES, NOISE_PX, FRESH = 40, 0.1, 150
#: A fresh pose sees at least this many corners of the true board.
FRESH_CORNERS = MIN_SEEN
#: The sentence the output carries about the flange placement.
FLANGE_NOTE = ("The placement on the flange (the hand-eye transform eye in hand, the board's eye to hand) shares a "
               "gauge with the last link's deviations: it is compared with the truth only on a robot whose last "
               "link is nominal (rows 'last link nominal'); elsewhere '-'")


def camera_sensor() -> Any:
    """The registered sensor that solves hand-eye alone (its ``hand_eye_alone``): the camera."""
    return next(s for s in SENSORS.values() if hasattr(s, "hand_eye_alone"))


@dataclass(frozen=True)
class HandEyeRow:
    """One case: the camera's pose at fresh poses by each way, and (last link nominal) the flange placement.

    Attributes:
        robot, mount, case, seed: The case.
        rows: Corners (rows) of the simulated set.
        joint, opencv, polished: RMS error of the camera's pose relative to the board (T_CW) at
            the fresh poses, (mm, deg), by the joint fit, OpenCV's best method, hand-eye polished.
        method: OpenCV's best method.
        flange_joint, flange_opencv: The flange placement's error against the truth (mm,
            deg), by the joint fit and OpenCV's best; None unless the last link is nominal.
        fit_s: The joint fit's estimation time [s].
    """

    robot: str
    mount: str
    case: str
    seed: int
    rows: int
    joint: tuple[float, float]
    opencv: tuple[float, float]
    method: str
    polished: tuple[float, float]
    flange_joint: tuple[float, float] | None
    flange_opencv: tuple[float, float] | None
    fit_s: float


def last_link(chain: Chain, params: ParameterModel) -> np.ndarray:
    """Which of the parameter model's deviations are the last link's: the last joint's and the end frame's."""
    n, last, end = chain.n_joints, chain.joint_names[-1], chain.end_frame
    return np.array([name.endswith(f"_{n}") or name.split(".")[0] in (last, end) for name in params.names])


def pose_rms(a: Sequence[pin.SE3], b: Sequence[pin.SE3]) -> tuple[float, float]:
    """RMS translation [mm] and rotation [deg] between two lists of placements."""
    t = np.sqrt(np.mean([np.sum((x.translation - y.translation) ** 2) for x, y in zip(a, b, strict=True)])) * 1e3
    r = np.sqrt(np.mean([np.sum(pin.log3(x.rotation.T @ y.rotation) ** 2) for x, y in zip(a, b, strict=True)]))
    return float(t), float(np.rad2deg(r))


def flange_placement(rig: Any) -> pin.SE3:
    """The placement on the flange of a camera set-up: the camera's eye in hand, the board's eye to hand."""
    return rig.camera if rig.in_hand else rig.board_pose


def simulated_case(robot: str, mount: str, case: str, seed: int, poses: int, noise_px: float
                   ) -> tuple[Chain, ParameterModel, Any, Any]:
    """A case's simulated camera set and its truth: the robot's deviations, its last link nominal, or none.

    Returns:
        The chain, its parameter model, the set and the simulator's truth.

    Raises:
        ValueError: an unknown case.
    """
    if case not in CASES:
        raise ValueError(f"unknown case '{case}' (valid: {', '.join(CASES)})")
    sensor = camera_sensor()
    chain = load_chain(robot)
    params = parameter_model(chain)
    setup = {"camera_mount": mount, "noise_px": noise_px}
    rmse = 0.0 if case == "nominal" else 2.0
    data, truth = simulate_set(sensor, chain, params, poses, seed, setup=setup, nominal_rmse_mm=rmse)
    if case == "last link nominal":
        x = np.where(last_link(chain, params), 0.0, truth.x)
        data, truth = simulate_set(sensor, chain, params, poses, seed, setup=setup, nominal_rmse_mm=rmse, true_x=x)
    return chain, params, data, truth


def fresh_poses(chain: Chain, true_model: Any, x_true: np.ndarray, seed: int, fresh: int) -> np.ndarray:
    """``fresh`` random poses [rad], shape (fresh, n_joints), at which the true camera sees FRESH_CORNERS corners or more."""
    q = random_poses(chain, 40 * fresh, np.random.default_rng(seed + 1000))
    return q[seen(true_model, x_true, q).sum(axis=1) >= FRESH_CORNERS][:fresh]


def opencv_best(model: Any, data: Any, q: np.ndarray, true_poses: Sequence[pin.SE3]
                ) -> tuple[dict[str, Any], dict[str, tuple[float, float]], str]:
    """OpenCV's hand-eye methods on ``data``'s PnP board poses and the nominal robot, scored at q against ``true_poses``.

    Returns:
        Each method's camera model, its T_CW error at q (RMS mm, deg), and the method nearest the truth
        in translation.
    """
    sensor = camera_sensor()
    corners = np.asarray(model.point_index(data.point_ids, len(data)), dtype=int)
    alone = {name: sensor(model.chain, model.params, rig, estimate=()) for name, rig in
             model.hand_eye_alone(data.q, np.asarray(data.values, dtype=float), corners).items()}
    scored = {name: pose_rms(m.camera_to_board(None, q), true_poses) for name, m in alone.items()}
    return alone, scored, min(scored, key=lambda name: scored[name][0])


def compare(robot: str, mount: str, case: str, seed: int = 1, poses: int = POSES, noise_px: float = NOISE_PX,
            fresh: int = FRESH) -> HandEyeRow:
    """One case of the study (module docstring), seeded.

    Raises:
        ValueError: an unknown case.
    """
    chain, params, data, truth = simulated_case(robot, mount, case, seed, poses, noise_px)
    result = calibrate(robot, data, method="lm", test_fraction=0.0, seed=seed)
    fitted = result.sets[0]
    model = fitted.model
    true_model: Any = truth.model(chain, params)
    q = fresh_poses(chain, true_model, truth.x_model, seed, fresh)
    true_poses = true_model.camera_to_board(truth.x_model, q)

    def error(m: Any, x: Any) -> tuple[float, float]:
        return pose_rms(m.camera_to_board(x, q), true_poses)

    alone, scored, method = opencv_best(model, data, q, true_poses)
    flange = None
    if case == "last link nominal":
        true_flange = flange_placement(truth.sensor)
        flange = (pose_rms([flange_placement(model.geometry_at(fitted.x))], [true_flange]),
                  pose_rms([flange_placement(alone[method].rig)], [true_flange]))
    return HandEyeRow(robot, mount, case, seed, len(data), error(model, fitted.x), scored[method], method,
                      error(model, None), flange[0] if flange else None, flange[1] if flange else None,
                      float(result.estimate.time_s))


def each_case(run: Callable[[str, str, str, int], Any], robots: Sequence[str], mounts: Sequence[str],
              cases: Sequence[str], seeds: Sequence[int], notify: Callable[[str], Any] | None = None) -> list[Any]:
    """``run(robot, mount, case, seed)`` of every robot, mount, case and seed, in that order (a camera study's loop)."""
    rows = []
    for robot in robots:
        for mount in mounts:
            for case in cases:
                for seed in seeds:
                    if notify is not None:
                        notify(f"{robot}, {mount}, {case}, seed {seed}")
                    rows.append(run(robot, mount, case, seed))
    return rows


def study(robots: Sequence[str] = ("irb120", "ur5"), mounts: Sequence[str] = ("eye-in-hand", "eye-to-hand"),
          cases: Sequence[str] = CASES, seeds: Sequence[int] = (1, 2, 3),
          notify: Callable[[str], Any] | None = None) -> list[HandEyeRow]:
    """Every case of the study, each robot, mount, case and seed."""
    return each_case(compare, robots, mounts, cases, seeds, notify)


def _cell(pair: tuple[float, float] | None) -> str:
    return "-" if pair is None else f"{pair[0]:.3f} / {pair[1]:.4f}"


def format_rows(rows: Sequence[HandEyeRow]) -> str:
    """The study as a Markdown table, medians over the seeds of each robot, mount and case, and its notes."""
    groups: dict[tuple[str, str, str], list[HandEyeRow]] = {}
    for r in rows:
        groups.setdefault((r.robot, r.mount, r.case), []).append(r)

    def median(values: list[tuple[float, float] | None]) -> tuple[float, float] | None:
        given = [v for v in values if v is not None]
        return (float(np.median([v[0] for v in given])), float(np.median([v[1] for v in given]))) if given else None

    lines = ["| robot | mount | robot case | joint fit mm / deg | OpenCV best mm / deg (method) | hand-eye polished "
             "mm / deg | flange placement, joint / OpenCV, mm / deg |", "|---|---|---|---|---|---|---|"]
    for (robot, mount, case), group in groups.items():
        methods = ", ".join(dict.fromkeys(r.method for r in group))
        flange = median([r.flange_joint for r in group]), median([r.flange_opencv for r in group])
        lines.append(f"| {robot} | {mount} | {case} | {_cell(median([r.joint for r in group]))} | "
                     f"{_cell(median([r.opencv for r in group]))} ({methods}) | "
                     f"{_cell(median([r.polished for r in group]))} | "
                     f"{'-' if flange[0] is None else _cell(flange[0]) + ' vs ' + _cell(flange[1])} |")
    seeds = sorted({r.seed for r in rows})
    lines += ["", f"The camera's pose relative to the board (T_CW) at {FRESH} fresh poses, RMS against the truth, median of "
              f"seeds {', '.join(map(str, seeds))}; {POSES} poses at {NOISE_PX:g} px each. OpenCV's best: the method "
              "nearest the truth in each seed, on PnP's board poses and the nominal robot. Hand-eye polished: the best "
              "refined on the pixels with the nominal robot (the joint fit's start).", FLANGE_NOTE + "."]
    return "\n".join(lines)


__all__ = ["CASES", "FLANGE_NOTE", "HandEyeRow", "camera_sensor", "compare", "each_case", "flange_placement",
           "format_rows", "fresh_poses", "last_link", "opencv_best", "pose_rms", "simulated_case", "study"]

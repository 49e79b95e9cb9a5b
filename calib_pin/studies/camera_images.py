"""Rendered images, detected and calibrated, scored against the truth (``benchmark --images``).

Each case simulates a camera set of a robot (40 poses, eye in hand or eye to hand) with the
robot's deviations (``deviations``) or with its last link nominal (``last link nominal``: the
last joint's and the end frame's deviations zero). Its simulated corners are not used: each
pose's image is rendered from the true robot and camera (:func:`~calib_pin.sensors.camera_render.render_images`:
the board's printed face warped into the camera, blur and grey-level noise), its ChArUco corners
found by OpenCV (:func:`~calib_pin.sensors.camera_detect.find_corners`), and those detected corners
make the set (``opencv_corners``: OpenCV's own corners, not refined again clear of the
markers, for a comparison). On it:

- **fit**: calib-pin's joint fit of the robot and both placements (``lm``, every row, with
  the robust :data:`LOSS` that ``detect`` recommends for detected corners), and the same fit
  with the plain squares (``linear``) beside it;
- **oracle**: Levenberg-Marquardt started from the true robot and the true placements, on the
  same detected rows with the same loss (what the detected corners allow at best);
- **OpenCV**: each of OpenCV's hand-eye methods on PnP's board poses and the nominal robot, the
  best against the truth kept (:mod:`.hand_eye`);
- **intrinsics**: the fit again with the lens given off (fx + 6, fy - 5, cx + 4 px, k1 + 0.01)
  and estimated with the rest.

Scored at fresh poses (those the true camera sees 12 corners or more at): the robot's error,
gauge-free (:func:`gauge_free_rms`), at the flange origin and at the camera (the camera's
optical centre eye in hand, the board's middle on the flange eye to hand), fit against oracle;
the camera's pose relative to the board (T_CW) against the truth, RMS translation [mm] and
rotation [deg]; the intrinsics' largest error in their reported standard deviations. The
placement on the flange shares a gauge with the last link's deviations, so it is compared with
the truth only on the robot whose last link is nominal (:data:`~.hand_eye.FLANGE_NOTE`).
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.stats import binom, norm

from ..calibration.solve import calibrate
from ..estimators import get_method, run_method
from ..measurements import MeasurementSet
from ..sensors.camera_detect import find_corners
from ..sensors.camera_render import render_images
from ..sensors.camera_rig import MIN_CORNERS
from ..sensors.lens import OPENCV_EXTRA, Intrinsics
from ..util.optional import require
from .hand_eye import (
    FLANGE_NOTE,
    camera_sensor,
    each_case,
    flange_placement,
    fresh_poses,
    opencv_best,
    pose_rms,
    simulated_case,
)

#: The robot cases (module docstring).
CASES = ("deviations", "last link nominal")
#: Poses of each simulated set; fresh poses the predictions are scored at.
POSES, FRESH = 40, 150
#: The lens the intrinsics fit starts from: the true one with these added (px, px, px, 1).
LENS_OFF = {"fx": 6.0, "fy": -5.0, "cx": 4.0, "k1": 0.01}
#: The intrinsics scored against their reported standard deviations.
LENS_SCORED = ("fx", "fy", "cx", "cy", "k1", "k2")
#: The loss of the fit on detected corners (and of the oracle, and of the intrinsics fit).
LOSS = "huber"
#: Goals: the fit's gauge-free error within this many times the oracle's; the camera's pose
#: relative to the board within these of the truth [mm, deg]; the intrinsics within this many sigma.
RATIO_GOAL, POSE_GOAL, SIGMA_GOAL = 1.2, (0.05, 0.01), 3.0
#: The intrinsics' goal holds unless so many values beyond SIGMA_GOAL would come by chance less often than this
#: with a true sigma (a binomial tail).
CHANCE = 0.01
#: What the oracle is, for the output.
ORACLE_NOTE = ("oracle: Levenberg-Marquardt started from the true robot and the true camera and board placements, "
               f"on the same detected corners, with the same loss ({LOSS})")
#: What the gauge-free errors are, for the output.
GAUGE_FREE_NOTE = ("gauge-free: RMS after the best rigid motion of the base; at the flange origin also the best point "
                   "of the end frame, at the camera the fit's own camera centre (eye in hand) or board middle (eye to "
                   "hand)")


@dataclass(frozen=True)
class ImagesRow:
    """One case: detection, and the fit, the oracle and OpenCV's best against the truth at fresh poses.

    Attributes:
        robot, mount, case, seed: The case.
        images: Rendered images; used: those with :data:`~.camera_rig.MIN_CORNERS` corners or more found.
        visible, detected: Corners the true camera sees in the images; corners found and used.
        detect_px: The detected corners' error against the true projection, RMS per coordinate [px].
        detect_ms: Median time to find the corners of one image [ms].
        flange: Gauge-free error at the flange origin at the fresh poses [mm], (fit, oracle).
        at_camera: Gauge-free error at the camera centre (eye to hand: the board's middle) [mm], (fit, oracle).
        pose_fit, pose_oracle, pose_opencv: RMS error of T_CW at the fresh poses, (mm, deg).
        pose_linear: The same of the fit with the plain squares (``linear`` loss).
        method: OpenCV's best hand-eye method.
        lens_z: The intrinsics fit's |error| / reported std of each of :data:`LENS_SCORED`
            (:func:`lens_errors`); ``lens_sigma`` their largest.
        hand_eye_fit, hand_eye_opencv: The flange placement's error against the truth (mm,
            deg), fit and OpenCV's best; None unless the last link is nominal.
    """

    robot: str
    mount: str
    case: str
    seed: int
    images: int
    used: int
    visible: int
    detected: int
    detect_px: float
    detect_ms: float
    flange: tuple[float, float]
    at_camera: tuple[float, float]
    pose_fit: tuple[float, float]
    pose_oracle: tuple[float, float]
    pose_opencv: tuple[float, float]
    pose_linear: tuple[float, float]
    method: str
    lens_z: tuple[float, ...]
    hand_eye_fit: tuple[float, float] | None
    hand_eye_opencv: tuple[float, float] | None

    @property
    def lens_sigma(self) -> float:
        """The intrinsics' largest |error| / reported std."""
        return max(self.lens_z)


def gauge_free_rms(model: Any, x: np.ndarray | None, q: np.ndarray, true_points: np.ndarray,
                   point: np.ndarray | None = None) -> float:
    """RMS [mm] of an end-frame point's base-frame positions at q (n, n_joints) [rad] against ``true_points`` (n, 3) [m].

    After the best rigid motion of the base; ``point`` None: the flange origin, moved to the
    best point of the end frame as well; else that point (3,) of the end frame [m], held.
    What images can tell of the robot: they see the flange only through the placement of the
    camera (or the board) on it, and the base only through the other placement.
    """
    rot, origin = model.end_frames(x, q)
    b = np.zeros(3) if point is None else np.asarray(point, dtype=float)
    a, shift = np.eye(3), np.zeros(3)
    for _ in range(50 if point is None else 1):
        points = origin + rot @ b
        ca, cb = points.mean(axis=0), true_points.mean(axis=0)
        u, _, vt = np.linalg.svd((points - ca).T @ (true_points - cb))
        a = vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))]) @ u.T
        shift = cb - a @ ca
        if point is None:
            b = np.linalg.lstsq(np.einsum("ij,njk->nik", a, rot).reshape(-1, 3),
                                (true_points - shift - origin @ a.T).reshape(-1), rcond=None)[0]
    points = (origin + rot @ b) @ a.T + shift
    return float(np.sqrt(np.mean(np.sum((points - true_points) ** 2, axis=1))) * 1e3)


def camera_point(rig: Any) -> np.ndarray:
    """The end-frame point [m] the camera scores are taken at: the optical centre eye in hand, the board's middle eye to hand."""
    return np.asarray(rig.camera.translation if rig.in_hand else rig.board_pose.act(rig.board.centre), dtype=float)


def detected_set(data: MeasurementSet, true_model: Any, x_true: np.ndarray, seed: int, opencv_corners: bool = False
                 ) -> tuple[MeasurementSet, list[float], np.ndarray]:
    """The set of corners found in images rendered at ``data``'s poses from the truth (module docstring).

    ``opencv_corners``: OpenCV's own ChArUco corners, not refined again clear of the markers.

    Returns:
        The set (``data``'s notes and set-up; its own rows, poses and corners), each image's
        detection time [s], and the detected corners' errors against the true projection (k, 2) [px].
    """
    cv2 = require("cv2", OPENCV_EXTRA)
    pose_ids, first = np.unique(np.asarray(data.pose_ids), return_index=True)
    q = data.q[first]
    board = true_model.rig.board
    seconds, kept = [], []
    for pose, qk, image in zip(pose_ids, q, render_images(true_model, x_true, q, np.random.default_rng(seed + 2000)),
                               strict=True):
        start = time.perf_counter()
        ids, uv = find_corners(cv2, image, board, clear_of_markers=not opencv_corners)
        seconds.append(time.perf_counter() - start)
        if len(ids) >= MIN_CORNERS:
            kept.append((pose, qk, ids, uv))
    rows_q = np.concatenate([np.repeat(qk[None, :], len(ids), axis=0) for _, qk, ids, _ in kept])
    ids = np.concatenate([k[2] for k in kept])
    uv = np.concatenate([k[3] for k in kept])
    detected = dataclasses.replace(
        data, q=rows_q, values=uv, pose_ids=np.concatenate([np.full(len(k[2]), k[0]) for k in kept]),
        point_ids=ids, lines=None, notes={**data.notes, "source": "calib-pin rendered images, detected"})
    return detected, seconds, uv - true_model.image_points(x_true, rows_q, ids)


def _correction(start: pin.SE3, true: pin.SE3) -> np.ndarray:
    """The camera model's 6 corrections (translation [m], rotation [rad]) that take ``start`` to ``true``."""
    return np.concatenate([true.translation - start.translation, pin.log3(start.rotation.T @ true.rotation)])


def oracle_fit(result: Any, truth: Any) -> np.ndarray:
    """The oracle's unknowns: LM from the true robot and placements on the result's training rows."""
    model = result.problem.model.one
    rig = truth.sensor
    x_true = np.concatenate([truth.x, _correction(model.rig.camera, rig.camera),
                             _correction(model.rig.board_pose, rig.board_pose)])
    return np.asarray(run_method(get_method("lm"), result.problem.subset(result.train), x_true, seed=0,
                                 noise=float(result.noise), loss=result.loss).x)


def lens_errors(robot: str, detected: MeasurementSet, true: Intrinsics, seed: int) -> tuple[float, ...]:
    """Each |error| / reported std (``result.uncertainty.std``) of :data:`LENS_SCORED` of the fit started from the
    lens off by :data:`LENS_OFF`."""
    off = dataclasses.replace(true, **{k: getattr(true, k) + v for k, v in LENS_OFF.items()})
    result = calibrate(robot, detected, method="lm", test_fraction=0.0, seed=seed, loss=LOSS,
                       setup=camera_sensor().setup_type(intrinsics=off, estimate="intrinsics"))
    names = list(result.problem.model.names)
    uncertainty: Any = result.uncertainty
    errors = {n: abs(getattr(result.sensor.intrinsics, n) - getattr(true, n)) for n in LENS_SCORED}
    return tuple(errors[n] / float(uncertainty.std[names.index(n)]) for n in LENS_SCORED)


def compare(robot: str, mount: str, case: str, seed: int = 1, poses: int = POSES, fresh: int = FRESH,
            opencv_corners: bool = False) -> ImagesRow:
    """One case of the study (module docstring), seeded; ``opencv_corners``: on OpenCV's own ChArUco corners.

    Raises:
        ValueError: an unknown case.
    """
    if case not in CASES:
        raise ValueError(f"unknown case '{case}' (valid: {', '.join(CASES)})")
    chain, params, data, truth = simulated_case(robot, mount, case, seed, poses, 0.0)
    true_model: Any = truth.model(chain, params)
    detected, seconds, error = detected_set(data, true_model, truth.x_model, seed, opencv_corners)
    result = calibrate(robot, detected, method="lm", test_fraction=0.0, seed=seed, loss=LOSS)
    linear = calibrate(robot, detected, method="lm", test_fraction=0.0, seed=seed)
    model: Any = result.problem.model.one
    x_oracle = oracle_fit(result, truth)

    q = fresh_poses(chain, true_model, truth.x_model, seed, fresh)
    rig = truth.sensor
    flange_true = true_model.points_at(truth.x_model, q, np.zeros(3))
    camera_true = true_model.points_at(truth.x_model, q, camera_point(rig))
    true_poses = true_model.camera_to_board(truth.x_model, q)

    def scores(m: Any, x: np.ndarray | None) -> tuple[float, float, tuple[float, float]]:
        return (gauge_free_rms(m, x, q, flange_true), gauge_free_rms(m, x, q, camera_true, camera_point(m.geometry_at(x))),
                pose_rms(m.camera_to_board(x, q), true_poses))

    fit, oracle = scores(model, result.x), scores(model, x_oracle)
    alone, scored, method = opencv_best(model, detected, q, true_poses)
    hand_eye: tuple[tuple[float, float] | None, tuple[float, float] | None] = (None, None)
    if case == "last link nominal":
        hand_eye = (pose_rms([flange_placement(model.geometry_at(result.x))], [flange_placement(rig)]),
                    pose_rms([flange_placement(alone[method].rig)], [flange_placement(rig)]))
    return ImagesRow(
        robot, mount, case, seed, len(seconds), len(np.unique(np.asarray(detected.pose_ids))), len(data), len(detected),
        float(np.sqrt(np.mean(error**2))), float(np.median(seconds)) * 1e3, (fit[0], oracle[0]), (fit[1], oracle[1]),
        fit[2], oracle[2], scored[method], pose_rms(model.camera_to_board(linear.x, q), true_poses), method,
        lens_errors(robot, detected, rig.intrinsics, seed), *hand_eye)


def study(robots: Sequence[str] = ("irb120", "ur5"), mounts: Sequence[str] = ("eye-in-hand", "eye-to-hand"),
          cases: Sequence[str] = CASES, seeds: Sequence[int] = (1, 2, 3),
          notify: Callable[[str], Any] | None = None, opencv_corners: bool = False) -> list[ImagesRow]:
    """Every case of the study, each robot, mount, case and seed (``opencv_corners``: on OpenCV's own corners)."""
    run = functools.partial(compare, opencv_corners=True) if opencv_corners else compare
    return each_case(run, robots, mounts, cases, seeds, notify)


def _median(values: Sequence[float]) -> float:
    return float(np.median(values))


def _pair(values: Sequence[tuple[float, float]]) -> tuple[float, float]:
    return _median([v[0] for v in values]), _median([v[1] for v in values])


def _pose(pair: tuple[float, float] | None) -> str:
    return "-" if pair is None else f"{pair[0]:.4f} / {pair[1]:.5f}"


def format_rows(rows: Sequence[ImagesRow], opencv_corners: bool = False) -> str:
    """The study as a Markdown table, medians over the seeds of each robot, mount and case, and its notes.

    ``opencv_corners``: the rows are of OpenCV's own ChArUco corners (the notes say so).
    """
    groups: dict[tuple[str, str, str], list[ImagesRow]] = {}
    for r in rows:
        groups.setdefault((r.robot, r.mount, r.case), []).append(r)
    lines = ["| robot | mount | robot case | corners detected / visible | detected px | flange mm fit / oracle (ratio) "
             "| at camera mm fit / oracle (ratio) | T_CW fit mm / deg | T_CW oracle mm / deg | T_CW linear loss mm / deg | "
             "T_CW OpenCV best mm / "
             "deg (method) | intrinsics max err/sigma | hand-eye fit / OpenCV mm / deg |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for (robot, mount, case), group in groups.items():
        flange, at_camera = _pair([r.flange for r in group]), _pair([r.at_camera for r in group])
        ratio = _median([r.flange[0] / r.flange[1] for r in group])
        camera_ratio = _median([r.at_camera[0] / r.at_camera[1] for r in group])
        methods = ", ".join(dict.fromkeys(r.method for r in group))
        fits = [r.hand_eye_fit for r in group if r.hand_eye_fit is not None]
        opencv = [r.hand_eye_opencv for r in group if r.hand_eye_opencv is not None]
        hand_eye = f"{_pose(_pair(fits))} vs {_pose(_pair(opencv))}" if fits and opencv else "-"
        lines.append(
            f"| {robot} | {mount} | {case} | {_median([r.detected for r in group]):.0f} / "
            f"{_median([r.visible for r in group]):.0f} | {_median([r.detect_px for r in group]):.3f} | "
            f"{flange[0]:.3f} / {flange[1]:.3f} ({ratio:.2f}) | {at_camera[0]:.4f} / {at_camera[1]:.4f} "
            f"({camera_ratio:.2f}) | {_pose(_pair([r.pose_fit for r in group]))} | "
            f"{_pose(_pair([r.pose_oracle for r in group]))} | {_pose(_pair([r.pose_linear for r in group]))} | "
            f"{_pose(_pair([r.pose_opencv for r in group]))} "
            f"({methods}) | {_median([r.lens_sigma for r in group]):.2f} | "
            f"{hand_eye} |")
    seeds = sorted({r.seed for r in rows})
    lines += ["", f"{POSES} poses per set, each pose's image rendered from the true robot and camera (blur and grey-level "
              f"noise), its ChArUco corners found by "
              f"{'OpenCV (its own corners, not refined again clear of the markers)' if opencv_corners else 'find_corners'}"
              f"; medians of seeds {', '.join(map(str, seeds))}. At "
              f"{FRESH} fresh poses: the robot's error, {GAUGE_FREE_NOTE}; the fit with the {LOSS} loss (linear "
              f"loss: the plain squares); T_CW, the board's pose in the camera frame, "
              "RMS against the truth. Detected px: the corners' error against the true projection, RMS per "
              f"coordinate. {ORACLE_NOTE[0].upper() + ORACLE_NOTE[1:]}. OpenCV best: the hand-eye method nearest the "
              "truth in each seed, on PnP's board poses and the nominal robot. Intrinsics: a second fit started "
              "from the lens off by fx +6, fy -5, cx +4 px, k1 +0.01, the largest |error| / std over fx, fy, cx, "
              "cy, k1, k2 in the std the calibration reports.", FLANGE_NOTE + " (column 'hand-eye')."]
    return "\n".join(lines)


def goal_lines(rows: Sequence[ImagesRow]) -> list[str]:
    """The must-hold goals, each with the worst case over every row it applies to and whether it holds."""
    if not rows:
        return []
    dev = [r for r in rows if r.case == "deviations"] or list(rows)

    def verdict(ok: bool) -> str:
        return "holds" if ok else "FAILS"

    ratio = max(max(r.flange[0] / r.flange[1], r.at_camera[0] / r.at_camera[1]) for r in rows)
    mm, deg = max(r.pose_fit[0] for r in rows), max(r.pose_fit[1] for r in rows)
    z = np.concatenate([r.lens_z for r in rows])
    beyond = int(np.sum(z > SIGMA_GOAL))
    chance = float(binom.sf(beyond - 1, len(z), 2 * norm.sf(SIGMA_GOAL)))  # so many or more, for a true sigma
    nearer = sum(r.pose_fit[0] < r.pose_opencv[0] and r.pose_fit[1] < r.pose_opencv[1] for r in dev)
    return [
        f"goal: gauge-free fresh error (flange origin and camera) <= {RATIO_GOAL:g} x the oracle's: worst ratio "
        f"{ratio:.2f}, {verdict(ratio <= RATIO_GOAL)}",
        f"goal: T_CW at fresh poses within {POSE_GOAL[0]:g} mm and {POSE_GOAL[1]:g} deg RMS: worst {mm:.4f} mm, "
        f"{deg:.5f} deg, {verdict(mm < POSE_GOAL[0] and deg < POSE_GOAL[1])}",
        f"goal: intrinsics within {SIGMA_GOAL:g} reported sigma: {len(z) - beyond} of {len(z)} values "
        f"({100 * (1 - beyond / len(z)):.1f} %; {100 * (1 - 2 * norm.sf(SIGMA_GOAL)):.1f} % for a true sigma, so many or "
        f"more beyond by chance {100 * chance:.0f} %), worst {z.max():.2f}, RMS {np.sqrt(np.mean(z**2)):.2f} (1 for a "
        f"true sigma), {verdict(chance >= CHANCE)}",
        f"goal: the joint fit's T_CW nearer the truth than OpenCV's best on the nominal robot (robot deviations "
        f"present): {nearer} of {len(dev)} cases, {verdict(nearer == len(dev))}",
    ]


__all__ = ["CASES", "ImagesRow", "camera_point", "compare", "detected_set", "format_rows", "gauge_free_rms",
           "goal_lines", "lens_errors", "oracle_fit", "study"]

"""``benchmark``: time the estimators (see :mod:`calib_pin.studies.benchmark`)."""

from __future__ import annotations

import argparse
import os
import platform
from collections.abc import Sequence

from ..estimators import DEFAULT_METHOD, PAPER_METHODS
from . import parse_args
from .common import add_seed_argument, count, methods, run


def benchmark_parser() -> argparse.ArgumentParser:
    """The ``calib-pin benchmark`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "benchmark")


def add_benchmark_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """benchmark's arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = "Time calib-pin's estimators on a seeded simulated IRB120 session."
    p.add_argument("--repeats", type=count(1000), default=5,
                   help="timed runs per method, and per command of --commands (5)")
    p.add_argument("--methods", type=methods,
                   help=f"comma-separated methods (the paper's nine; against FIGAROH: {DEFAULT_METHOD},lm)")
    add_seed_argument(p)
    p.add_argument("--poses", type=count(100_000), default=120, help="poses of the simulated set, 80 %% train (120)")
    p.add_argument("--scaling", action="store_true",
                   help="also print the scaling table: lm, ekf, ekf-qibas, qibas at 100, 1 000, 10 000 poses (minutes)")
    p.add_argument("--commands", type=_command_list, nargs="?", const="all",
                   help="also time the user's commands as whole processes at 1 000, 10 000, 100 000 rows "
                   "(comma-separated of calibrate,no-html,compare,batch,compensate; default all; long)")
    p.add_argument("--max-rows", type=count(100_000), default=100_000,
                   help="largest size of --commands (100000; e.g. 10000 to finish sooner)")
    p.add_argument("--compare-max-rows", type=count(100_000),
                   help="time compare only up to this size (default: --max-rows)")
    p.add_argument("--command-method", type=methods, default=[DEFAULT_METHOD],
                   help=f"method of --commands' calibrate and batch ({DEFAULT_METHOD})")
    p.add_argument("--quick-start", action="store_true",
                   help="also time the quick start (calib-pin calibrate irb120) and its phases, fresh processes")
    p.add_argument("--floor", action="store_true",
                   help="also time calibrate ur5 --model placement --test-fraction 0 --no-html on 1 000 simulated "
                   "marker positions (lm, ekf-qibas) as whole processes against a process that only imports numpy, "
                   "Pinocchio and scipy.optimize, interleaved")
    p.add_argument("--camera", action="store_true",
                   help="also time calibrate irb120 on a simulated camera set of 100 images of 50 corners each (lm, "
                   "with report.html, --estimate intrinsics, the default method) as whole processes against the floor "
                   "process, interleaved")
    p.add_argument("--hand-eye", action="store_true",
                   help="instead of timing: the joint calibration against OpenCV's best hand-eye method on the nominal "
                   "robot, on the same simulated camera sets (--robots irb120,ur5; both mounts; with the robot's "
                   "deviations, its last link nominal, none; --repeats seeds); the camera's pose relative to the board "
                   "at fresh poses against the truth")
    p.add_argument("--images", action="store_true",
                   help="instead of timing: rendered images of simulated camera sets (--robots irb120,ur5; both mounts; "
                   "with the robot's deviations and its last link nominal; --repeats seeds) detected and calibrated, "
                   "against an oracle fit and the truth; the detection time per image")
    p.add_argument("--opencv-corners", action="store_true",
                   help="with --images: detect OpenCV's own ChArUco corners, not refined again clear of the markers "
                   "(a comparison)")
    p.add_argument("--trust", action="store_true",
                   help="instead of timing: check the gauge, the predicted accuracy and the intervals against the "
                   "simulator's truth (IRB120, UR5, Panda; every sensor; lm, ekf-qibas, de; --repeats seeds) and the "
                   "predicted error against the held-out error on the real IRB120 set (10 splits); long")
    p.add_argument("--robots", type=_robot_list,
                   help="robots of --trust (irb120,ur5,panda), --hand-eye or --images (irb120,ur5), comma-separated")
    p.add_argument("--against", choices=["figaroh"],
                   help="also race FIGAROH (when installed) on simulated UR5 positions, 100 and 1 000 samples")
    return p


def _robot_list(text: str) -> tuple[str, ...]:
    """``irb120,ur5``: the robots of ``--trust``."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise argparse.ArgumentTypeError(f"expected robot names, comma-separated, got '{text[:40]}'")
    return names


#: The robots the camera studies (--hand-eye, --images) simulate: those whose end frame is tool0.
CAMERA_ROBOTS = ("irb120", "ur5")


def _camera_robots(args: argparse.Namespace, flag: str) -> tuple[str, ...]:
    """The robots of a camera study, checked where they enter.

    Raises:
        CalibPinError: a robot the study does not simulate.
    """
    from ..exceptions import CalibPinError

    robots = tuple(args.robots or CAMERA_ROBOTS)
    other = [r for r in robots if r not in CAMERA_ROBOTS]
    if other:
        raise CalibPinError(f"--robots: {flag} studies {' and '.join(CAMERA_ROBOTS)}, not '{other[0]}'")
    return robots


def _command_list(text: str) -> tuple[str, ...]:
    """``calibrate,no-html,...`` or ``all``: the commands of ``--commands``."""
    from ..studies.benchmark_commands import COMMANDS

    names = COMMANDS if text == "all" else tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in COMMANDS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(f"unknown command '{unknown[0] if unknown else text}' "
                                         f"(valid: {', '.join(COMMANDS)}, or all)")
    return names


def benchmark_main(argv: Sequence[str] | None = None) -> int:
    """``benchmark.py [--repeats 5] [--methods ekf-qibas,lm] [--seed 0] [--poses 120]``."""
    args = parse_args("benchmark", argv)
    return run(lambda: _trust(args) if args.trust else _hand_eye(args) if args.hand_eye else _images(args)
               if args.images else _benchmark(args) if not args.opencv_corners else _without_images())


def _without_images() -> int:
    """``--opencv-corners`` without ``--images``: refused (it would time the estimators and say nothing of corners)."""
    from ..exceptions import CalibPinError

    raise CalibPinError("--opencv-corners: it chooses the corners of --images; give --images too")


def _trust(args: argparse.Namespace) -> int:
    """``--trust``: the study of :mod:`calib_pin.studies.trust`, printed as Markdown tables."""
    import sys

    from ..studies.trust import study, wu_splits

    methods = tuple(args.methods) if args.methods else ("lm", "ekf-qibas", "de")
    robots = args.robots or ("irb120", "ur5", "panda")
    print("\n".join(study(robots=robots, methods=methods, seeds=args.repeats,
                          notify=lambda line: print(line, file=sys.stderr, flush=True))))
    if "irb120" in robots:
        print()
        print("\n".join(wu_splits()))
    return 0


def _hand_eye(args: argparse.Namespace) -> int:
    """``--hand-eye``: the study of :mod:`calib_pin.studies.hand_eye`, printed as a Markdown table."""
    import sys

    from ..studies.hand_eye import format_rows, study

    rows = study(robots=_camera_robots(args, "--hand-eye"), seeds=tuple(range(1, args.repeats + 1)),
                 notify=lambda line: print(line, file=sys.stderr, flush=True))
    print(format_rows(rows))
    return 0


def _images(args: argparse.Namespace) -> int:
    """``--images``: the study of :mod:`calib_pin.studies.camera_images`, a Markdown table, detection time and goals."""
    import statistics
    import sys

    from ..sensors.camera_view import default_intrinsics
    from ..studies.camera_images import format_rows, goal_lines, study

    rows = study(robots=_camera_robots(args, "--images"), seeds=tuple(range(1, args.repeats + 1)),
                 notify=lambda line: print(line, file=sys.stderr, flush=True), opencv_corners=args.opencv_corners)
    print(format_rows(rows, args.opencv_corners))
    times = [r.detect_ms for r in rows]
    lens = default_intrinsics()
    how = "cv2.aruco.CharucoDetector" + ("" if args.opencv_corners else ", refined clear of the markers")
    print(f"detection time per image (ChArUco, {lens.width}x{lens.height} px, {how}): median "
          f"{statistics.median(times):.1f} "
          f"ms (each case's median over its {rows[0].images} images; cases {min(times):.1f} to {max(times):.1f} ms)")
    print("\n".join(goal_lines(rows)))
    return 0


def _benchmark(args: argparse.Namespace) -> int:
    from ..studies.benchmark import benchmark, floor, format_scaling, format_timings, jacobian_profile, scaling
    from ..util.version import package_version
    from . import BLAS_THREADS

    what, rows = benchmark(args.methods or list(PAPER_METHODS), args.repeats, args.seed, args.poses)
    print(f"calib-pin {package_version()} benchmark: {what}")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; BLAS and OpenMP limited to {BLAS_THREADS} thread "
          "(threadpoolctl and the environment: calib_pin.cli.limit_blas_threads, every command)")
    print(format_timings(rows))
    cost = floor(args.poses, args.seed)
    print(f"one evaluation over {round(0.8 * args.poses)} poses [ms]: " +
          ", ".join(f"{k} {v:.3f}" for k, v in cost.items()) +
          f"; residual {cost['residual'] / cost['floor FK']:.1f}x FK, "
          f"Jacobian {cost['jacobian'] / cost['floor FK+regressor']:.1f}x FK+regressor")
    print(jacobian_profile(cost))
    print("goals: EKF-QIBAS at 96 poses < 30 ms; 10 000 poses < 5 s; cost and memory linear in the poses")
    if args.scaling:
        print(format_scaling(scaling(seed=args.seed)))
    if args.quick_start:
        _quick_start(args)
    if args.commands:
        _commands(args)
    if args.floor:
        _floor(args)
    if args.camera:
        _camera(args)
    if args.against == "figaroh":
        _against_figaroh(args)
    return 0


def _floor(args: argparse.Namespace) -> None:
    from ..studies.benchmark_commands import PROCESS_NOTE
    from ..studies.benchmark_floor import FLOOR_SAMPLES, above_floor, format_floor

    repeats = max(args.repeats, 5)
    print(f"calibrate ur5 --model placement --test-fraction 0 --no-html on {FLOOR_SAMPLES} simulated marker positions "
          f"(seed {args.seed}) as whole processes, interleaved with the floor (a process importing numpy, Pinocchio "
          f"and scipy.optimize), median wall s of {repeats} runs; {PROCESS_NOTE}:")
    print(format_floor(above_floor(repeats=repeats, seed=args.seed)))


def _camera(args: argparse.Namespace) -> None:
    from ..studies.benchmark_camera import CORNERS, format_camera, time_camera
    from ..studies.benchmark_commands import PROCESS_NOTE

    repeats = max(args.repeats, 5)
    runs, images, rows = time_camera(repeats=repeats, seed=args.seed)
    print(f"a camera set: calibrate irb120 on {images} simulated images of {CORNERS} corners each ({rows} rows, eye in "
          f"hand, 0.1 px, seed {args.seed}) as whole processes, interleaved with the floor, median wall s of {repeats} "
          f"runs; {PROCESS_NOTE}:")
    print(format_camera(runs))
    print("goal: 100 images of 50 corners each calibrate in a few seconds")


def _quick_start(args: argparse.Namespace) -> None:
    from ..studies.benchmark_commands import PROCESS_NOTE, quick_start_phases

    phases, wall = quick_start_phases(max(args.repeats, 3))
    print(f"quick start (calibrate.py irb120, whole process, median of {max(args.repeats, 3)}): {wall:.2f} s; "
          "its phases in a "
          "fresh process [s]: " + ", ".join(f"{k} {v:.3f}" for k, v in phases.items()))
    print(f"({PROCESS_NOTE})")
    print("goal: the quick start under 3 s warm")


def _commands(args: argparse.Namespace) -> None:
    from ..studies.benchmark_commands import COMMAND_SIZES, PROCESS_NOTE, format_commands, time_commands

    sizes = tuple(n for n in COMMAND_SIZES if n <= args.max_rows) or (args.max_rows,)
    method = args.command_method[0]
    runs = time_commands(args.commands, sizes, method, repeats=args.repeats, seed=args.seed,
                         compare_max_rows=args.compare_max_rows)
    print(f"the user's commands as whole processes (python scripts/COMMAND.py, simulated IRB120 drawstring sets, "
          f"seed {args.seed}; calibrate, --no-html and batch with --method {method}; batch: 8 sets of rows/8 "
          "poses; compare --trials 10, every method; compensate: 1000 targets), median wall s of "
          f"{args.repeats} run(s), ratio to the size before, peak resident MiB; {PROCESS_NOTE}:")
    print(format_commands(runs))
    print("goals: calibrate at 10 000 rows <= 12x its time at 1 000; peak memory at 100 000 rows <= 1 GB")


def _against_figaroh(args: argparse.Namespace) -> None:
    """Print the FIGAROH race, or one line saying it is skipped."""
    from ..studies.benchmark_commands import PROCESS_NOTE
    from ..studies.benchmark_figaroh import (
        FLOOR_PROCESS,
        FRESH_POSES,
        NOISE_MM,
        TIMED,
        against_figaroh,
        ekf_qibas_stages,
        figaroh_version,
        format_goal,
        format_process_goal,
        format_processes,
        format_races,
        format_stages,
        whole_processes,
    )
    from . import BLAS_THREADS

    chosen = args.methods or [DEFAULT_METHOD, "lm"]
    rows = against_figaroh(chosen, args.repeats, args.seed)
    if rows is None:
        print("against figaroh: skipped, figaroh is not installed (pip install figaroh; not a dependency)")
        return
    print(f"against FIGAROH {figaroh_version()}: simulated UR5 positions (one marker, {NOISE_MM:g} mm per axis, "
          f"seed {args.seed}), every sample trains; interleaved calib-pin/FIGAROH, {args.repeats} repeat(s), "
          f"medians; both in this process with BLAS and OpenMP limited to {BLAS_THREADS} thread")
    print(format_races(rows))
    print(f"ratio: FIGAROH's median over calib-pin's; RMSE: Euclidean position error against the noise-free "
          f"truth at the training poses and at {FRESH_POSES} fresh poses [mm]; params: calib-pin/FIGAROH unknowns")
    print(f"timed: {TIMED}")
    print(format_goal(rows))
    if DEFAULT_METHOD in chosen:
        print(format_stages(*ekf_qibas_stages(repeats=max(args.repeats, 5), seed=args.seed)))
    processes = whole_processes(chosen, args.repeats, args.seed)
    if processes is not None:
        print(f"as whole processes (what a user runs; calibrate.py ur5 --data FILE --method M --no-html "
              f"--test-fraction 0, against FIGAROH's default in a fresh Python process from its URDF, YAML and "
              f"CSV), interleaved, median wall s of {args.repeats} run(s); {PROCESS_NOTE}:")
        print(format_processes(processes))
        print(f"floor: a process that only runs '{FLOOR_PROCESS}' (what both tools import, with Python's cyclic "
              "collector as calib-pin's command process has it: calib_pin.cli.process); above: calib-pin's median "
              "minus the floor, its own imports and work")
        print(format_process_goal(processes))

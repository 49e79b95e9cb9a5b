"""Command line of the drawstring reader: ``collect.py``, ``make_poses.py``, ``fake_indicator.py``.

Exit status: 0 done; 2 bad input (one line on stderr); 3 the sensor failed after its
retries (the rows measured so far are kept; rerun the same command to resume);
130 stopped by Ctrl-C (likewise).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .cli import OneLineParser, _at_least_one, _extras, _positive, _report_errors, _xyz
from .collect import collect, open_session, read_pose_list
from .drawstring import SensorFault, SensorProfile, open_reader, read_with_retries
from .exceptions import CalibPinError
from .measurements import write_poses
from .parameters import MODELS
from .model import load_chain
from .simulate import random_poses

SENSOR_FAULT_EXIT = 3
INTERRUPTED_EXIT = 130

#: Command-line flag -> SensorProfile field (flags default to None: "not given").
_PROFILE_FLAGS = {
    "protocol": "protocol", "baud": "baud", "parity": "parity", "stopbits": "stopbits",
    "bytesize": "bytesize", "timeout": "timeout_s", "slave": "slave", "function": "function",
    "register": "register", "words": "words", "signed": "signed", "word_order": "word_order",
    "pattern": "pattern", "scale_mm": "scale_mm", "ascii_scale_mm": "ascii_scale_mm", "zero_mm": "zero_mm", "min_mm": "min_mm",
    "max_mm": "max_mm", "samples": "samples", "tolerance_mm": "tolerance_mm",
    "max_reads": "max_reads", "interval": "interval_s", "retries": "retries",
}


def _add_sensor_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("sensor (defaults: the --profile file, else as shown)")
    g.add_argument("--profile", help="load sensor settings from this JSON file")
    g.add_argument("--save-profile", help="save the resulting sensor settings to this JSON file")
    g.add_argument("--protocol", choices=["modbus", "ascii"], help="modbus (default) or ascii")
    g.add_argument("--baud", type=int, help="baud rate (9600)")
    g.add_argument("--parity", choices=["N", "E", "O"], help="parity (N)")
    g.add_argument("--stopbits", type=int, choices=[1, 2], help="stop bits (1)")
    g.add_argument("--bytesize", type=int, choices=[7, 8], help="data bits (8)")
    g.add_argument("--timeout", type=_positive(float), help="answer timeout, s (0.5)")
    g.add_argument("--slave", type=int, help="Modbus slave address (1)")
    g.add_argument("--function", type=int, choices=[3, 4], help="Modbus function: 3 holding, 4 input registers (3)")
    g.add_argument("--register", type=int, help="first register address, 0-based (0)")
    g.add_argument("--words", type=int, choices=[1, 2], help="16-bit (1) or 32-bit (2) value (2)")
    g.add_argument("--signed", action="store_true", default=None, help="value is signed (two's complement)")
    g.add_argument("--unsigned", dest="signed", action="store_false", help="value is unsigned (default)")
    g.add_argument("--word-order", choices=["high", "low"], help="for 32-bit: which word comes first (high)")
    g.add_argument("--pattern", help="ascii: regex whose group 1 is the number (default: '+0123.456 mm')")
    g.add_argument("--scale-mm", type=float, help="modbus: mm per count (1)")
    g.add_argument("--ascii-scale-mm", type=float, help="ascii: mm per printed unit (1: the indicator prints mm)")
    g.add_argument("--zero-mm", type=float, help="zero offset added after scaling, mm (0)")
    g.add_argument("--min-mm", type=float, help="sensor range low end, mm (0)")
    g.add_argument("--max-mm", type=float, help="sensor range high end, mm (5000)")
    g.add_argument("--samples", type=int, help="samples that must agree to be stable (5)")
    g.add_argument("--tolerance-mm", type=_positive(float), help="largest spread of those samples, mm (0.02)")
    g.add_argument("--max-reads", type=int, help="samples tried per pose before giving up (50)")
    g.add_argument("--interval", type=_positive(float), help="pause between samples, s (0.05)")
    g.add_argument("--retries", type=int, help="faults in a row tolerated per sample (3)")


def _profile(args: argparse.Namespace) -> SensorProfile:
    profile = SensorProfile.load(args.profile) if args.profile else SensorProfile()
    given = {field: getattr(args, flag) for flag, field in _PROFILE_FLAGS.items() if getattr(args, flag) is not None}
    profile = dataclasses.replace(profile, **given).check()
    if args.save_profile:
        profile.save(args.save_profile)
        print(f"saved sensor profile {args.save_profile}")
    return profile


def collect_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="collect.py",
        description="Read a drawstring sensor at each pose of a pose list and append the "
        "readings to a measurement set (resumable); or --probe the sensor.",
    )
    p.add_argument("robot", nargs="?", help="robot name (irb120) or URDF path; not needed with --probe")
    p.add_argument("--poses", help="pose list CSV (make_poses.py writes one)")
    p.add_argument("--port", required=True, help="serial device, e.g. /dev/ttyUSB0")
    p.add_argument("--out", help="measurement set CSV to create or resume")
    p.add_argument("--auto", type=_positive(float), metavar="SECONDS",
                   help="do not wait for Enter: wait this long at each pose, then read")
    p.add_argument("--probe", action="store_true", help="only read and print a few values")
    p.add_argument("--count", type=int, default=5, help="values read by --probe (5)")
    p.add_argument("--end-frame", help="end frame (default tool0)")
    p.add_argument("--anchor-mm", type=_xyz, help="sensor point P0 in the base frame, x,y,z mm (written to the file)")
    p.add_argument("--tool-mm", type=_xyz, help="hook point in the end frame, x,y,z mm (written to the file)")
    _add_sensor_arguments(p)
    return p


def collect_main(argv: Sequence[str] | None = None) -> int:
    """``collect.py ROBOT --poses P.csv --port DEV --out F.csv [--auto S] [sensor flags]``."""
    args = collect_parser().parse_args(argv)
    if not args.probe:
        missing = [name for name in ("robot", "poses", "out") if not getattr(args, name)]
        if missing:
            print(f"error: collect needs {', '.join('--' + m if m != 'robot' else 'ROBOT' for m in missing)}"
                  " (or --probe)", file=sys.stderr)
            return 2
    try:
        return _report_errors(lambda: _probe(args) if args.probe else _collect(args), args.out or args.port)
    except KeyboardInterrupt:
        print("\nstopped by Ctrl-C: every completed row is saved; run the same command to resume",
              file=sys.stderr)
        return INTERRUPTED_EXIT


def _probe(args: argparse.Namespace) -> int:
    profile = _profile(args)
    reader = open_reader(args.port, profile)
    print(f"probing {args.port}: {profile.describe()}")
    try:
        reader.flush()
        for i in range(1, max(args.count, 1) + 1):
            try:
                print(f"{i}: {read_with_retries(reader):.3f} mm")
            except SensorFault as e:
                print(f"{i}: fault: {e}")
            time.sleep(profile.interval_s)
    finally:
        reader.close()
    return 0


def _wait(auto: float | None):
    def wait(pid: int, position: int, q_deg: np.ndarray) -> bool:
        angles = ", ".join(f"{v:.3f}" for v in q_deg)
        if auto is not None:
            print(f"move to pose {pid} (#{position}): q = [{angles}] deg; reading in {auto:g} s", flush=True)
            time.sleep(auto)
            return True
        try:
            answer = input(f"move to pose {pid} (#{position}): q = [{angles}] deg, then Enter (q to stop): ")
        except EOFError:
            return False
        return answer.strip().lower() not in ("q", "quit", "stop")

    return wait


def _collect(args: argparse.Namespace) -> int:
    profile = _profile(args)
    chain = load_chain(args.robot, args.end_frame)
    poses = read_pose_list(args.poses, chain)
    session = open_session(args.out, poses, chain, profile, anchor_mm=args.anchor_mm, tool_mm=args.tool_mm)
    if session.dropped:
        print(f"dropped an incomplete last line of {args.out} (a write cut short): {session.dropped!r}")
    if not session.remaining:
        print(f"all {len(poses)} poses are already in {args.out}")
        return 0
    if session.done:
        print(f"resuming {args.out}: {session.done} of {len(poses)} poses done")
    reader = open_reader(args.port, profile)
    try:
        written = collect(session, reader, _wait(args.auto))
    except SensorFault as e:
        print(f"error: sensor: {e}; {session.done} of {len(poses)} poses are saved in {args.out}; "
              "fix the fault and run the same command to resume", file=sys.stderr)
        return SENSOR_FAULT_EXIT
    finally:
        reader.close()
    state = "complete" if not session.remaining else f"{len(session.remaining)} poses left"
    print(f"wrote {written} rows to {args.out} ({session.done} of {len(poses)}, {state})")
    return 0


def make_poses_parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="make_poses.py", description="Write a random pose list within the joint limits.")
    p.add_argument("robot", help="robot name (irb120) or URDF path")
    p.add_argument("--n", type=_at_least_one, default=120, help="number of poses (120)")
    p.add_argument("--seed", type=_positive(int), default=0, help="seed (0)")
    p.add_argument("--margin-deg", type=_positive(float), default=5.0,
                   help="keep this far inside every joint limit, deg (5)")
    p.add_argument("--end-frame", help="end frame (default tool0)")
    p.add_argument("--out", required=True, help="pose list CSV")
    return p


def make_poses_main(argv: Sequence[str] | None = None) -> int:
    """``make_poses.py ROBOT --n 120 --seed S --out poses.csv [--margin-deg 5]``."""
    args = make_poses_parser().parse_args(argv)
    return _report_errors(lambda: _make_poses(args), args.out)


def _make_poses(args: argparse.Namespace) -> int:
    chain = load_chain(args.robot, args.end_frame)
    margin = np.deg2rad(args.margin_deg)
    span = np.where(np.isfinite(chain.upper - chain.lower), chain.upper - chain.lower, np.inf)
    if np.any(span <= 2 * margin):
        k = int(np.argmin(span))
        raise CalibPinError(
            f"--margin-deg {args.margin_deg:g} leaves no range for {chain.joint_names[k]} "
            f"({np.rad2deg(span[k]):g} deg between its limits)"
        )
    q = random_poses(chain, args.n, np.random.default_rng(args.seed), margin=margin)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    write_poses(args.out, q, robot=chain.name, end_frame=chain.end_frame,
                notes={"source": f"make_poses.py seed {args.seed}, margin {args.margin_deg:g} deg"})
    print(f"{chain.name}: {args.n} poses within the joint limits less {args.margin_deg:g} deg (seed {args.seed})")
    print(f"wrote {args.out}")
    return 0


def plan_poses_main(argv: Sequence[str] | None = None) -> int:
    """``plan_poses.py ROBOT --n 40 --candidates 5000 [--seed S] --out poses.csv``."""
    p = OneLineParser(prog="plan_poses.py",
                      description="Choose poses that maximise the observability of the parameters (D-optimal).")
    p.add_argument("robot", help="robot name (irb120) or URDF path")
    p.add_argument("--n", type=_at_least_one, default=40, help="poses to choose (40)")
    p.add_argument("--candidates", type=_at_least_one, default=5000, help="random candidates to choose from (5000)")
    p.add_argument("--seed", type=_positive(int), default=0, help="seed of the candidates (0)")
    p.add_argument("--margin-deg", type=_positive(float), default=5.0, help="distance from the joint limits, deg (5)")
    p.add_argument("--anchor-mm", type=_xyz, help="sensor point P0 in the base frame, x,y,z mm (600,200,-100)")
    p.add_argument("--tool-mm", type=_xyz, help="hook point in the end frame, x,y,z mm (0,0,50)")
    p.add_argument("--end-frame", help="end frame (default tool0)")
    p.add_argument("--model", choices=MODELS,
                   help="parameter model to plan for (default dh with a DH table, else placement)")
    p.add_argument("--estimate", type=_extras, default=(),
                   help="sensor geometry that will be estimated too: anchor, offset or anchor,offset")
    p.add_argument("--out", required=True, help="pose list CSV")
    args = p.parse_args(argv)
    if args.candidates < args.n:
        print(f"error: --candidates ({args.candidates}) must be at least --n ({args.n})", file=sys.stderr)
        return 2
    return _report_errors(lambda: _plan_poses(args), args.out)


def _plan_poses(args: argparse.Namespace) -> int:
    from .errors import CableModel, Drawstring
    from .parameters import parameter_model
    from .planning import plan_poses
    from .simulate import DEFAULT_ANCHOR_MM, DEFAULT_TOOL_MM

    chain = load_chain(args.robot, args.end_frame)
    sensor = Drawstring(np.array(args.anchor_mm or DEFAULT_ANCHOR_MM) * 1e-3,
                        np.array(args.tool_mm or DEFAULT_TOOL_MM) * 1e-3)
    name = args.model or ("dh" if chain.description.dh is not None else "placement")
    model = CableModel(chain, parameter_model(chain, name), sensor, args.estimate)
    try:
        plan = plan_poses(model, args.n, args.candidates, seed=args.seed, margin=np.deg2rad(args.margin_deg))
    except ValueError as e:
        raise CalibPinError(str(e)) from None
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    write_poses(args.out, plan.q, robot=chain.name, end_frame=chain.end_frame,
                notes={"source": f"plan_poses.py: {args.n} of {args.candidates} candidates (seed {args.seed}), "
                                 f"D-optimal for the {name} model and the drawstring sensor"
                                 + (f" with {' and '.join(args.estimate)} estimated" if args.estimate else "")})
    print(f"{chain.name}: {args.n} poses chosen from {args.candidates} candidates (seed {args.seed}), "
          f"{name} model" + (f", {' and '.join(args.estimate)} estimated" if args.estimate else ""))
    print(f"observability O1 {plan.o1:.3g} (random poses: {plan.random_o1:.3g}), "
          f"O3 {plan.o3:.3g} (random: {plan.random_o3:.3g})")
    reach = f"the first {plan.reach}" if plan.reach else "none"
    print(f"information of {args.n} random poses is reached by {reach} of the planned poses")
    print(f"wrote {args.out}")
    return 0


def fake_indicator_main(argv: Sequence[str] | None = None) -> int:
    """``fake_indicator.py [--protocol modbus|ascii] [--value-mm V | --values F.csv --follow OUT.csv] ...``."""
    from .fake_indicator import FAULTS, FakeIndicator
    from .measurements import read_measurements

    p = OneLineParser(prog="fake_indicator.py",
                      description="Serve a simulated drawstring indicator on a pseudo-terminal; prints its device path.")
    p.add_argument("--protocol", choices=["modbus", "ascii"], default="modbus")
    p.add_argument("--value-mm", type=float, default=1000.0, help="value served (1000)")
    p.add_argument("--values", help="measurement set whose length_mm values are served pose by pose (with --follow)")
    p.add_argument("--follow", help="the collector's output: serve value k when it holds k rows")
    p.add_argument("--slave", type=int, default=1)
    p.add_argument("--register", type=int, default=0)
    p.add_argument("--words", type=int, choices=[1, 2], default=2)
    p.add_argument("--unsigned", action="store_true", help="encode unsigned (default signed)")
    p.add_argument("--word-order", choices=["high", "low"], default="high")
    p.add_argument("--scale-mm", type=float, default=0.001, help="mm per count (0.001)")
    p.add_argument("--noise-mm", type=_positive(float), default=0.0)
    p.add_argument("--drift-mm-per-s", type=float, default=0.0)
    p.add_argument("--fault", choices=FAULTS, help="inject this fault ...")
    p.add_argument("--fault-every", type=int, default=0, help="... on every Nth answer (0: never)")
    args = p.parse_args(argv)
    values = None
    if args.values:
        if not args.follow:
            p.error("--values needs --follow (the collector's output file)")
        try:
            values = (read_measurements(args.values).lengths * 1e3).tolist()
        except CalibPinError as e:
            p.error(str(e))
    fake = FakeIndicator(
        args.protocol, args.value_mm, slave=args.slave, register=args.register, words=args.words,
        signed=not args.unsigned, word_order=args.word_order, scale_mm=args.scale_mm,
        noise_mm=args.noise_mm, drift_mm_per_s=args.drift_mm_per_s, values_mm=values, follow=args.follow,
    )
    print(f"fake {args.protocol} indicator on {fake.path} (Ctrl-C to stop)", flush=True)
    fake.start()
    try:
        seen = 0
        while True:
            time.sleep(0.05)
            if args.fault and args.fault_every and fake.requests >= seen + args.fault_every:
                seen = fake.requests
                fake.inject(args.fault)
    except KeyboardInterrupt:
        pass
    finally:
        fake.stop()
    return 0

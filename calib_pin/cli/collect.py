"""``collect``: read the drawstring sensor at each pose of a pose list (or ``--probe`` it).

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
from typing import TYPE_CHECKING

import numpy as np

from ..robot.description import robot_inputs
from ..util.outputs import Outputs, refuse_input
from ..util.progress import quiet_progress
from . import parse_args
from .common import (
    SENSOR_FAULT_EXIT,
    add_end_frame_argument,
    add_quiet_argument,
    count,
    fail,
    non_negative,
    one_line,
    point_mm,
    run,
    warn,
)
from .outputs import add_force_argument

if TYPE_CHECKING:
    from ..hardware.reader import SensorProfile
    from ..hardware.session import Session

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
    g.add_argument("--timeout", type=non_negative(float), help="answer timeout, s (0.5)")
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
    g.add_argument("--tolerance-mm", type=non_negative(float), help="largest spread of those samples, mm (0.02)")
    g.add_argument("--max-reads", type=int, help="samples tried per pose before giving up (50)")
    g.add_argument("--interval", type=non_negative(float), help="pause between samples, s (0.05)")
    g.add_argument("--retries", type=int, help="faults in a row tolerated per sample (3)")


def _profile(args: argparse.Namespace) -> SensorProfile:
    """The sensor settings: the --profile file, then the flags; checked, nothing written."""
    from ..hardware.reader import SensorProfile

    profile = SensorProfile.load(args.profile) if args.profile else SensorProfile()
    given = {field: getattr(args, flag) for flag, field in _PROFILE_FLAGS.items() if getattr(args, flag) is not None}
    return dataclasses.replace(profile, **given).check()


def _outputs(args: argparse.Namespace, profile: SensorProfile) -> Outputs:
    """The --save-profile file, refused here if it may not be written; written by the caller last.

    It may not be written over an existing file without --force, nor over an input or the
    session even with it.
    """
    inputs = {**robot_inputs(args.robot), "--poses": args.poses, "--profile": args.profile,
              "--port": args.port}
    if args.out:
        refuse_input(args.out, inputs)
        inputs["--out, the session"] = args.out
    out = Outputs(Path(args.save_profile or ".").parent, force=args.force, inputs=inputs)
    if args.save_profile:
        out.add(args.save_profile, profile.save)
    return out


def _save(outputs: Outputs, args: argparse.Namespace) -> None:
    if outputs.commit():
        print(f"saved sensor profile {args.save_profile}")


def collect_parser() -> argparse.ArgumentParser:
    """The ``calib-pin collect`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "collect")


def add_collect_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """collect's arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = ("Read a drawstring sensor at each pose of a pose list and append the "
                     "readings to a measurement set (resumable); or --probe the sensor.")
    p.add_argument("robot", nargs="?", help="robot name (irb120) or URDF path; not needed with --probe")
    p.add_argument("--poses", help="pose list CSV (make_poses.py writes one)")
    p.add_argument("--port", required=True, help="serial device, e.g. /dev/ttyUSB0")
    p.add_argument("--out", help="measurement set CSV to create or resume")
    p.add_argument("--auto", type=non_negative(float), metavar="SECONDS",
                   help="do not wait for Enter: wait this long at each pose, then read")
    p.add_argument("--probe", action="store_true", help="only read and print a few values")
    p.add_argument("--count", type=count(10_000), default=5, help="values read by --probe (5)")
    add_end_frame_argument(p)
    p.add_argument("--anchor-mm", type=point_mm("base"),
                   help="sensor point P0 in the base frame, x,y,z mm (written to the file)")
    p.add_argument("--tool-mm", type=point_mm("end frame"),
                   help="hook point in the end frame, x,y,z mm (written to the file)")
    _add_sensor_arguments(p)
    add_force_argument(p, "--save-profile file")
    add_quiet_argument(p)
    return p


def collect_main(argv: Sequence[str] | None = None) -> int:
    """``collect.py ROBOT --poses P.csv --port DEV --out F.csv [--auto S] [sensor flags]``."""
    args = parse_args("collect", argv)
    if not args.probe:
        missing = [name for name in ("robot", "poses", "out") if not getattr(args, name)]
        if missing:
            return fail(f"collect needs {', '.join('--' + m if m != 'robot' else 'ROBOT' for m in missing)}"
                        " (or --probe)")
    with quiet_progress(args.quiet):
        return run(lambda: _probe(args) if args.probe else _collect(args),
                   interrupted="stopped by Ctrl-C: every completed row is saved; run the same command to resume")


def _probe(args: argparse.Namespace) -> int:
    from ..hardware.reader import SensorFault, open_reader, read_with_retries

    profile = _profile(args)
    outputs = _outputs(args, profile)
    reader = open_reader(args.port, profile)
    try:
        _save(outputs, args)
    except BaseException:
        reader.close()
        raise
    print(f"probing {args.port}: {profile.describe()}")
    try:
        reader.flush()
        for i in range(1, args.count + 1):
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


def _start(session: Session, outputs: Outputs, args: argparse.Namespace) -> None:
    """Write what the checks allowed: the session's header or cut, the --save-profile file.

    If that fails, a session file this run created is removed again.
    """
    new = session.new
    session.start()
    try:
        _save(outputs, args)
    except BaseException:
        if new:
            session.discard()
        raise
    if session.dropped:
        warn(f"dropped an incomplete last line of {args.out} (a write cut short): {session.dropped!r}")


def _collect(args: argparse.Namespace) -> int:
    from ..hardware.reader import SensorFault, open_reader
    from ..hardware.session import collect, prepare_session
    from ..measurements.pose_list import read_pose_list
    from ..robot import load_chain

    # Everything is checked before anything is written: a refused run leaves no header,
    # no cut, no profile.
    profile = _profile(args)
    chain = load_chain(args.robot, args.end_frame)
    poses = read_pose_list(args.poses, chain)
    outputs = _outputs(args, profile)
    with prepare_session(args.out, poses, chain, profile, anchor_mm=args.anchor_mm, tool_mm=args.tool_mm) as session:
        if not session.remaining:
            _start(session, outputs, args)
            print(f"all {len(poses)} poses are already in {args.out}")
            return 0
        reader = open_reader(args.port, profile)
        try:
            _start(session, outputs, args)
            if session.done:
                print(f"resuming {args.out}: {session.done} of {len(poses)} poses done")
            written = collect(session, reader, _wait(args.auto))
        except SensorFault as e:
            print(f"error: {one_line(f'sensor: {e}; {session.done} of {len(poses)} poses are saved in {args.out}')}; "
                  "fix the fault and run the same command to resume", file=sys.stderr)
            return SENSOR_FAULT_EXIT
        except OSError as e:  # the progress lines could not be printed (stdout on a full disk), say
            where = f"{e.filename}: " if getattr(e, "filename", None) else ""
            return fail(f"{where}{e.strerror or e}; {session.done} of {len(poses)} poses are saved in {args.out}: "
                        "run the same command to resume")
        finally:
            reader.close()
    state = "complete" if not session.remaining else f"{len(session.remaining)} poses left"
    print(f"wrote {written} rows to {args.out} ({session.done} of {len(poses)}, {state})")
    return 0

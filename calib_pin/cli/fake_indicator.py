"""``fake-indicator``: a simulated drawstring indicator on a pseudo-terminal, for dry runs."""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence

from ..exceptions import CalibPinError
from . import parse_args
from .common import non_negative


def fake_indicator_parser() -> argparse.ArgumentParser:
    """The ``calib-pin fake-indicator`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "fake-indicator")


def add_fake_indicator_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """fake-indicator's arguments, added to its subparser ``p``."""
    from ..hardware.fake_indicator import FAULTS

    p.description = "Serve a simulated drawstring indicator on a pseudo-terminal; prints its device path."
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
    p.add_argument("--noise-mm", type=non_negative(float), default=0.0)
    p.add_argument("--drift-mm-per-s", type=float, default=0.0)
    p.add_argument("--fault", choices=FAULTS, help="inject this fault ...")
    p.add_argument("--fault-every", type=int, default=0, help="... on every Nth answer (0: never)")
    return p


def fake_indicator_main(argv: Sequence[str] | None = None) -> int:
    """Run the simulated dial indicator.

    ``fake_indicator.py [--protocol modbus|ascii] [--value-mm V | --values F.csv --follow OUT.csv] ...``.
    """
    from ..hardware.fake_indicator import FakeIndicator
    from ..measurements import read_measurements

    args = parse_args("fake-indicator", argv)
    p = fake_indicator_parser()  # its error(): one line, exit 2, as a bad argument's
    values = None
    if args.values:
        if not args.follow:
            p.error("--values needs --follow (the collector's output file)")
        try:
            values = (read_measurements(args.values).lengths * 1e3).tolist()
        except CalibPinError as e:
            p.error(str(e))
    if args.fault_every < 0 or (args.fault and not args.fault_every):
        p.error("--fault needs --fault-every N with N >= 1")
    try:
        fake = FakeIndicator(
            args.protocol, args.value_mm, slave=args.slave, register=args.register, words=args.words,
            signed=not args.unsigned, word_order=args.word_order, scale_mm=args.scale_mm,
            noise_mm=args.noise_mm, drift_mm_per_s=args.drift_mm_per_s, values_mm=values, follow=args.follow,
        )
    except CalibPinError as e:
        p.error(str(e))
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

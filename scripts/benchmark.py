#!/usr/bin/env python3
"""`python scripts/benchmark.py --help`: the same as `calib-pin benchmark` (calib_pin.cli)."""

import sys

from calib_pin.cli import command

if __name__ == "__main__":
    sys.exit(command("benchmark")(sys.argv[1:]))

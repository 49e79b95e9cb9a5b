#!/usr/bin/env python3
"""`python scripts/simulate.py --help`: the same as `calib-pin simulate` (calib_pin.cli)."""

import sys

from calib_pin.cli import command

if __name__ == "__main__":
    sys.exit(command("simulate")(sys.argv[1:]))

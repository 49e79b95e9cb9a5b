#!/usr/bin/env python3
"""`python scripts/simulate.py --help`: the same as `calib-pin simulate` (calib_pin.cli)."""

import sys

from calib_pin.cli.process import run_command

if __name__ == "__main__":
    sys.exit(run_command("simulate", sys.argv[1:]))

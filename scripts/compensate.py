#!/usr/bin/env python3
"""`python scripts/compensate.py --help`: the same as `calib-pin compensate` (calib_pin.cli)."""

import sys

from calib_pin.cli.process import run_command

if __name__ == "__main__":
    sys.exit(run_command("compensate", sys.argv[1:]))

#!/usr/bin/env python3
"""`python scripts/fake_indicator.py --help`: the same as `calib-pin fake-indicator` (calib_pin.cli)."""

import sys

from calib_pin.cli.process import run_command

if __name__ == "__main__":
    sys.exit(run_command("fake-indicator", sys.argv[1:]))

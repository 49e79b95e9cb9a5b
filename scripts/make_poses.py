#!/usr/bin/env python3
"""`python scripts/make_poses.py --help`: the same as `calib-pin make-poses` (calib_pin.cli)."""

import sys

from calib_pin.cli.process import run_command

if __name__ == "__main__":
    sys.exit(run_command("make-poses", sys.argv[1:]))

#!/usr/bin/env python3
"""`python scripts/detect.py --help`: the same as `calib-pin detect` (calib_pin.cli)."""

import sys

from calib_pin.cli.process import run_command

if __name__ == "__main__":
    sys.exit(run_command("detect", sys.argv[1:]))

#!/usr/bin/env python3
"""`python scripts/benchmark.py --help`: the same as `calib-pin benchmark` (calib_pin.cli)."""

import sys

from calib_pin.cli.process import run_command

if __name__ == "__main__":
    sys.exit(run_command("benchmark", sys.argv[1:]))

#!/usr/bin/env python3
"""Thin wrapper: see `python scripts/calibrate.py --help` and calib_pin.cli."""

import sys

from calib_pin.cli import calibrate_main

if __name__ == "__main__":
    sys.exit(calibrate_main())

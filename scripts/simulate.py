#!/usr/bin/env python3
"""Thin wrapper: see `python scripts/simulate.py --help` and calib_pin.cli."""

import sys

from calib_pin.cli import simulate_main

if __name__ == "__main__":
    sys.exit(simulate_main())

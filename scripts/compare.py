#!/usr/bin/env python3
"""Thin wrapper: see `python scripts/compare.py --help` and calib_pin.cli."""

import sys

from calib_pin.cli import compare_main

if __name__ == "__main__":
    sys.exit(compare_main())

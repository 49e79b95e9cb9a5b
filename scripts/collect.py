#!/usr/bin/env python3
"""Thin wrapper: see `python scripts/collect.py --help` and calib_pin.collect_cli."""

import sys

from calib_pin.collect_cli import collect_main

if __name__ == "__main__":
    sys.exit(collect_main())

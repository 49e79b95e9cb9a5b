#!/usr/bin/env python3
"""Thin wrapper: see `python scripts/fake_indicator.py --help` and calib_pin.collect_cli."""

import sys

from calib_pin.collect_cli import fake_indicator_main

if __name__ == "__main__":
    sys.exit(fake_indicator_main())

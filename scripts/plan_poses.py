#!/usr/bin/env python3
"""Thin wrapper: see `python scripts/plan_poses.py --help` and calib_pin.collect_cli."""

import sys

from calib_pin.collect_cli import plan_poses_main

if __name__ == "__main__":
    sys.exit(plan_poses_main())

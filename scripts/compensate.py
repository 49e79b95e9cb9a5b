#!/usr/bin/env python3
"""`python scripts/compensate.py --help`: the same as `calib-pin compensate` (calib_pin.cli)."""

import sys

from calib_pin.cli import command

if __name__ == "__main__":
    sys.exit(command("compensate")(sys.argv[1:]))

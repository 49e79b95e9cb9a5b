"""``python -m calib_pin.cli COMMAND ...``: the ``calib-pin`` console script
(:func:`calib_pin.cli.process.main`), for an environment without it on the PATH."""

import sys

from .process import main

if __name__ == "__main__":
    sys.exit(main())

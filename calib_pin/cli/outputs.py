"""The commands' ``--force`` option.

The output writer itself (:class:`Outputs`: inputs never replaced, existing files only
with ``force``, all outputs or none) is the library's, :mod:`calib_pin.util.outputs`.
"""

from __future__ import annotations

import argparse


def add_force_argument(p: argparse.ArgumentParser, what: str = "output file") -> None:
    """``--force``: replace an existing output (never one of the command's inputs)."""
    p.add_argument("--force", action="store_true",
                   help=f"replace an existing {what} (without --force an existing output is refused; "
                   "an output that is one of the command's inputs is refused even with --force)")


__all__ = ["add_force_argument"]

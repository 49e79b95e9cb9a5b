"""The installed calib-pin's version."""

from __future__ import annotations

from functools import cache


@cache
def package_version() -> str:
    """The installed distribution's version (``0+unknown`` for a source tree not installed)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("calib-pin")
    except PackageNotFoundError:
        return "0+unknown"

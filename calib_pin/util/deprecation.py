"""Deprecation warnings that point at the caller's line, and names kept at a previous path.

:func:`warn_deprecated` reports a DeprecationWarning at the first frame outside calib_pin,
however deep in the library it is raised, so Python's default filters show it to a
script that calls a deprecated argument. :func:`moved_names` gives a module the
``__getattr__`` of names that moved to another module: each is imported from its new module
on first use (a module below that one in the layers imports nothing of it), with a warning.
"""

from __future__ import annotations

import importlib
import sys
import warnings
from collections.abc import Callable, Mapping
from typing import Any

_PACKAGE = __name__.split(".")[0]


def _internal(frame: Any) -> bool:
    """A frame of the import machinery, which :func:`warnings.warn` skips when it counts levels."""
    filename = frame.f_code.co_filename
    return "importlib" in filename and "_bootstrap" in filename


def _ours(frame: Any) -> bool:
    return str(frame.f_globals.get("__name__", "")).split(".")[0] == _PACKAGE


def warn_deprecated(message: str) -> None:
    """Warn ``message`` as a DeprecationWarning at the first caller outside calib_pin.

    Args:
        message: What is deprecated and what to use instead.
    """
    frame = sys._getframe(1)
    level = 2  # the caller of this function
    while frame.f_back is not None and (_ours(frame) or _internal(frame)):
        frame = frame.f_back
        level += 0 if _internal(frame) else 1
    warnings.warn(message, DeprecationWarning, stacklevel=level)


def moved_names(module: str, moved: Mapping[str, str], advice: Mapping[str, str] | None = None) -> Callable[[str], Any]:
    """A module ``__getattr__`` that gives each old name of ``moved`` from its new place.

    Args:
        module: The module's name (``calib_pin.sensors.pose``).
        moved: Old name -> ``"<new module>:<new name>"`` (``:<new name>`` may be left
            out when the name is unchanged).
        advice: Old name -> what the warning says to use instead, where its new path is not
            the whole answer (default: ``use <its new path>``).

    Returns:
        ``__getattr__(name)``: the object, with a DeprecationWarning naming where it is now;
        AttributeError for any other name.
    """

    def __getattr__(name: str) -> Any:
        if name not in moved:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        where, _, new = moved[name].partition(":")
        new = new or name
        instead = (advice or {}).get(name, f"use {where}.{new}")
        warn_deprecated(f"{module}.{name} is deprecated: {instead}")
        return getattr(importlib.import_module(where), new)

    return __getattr__

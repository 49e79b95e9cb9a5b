"""filterpy's Kalman filters without the import of scipy.stats they do not need here.

``import filterpy`` runs its package ``__init__``, which imports every subpackage, and
``filterpy.stats`` imports ``scipy.stats`` (about 0.6 s warm on a loaded 2-core machine,
most of a quick start's import time). The filters use ``filterpy.stats`` for one thing,
``logpdf``, inside their lazily computed ``log_likelihood``/``likelihood`` properties,
which calib-pin never reads. :func:`kalman` puts a stand-in ``filterpy.stats`` in
``sys.modules`` first: a module whose ``logpdf`` (the one name filterpy's filters
import from it) loads the real ``filterpy.stats.stats`` (and so scipy.stats) when
called, and whose other attributes load it on first access. Everything filterpy does works as before; only
the moment scipy.stats is imported moves. When ``filterpy.stats`` was already imported
the stand-in is not installed.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import types
from typing import Any


def _real_stats() -> types.ModuleType:
    return importlib.import_module("filterpy.stats.stats")  # found through the stand-in's __path__


def _logpdf(*args: Any, **kwargs: Any) -> Any:
    """filterpy.stats.logpdf, imported when first called."""
    return _real_stats().logpdf(*args, **kwargs)


class _DeferredStats(types.ModuleType):
    """``filterpy.stats`` whose attributes come from the real module, imported on first use."""

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        real = _real_stats()
        self.__dict__.update({k: v for k, v in vars(real).items() if not k.startswith("__")})
        if name not in self.__dict__:
            raise AttributeError(f"module 'filterpy.stats' has no attribute '{name}'")
        return self.__dict__[name]


def _defer_stats() -> None:
    if "filterpy.stats" in sys.modules or "filterpy" in sys.modules:
        return
    spec = importlib.util.find_spec("filterpy")
    if spec is None or not spec.submodule_search_locations:
        return  # filterpy is missing: the import below says so
    stats = _DeferredStats("filterpy.stats")
    stats.__path__ = [f"{spec.submodule_search_locations[0]}/stats"]
    stats.__package__ = "filterpy.stats"
    stats.logpdf = _logpdf  # type: ignore[attr-defined]
    sys.modules["filterpy.stats"] = stats


def kalman() -> types.ModuleType:
    """``filterpy.kalman`` (ExtendedKalmanFilter, UnscentedKalmanFilter, MerweScaledSigmaPoints),
    imported with ``filterpy.stats`` deferred (see the module docstring)."""
    _defer_stats()
    return importlib.import_module("filterpy.kalman")

"""filterpy's Kalman filters without the scipy.stats and scipy.ndimage imports they do not need.

``import filterpy`` runs its package ``__init__``, which imports every subpackage:
``filterpy.stats`` imports ``scipy.stats`` (slow to import: most of a quick start's
import time) and ``filterpy.discrete_bayes`` imports ``scipy.ndimage`` (slow too).
The filters use ``filterpy.stats`` for one thing,
``logpdf``, inside their lazily computed ``log_likelihood``/``likelihood`` properties,
which calib-pin never reads, and never use ``discrete_bayes``. :func:`kalman` puts
stand-ins for both in ``sys.modules`` first: modules whose attributes load the real
module (:data:`DEFERRED`) on first access, and a ``logpdf`` (the one name filterpy's
filters import from ``stats``) that loads the real ``filterpy.stats.stats`` (and so
scipy.stats) when called. Everything filterpy does works unchanged; only the moment
scipy.stats and scipy.ndimage are imported moves. When filterpy or either subpackage is
already imported the stand-ins are not installed.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import types
from typing import Any

#: filterpy subpackages put off: stand-in name -> the module holding its names.
DEFERRED = {"filterpy.stats": "filterpy.stats.stats",
            "filterpy.discrete_bayes": "filterpy.discrete_bayes.discrete_bayes"}


def _real_stats() -> types.ModuleType:
    return importlib.import_module("filterpy.stats.stats")  # found through the stand-in's __path__


def _logpdf(*args: Any, **kwargs: Any) -> Any:
    """filterpy.stats.logpdf, imported when first called."""
    return _real_stats().logpdf(*args, **kwargs)


class _Deferred(types.ModuleType):
    """A filterpy subpackage whose attributes come from its real module, imported on first use.

    The real modules are named in :data:`DEFERRED`.
    """

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        real = importlib.import_module(DEFERRED[self.__name__])  # found through the stand-in's __path__
        self.__dict__.update({k: v for k, v in vars(real).items() if not k.startswith("__")})
        if name not in self.__dict__:
            raise AttributeError(f"module '{self.__name__}' has no attribute '{name}'")
        return self.__dict__[name]


def _defer_stats() -> None:
    if "filterpy" in sys.modules or any(name in sys.modules for name in DEFERRED):
        return
    spec = importlib.util.find_spec("filterpy")
    if spec is None or not spec.submodule_search_locations:
        return  # filterpy is missing: the import below says so
    for name in DEFERRED:
        stand_in = _Deferred(name)
        stand_in.__path__ = [f"{spec.submodule_search_locations[0]}/{name.rsplit('.', 1)[1]}"]
        stand_in.__package__ = name
        sys.modules[name] = stand_in
    sys.modules["filterpy.stats"].logpdf = _logpdf  # type: ignore[attr-defined]


def kalman() -> types.ModuleType:
    """``filterpy.kalman``, imported with ``filterpy.stats`` and ``filterpy.discrete_bayes`` deferred.

    It holds ExtendedKalmanFilter, UnscentedKalmanFilter, MerweScaledSigmaPoints; see the
    module docstring.
    """
    _defer_stats()
    return importlib.import_module("filterpy.kalman")

"""Optional dependencies: a missing one is named with the pip command that installs it."""

from __future__ import annotations

import importlib
from types import ModuleType

from .exceptions import CalibPinError

#: Module -> the extra of calib-pin that installs it.
EXTRAS = {"matplotlib": "plots", "serial": "hardware", "minimalmodbus": "hardware", "dask": "cluster",
          "distributed": "cluster", "joblib": "cluster"}


def require(module: str) -> ModuleType:
    """Import an optional dependency.

    Raises:
        CalibPinError: it is not installed; the message names the pip command.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        extra = EXTRAS.get(module.split(".")[0], "")
        hint = f"pip install 'calib-pin[{extra}]'" if extra else f"pip install {module}"
        raise CalibPinError(f"this needs the optional package '{module.split('.')[0]}': {hint}") from None

"""Optional dependencies: a missing one is named with the pip command that installs it.

Figures are optional everywhere: :func:`figures_or_warn` draws them, and any failure of
matplotlib (not installed, broken, or an exception while drawing) costs the figure one
warning line on stderr, never the other outputs. calib-pin draws on matplotlib's Agg
canvas only (no pyplot, no screen), so an ``MPLBACKEND`` that matplotlib refuses at
import is replaced by Agg for the process (:func:`import_matplotlib`).
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys
from collections.abc import Callable
from types import ModuleType
from typing import TypeVar

from ..exceptions import CalibPinError

#: Module -> the extra of calib-pin that installs it.
EXTRAS = {"matplotlib": "plots", "serial": "hardware", "minimalmodbus": "hardware", "dask": "cluster",
          "distributed": "cluster", "joblib": "cluster"}

#: Module -> the package that provides it, where the names differ.
PACKAGES = {"cv2": "opencv-python-headless"}

T = TypeVar("T")

#: Why matplotlib's backend was replaced by Agg in this process, until it is printed once.
_backend_note: list[str] = []


def require(module: str, extra: str = "") -> ModuleType:
    """Import an optional dependency (matplotlib through :func:`import_matplotlib`).

    Args:
        module: The module's name (``matplotlib``, ``filterpy``, ...).
        extra: The extra of calib-pin that installs it, when :data:`EXTRAS` does not say.

    Raises:
        CalibPinError: it is not installed (the message names the pip command), or it is
            installed but its import fails (the message gives the reason).
    """
    top = module.split(".")[0]
    if top == "matplotlib":
        import_matplotlib()
    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise _unavailable(module, e, extra) from None


def _unavailable(module: str, error: Exception, extra: str = "") -> CalibPinError:
    """The one-line reason an optional package cannot be imported."""
    top = module.split(".")[0]
    try:
        installed = importlib.util.find_spec(top) is not None
    except (ImportError, ValueError):
        installed = False
    missing = isinstance(error, ModuleNotFoundError) and error.name == top
    if installed and not missing:
        return CalibPinError(f"the optional package '{top}' is installed but cannot be imported "
                             f"({type(error).__name__}: {error})")
    extra = extra or EXTRAS.get(top, "")
    hint = f"pip install 'calib-pin[{extra}]'" if extra else f"pip install {module}"
    package = PACKAGES.get(top, top)
    return CalibPinError(f"this needs the optional package '{package}': {hint}")


def import_matplotlib() -> ModuleType:
    """matplotlib, for drawing on the Agg canvas.

    An ``MPLBACKEND`` matplotlib refuses at import (``MPLBACKEND=nonsense``) is replaced
    by ``agg`` in this process's environment and the import repeated; the next
    :func:`figures_or_warn` says so in one line. A valid one is left alone (calib-pin never
    uses the backend).

    Raises:
        CalibPinError: matplotlib is not installed, or its import fails for another reason.
    """
    loaded = sys.modules.get("matplotlib")
    if loaded is not None and hasattr(loaded, "rcParams"):
        return loaded
    try:
        return importlib.import_module("matplotlib")
    except ImportError as e:
        raise _unavailable("matplotlib", e) from None
    except Exception as e:  # matplotlib raises ValueError for a bad MPLBACKEND at import
        backend = os.environ.get("MPLBACKEND")
        if backend is None or backend.lower() == "agg":
            raise CalibPinError(f"matplotlib cannot be imported ({type(e).__name__}: {e})") from None
        for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
            del sys.modules[name]  # the failed, half-done import
        os.environ["MPLBACKEND"] = "agg"
        try:
            module = importlib.import_module("matplotlib")
        except Exception as again:
            raise CalibPinError(f"matplotlib cannot be imported ({type(again).__name__}: {again})") from None
        _backend_note[:] = [f"MPLBACKEND={backend!r} is not a backend matplotlib accepts: ignored, figures "
                            "drawn off-screen with Agg"]
        return module


def figures_or_warn(what: str, draw: Callable[[], T], hint: str = "") -> T | None:
    """``draw()`` (which draws with matplotlib), or None after one warning line on stderr.

    Any failure (matplotlib missing or broken, an exception while drawing) prints
    ``warning: no WHAT: REASON`` (and ``hint``) and returns None, so the caller writes its
    other outputs; KeyboardInterrupt and SystemExit pass. A bad ``MPLBACKEND`` replaced by
    Agg prints its one warning line once, and the figures are drawn.

    Args:
        what: What is skipped on failure, for people (``report.html``, ``the figures``).
        draw: Makes the figures (imports matplotlib or calib-pin's figure modules itself).
        hint: Appended to the warning (e.g. ``--no-html silences this``).
    """
    try:
        require("matplotlib")
        result = draw()
    except Exception as e:
        if isinstance(e, CalibPinError):
            reason = str(e)
        elif isinstance(e, ImportError):
            reason = f"matplotlib cannot be imported ({type(e).__name__}: {e})"
        else:
            reason = f"drawing failed ({type(e).__name__}: {e})"
        print(f"warning: no {what}: {reason}{f' ({hint})' if hint else ''}", file=sys.stderr)
        return None
    if _backend_note:  # once per process
        print(f"warning: {_backend_note.pop()}", file=sys.stderr)
    return result

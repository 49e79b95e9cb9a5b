"""Progress bars for long work: shown on a terminal, silent in a pipe or when quiet.

A bar (tqdm, with rate and ETA) goes to stderr only, and only when stderr is a
terminal; stdout, which scripts parse, never carries progress. A command's ``--quiet``
turns every bar of the work it runs off with :func:`quiet_progress`, so the library
functions (compare, plan_poses, collect, the PSO and DE generations) need no flag of
their own.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterable, Iterator
from contextvars import ContextVar
from typing import Any, TextIO, TypeVar


def _tqdm() -> Any:
    """tqdm's bar class, imported when a bar is drawn (not at every command's start)."""
    from tqdm import tqdm  # type: ignore[import-untyped]

    return tqdm

T = TypeVar("T")

#: True inside :func:`quiet_progress`: no bar is drawn.
_QUIET: ContextVar[bool] = ContextVar("calib_pin_quiet_progress", default=False)


@contextlib.contextmanager
def quiet_progress(quiet: bool = True) -> Iterator[None]:
    """Within this block no progress bar is drawn (when ``quiet``)."""
    token = _QUIET.set(quiet or _QUIET.get())
    try:
        yield
    finally:
        _QUIET.reset(token)


def _terminal(quiet: bool, stream: TextIO | None) -> TextIO | None:
    """Where to draw a bar: stderr (or ``stream``) when it is a terminal and nothing is quiet."""
    out = sys.stderr if stream is None else stream
    isatty = getattr(out, "isatty", None)
    if quiet or _QUIET.get() or isatty is None or not isatty():
        return None
    return out


def progress(
    iterable: Iterable[T],
    total: int | None = None,
    desc: str = "",
    quiet: bool = False,
    stream: TextIO | None = None,
) -> Iterator[T]:
    """Iterate over ``iterable`` with a progress bar on a terminal.

    Args:
        iterable: The work items.
        total: Number of items when ``iterable`` has no length (a generator), or None.
        desc: Label in front of the bar (e.g. ``"trials"``).
        quiet: Never show a bar (``--quiet``).
        stream: Where the bar goes; default ``sys.stderr`` (read at call time). A bar
            is drawn only when this stream is a terminal.

    Returns:
        An iterator over the same items, in order.
    """
    out = _terminal(quiet, stream)
    if out is None:
        return iter(iterable)
    return iter(_tqdm()(iterable, total=total, desc=desc or None, file=out, leave=False,
                     dynamic_ncols=True, unit="it"))


def status(line: str, quiet: bool = False, stream: TextIO | None = None) -> None:
    """One line on stderr (or ``stream``) saying what long work starts (e.g. drawing the figures).

    Under the bars' rule: only on a terminal, never when quiet.
    """
    out = _terminal(quiet, stream)
    if out is not None:
        print(line, file=out, flush=True)


@contextlib.contextmanager
def progress_bar(total: int, desc: str = "", quiet: bool = False, stream: TextIO | None = None) -> Iterator[Any | None]:
    """A bar advanced by hand (``bar.update(n)``), for work that is not one loop.

    Args:
        total: Items expected.
        desc, quiet, stream: As :func:`progress`.

    Yields:
        A tqdm bar (``update(n=1)``) on a terminal, else None (no bar: nothing to update).
    """
    out = _terminal(quiet, stream)
    if out is None:
        yield None
        return
    bar = _tqdm()(total=total, desc=desc or None, file=out, leave=False, dynamic_ncols=True, unit="it")
    try:
        yield bar
    finally:
        bar.close()

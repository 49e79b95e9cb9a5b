"""Finished work of a long run, kept on disk so that Ctrl-C or a fault loses none of it.

A :class:`Checkpoint` lives in the run's output folder (``OUT/.calib-pin-checkpoint/``)
and holds one JSON file per finished item (a batch set, a comparison trial), written
atomically (a temporary file, fsync, rename) as soon as the item is done. Each file is
named by the item's *key*, a fingerprint of everything its result depends on (the input
files' bytes, the robot, the method, the seed, the options, the calib-pin version):
the same command run again finds the finished items and runs only the rest; a command
with other inputs or options finds no key of its own and reuses nothing.

:meth:`Checkpoint.map` runs the items not yet done with
:func:`calib_pin.studies.parallel.parallel_completed` and keeps each as it finishes; Ctrl-C
becomes :class:`Interrupted` and a worker or scheduler fault a
:class:`~calib_pin.studies.parallel.ParallelFault`, each one line that says how many items are
kept and that the same command resumes. JSON, not pickle: a file in an output folder
is read as data, never run.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar

from ..exceptions import CalibPinError
from ..util.atomic import write_text
from .parallel import ParallelFault, parallel_completed

T = TypeVar("T")
R = TypeVar("R")

#: The checkpoint's folder inside a run's output folder.
CHECKPOINT_FOLDER = ".calib-pin-checkpoint"
#: Format of a checkpoint file (a file of another format is not reused).
FORMAT = 1


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a checkpointed run; the message says what is kept and how to resume."""


def file_digest(path: str | os.PathLike[str] | None) -> str | None:
    """SHA-256 of a file's bytes, or None when there is no such file (a robot name, say)."""
    if path is None or not Path(path).is_file():
        return None
    digest = hashlib.sha256()
    with Path(path).open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def fingerprint(*parts: Any) -> str:
    """A key of ``parts`` and the calib-pin version: equal parts give equal keys, any difference another.

    ``parts`` are JSON-able values: names, numbers, digests, option dicts.
    """
    from ..util.version import package_version

    text = json.dumps([FORMAT, package_version(), *parts], sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


class Checkpoint:
    """The finished items of a run, in ``folder/.calib-pin-checkpoint``.

    Args:
        folder: The run's output folder.
        noun: What an item is, in messages (``set``, ``trial``).
    """

    def __init__(self, folder: str | os.PathLike[str], noun: str = "item") -> None:
        self.out = Path(folder)
        self.folder = self.out / CHECKPOINT_FOLDER
        self.noun = noun

    def _path(self, key: str) -> Path:
        return self.folder / f"{self.noun}-{key}.json"

    def load(self, key: str) -> Any | None:
        """The kept result of ``key`` (as saved), or None when there is none or it cannot be read."""
        try:
            content = json.loads(self._path(key).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(content, dict) or content.get("format") != FORMAT or content.get("key") != key:
            return None
        return content.get("result")

    def save(self, key: str, result: Any) -> None:
        """Keep ``result`` (JSON-able) under ``key``, atomically: the file is whole or absent.

        Args:
            key: The item's :func:`fingerprint`.
            result: The item's result, a JSON-able value.

        Raises:
            OSError: it could not be written (a full disk); no file is then left.
        """
        self.folder.mkdir(parents=True, exist_ok=True)
        text = json.dumps({"format": FORMAT, "key": key, "result": result}, allow_nan=True)
        write_text(self._path(key), text)

    def clear(self) -> None:
        """Remove the checkpoint (after a complete run)."""
        shutil.rmtree(self.folder, ignore_errors=True)

    def kept(self, done: int, total: int) -> str:
        """``3 of 8 set(s) kept in OUT; run the same command to resume`` (or that none is)."""
        if not done:
            return f"no {self.noun} was finished, nothing was kept"
        return f"{done} of {total} {self.noun}(s) kept in {self.out}; run the same command to resume"

    def unwritten(self, error: Exception, total: int) -> Exception:
        """``error`` (the outputs could not be written, so none was) saying that all ``total`` items are kept.

        For example ``...: cannot write: File too large; no output was changed; 3 of 3
        set(s) kept in OUT; run the same command to resume``.
        """
        if not self.folder.is_dir():
            return error
        kept = self.kept(total, total)
        if isinstance(error, CalibPinError):
            return CalibPinError(f"{error}; {kept}")
        if isinstance(error, OSError):
            where = f"{error.filename}: " if error.filename else ""
            return CalibPinError(f"{where}cannot write: {error.strerror or error}; nothing was written; {kept}")
        return error

    def map(
        self,
        fn: Callable[[T], R],
        items: Sequence[T],
        keys: Sequence[str],
        *,
        encode: Callable[[R], Any],
        decode: Callable[[Any], R],
        keep: Callable[[R], bool] | None = None,
        jobs: int = 1,
        scheduler: str | None = None,
        notify: Callable[[str], Any] | None = None,
    ) -> list[R]:
        """``[fn(item) for item in items]``, in order: the kept results, and the others run and kept.

        The others run with :func:`~calib_pin.studies.parallel.parallel_completed` and are
        kept as each finishes.

        Args:
            fn, items, jobs, scheduler: As :func:`calib_pin.studies.parallel.parallel_map`.
            keys: Each item's :func:`fingerprint`.
            encode, decode: A result to a JSON-able value and back (exactly).
            keep: Whether a result is kept (default all); one that is not (a fault of the
                machine, say) runs again in the next run.
            notify: Called with one line when kept results are reused
                (``resuming OUT: 3 of 8 set(s) already done``).

        Raises:
            Interrupted: Ctrl-C; the message says how many items are kept.
            ParallelFault: a worker or the scheduler failed; the same, in one line.
            CalibPinError: a result could not be kept (a full disk); the same.
        """
        items = list(items)
        results: dict[int, R] = {}
        for i, key in enumerate(keys):
            kept = self.load(key)
            if kept is not None:
                with contextlib.suppress(Exception):  # a file of another layout is not a result
                    results[i] = decode(kept)
        if results and notify is not None:
            notify(f"resuming {self.out}: {len(results)} of {len(items)} {self.noun}(s) already done")
        todo = [i for i in range(len(items)) if i not in results]
        saved = len(results)  # results on disk
        try:
            for j, result in parallel_completed(fn, [items[i] for i in todo], jobs, scheduler):
                i = todo[j]
                results[i] = result
                if keep is not None and not keep(result):
                    continue
                try:
                    self.save(keys[i], encode(result))
                except OSError as e:
                    kept = self.kept(saved, len(items)) if saved else f"none of the {len(items)} {self.noun}(s) is kept"
                    raise CalibPinError(f"{self.folder}: cannot keep a finished {self.noun} ({e.strerror or e}); "
                                        f"{kept}") from None
                saved += 1
        except KeyboardInterrupt:
            raise Interrupted(f"stopped by Ctrl-C: {self.kept(saved, len(items))}") from None
        except ParallelFault as e:
            if not saved:
                raise
            raise ParallelFault(f"{e}; {self.kept(saved, len(items))}") from None
        return [results[i] for i in range(len(items))]

"""A command's output files: written under temporary names, renamed together at the end.

A run that fails leaves no file of its own and no mix of an earlier run's files with
new ones: every output is written beside its final name, and only when all are written
are they renamed into place (each rename is atomic).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any


class Outputs:
    """The output files of one run.

    Args:
        folder: Where they go (created when the first file is committed).
    """

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self._pending: list[tuple[Path, Callable[[Path], Any]]] = []

    def add(self, path: Path, write: Callable[[Path], Any]) -> None:
        """Write ``path`` later, through ``write(temporary_path)``."""
        self._pending.append((Path(path), write))

    def commit(self) -> list[Path]:
        """Write every file under a temporary name, then rename them all into place.

        Raises:
            OSError: a file could not be written (no output file is then changed).
        """
        done: list[tuple[Path, Path]] = []
        try:
            for path, write in self._pending:
                path.parent.mkdir(parents=True, exist_ok=True)
                tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
                done.append((tmp, path))
                write(tmp)
        except BaseException:
            for tmp, _ in done:
                tmp.unlink(missing_ok=True)
            raise
        for tmp, path in done:
            os.replace(tmp, path)
        return [path for _, path in done]

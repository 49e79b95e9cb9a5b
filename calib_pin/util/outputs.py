"""Output files: checked first, written under temporary names, renamed together.

Every command and the library's :func:`calib_pin.report.bundle.write_outputs` write
through :class:`Outputs`, so one rule holds for all of them:

* an output that is one of the command's inputs is always refused (``--force`` too):
  the paths are compared as files (:func:`os.path.samefile`), so ``./p.csv``, a
  symbolic link or a hard link to an input are caught as well;
* an output that is a device, a pipe or a socket is always refused (a rename would put
  a regular file in the place of ``/dev/null``);
* an existing output is refused unless ``force`` (the command's ``--force``) is given;
* every output is written beside its final name and synced; only when all are written
  are they renamed into place. A failure part-way (a full disk, a rename that fails,
  Ctrl-C) restores the files that were there before, removes the new ones that had no
  predecessor, and leaves no temporary file: all of the outputs or none.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import stat
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..exceptions import CalibPinError
from .atomic import fsync_path

#: What a caller names inputs as: ``{label: path}`` (label = the option, e.g. ``--targets``).
Inputs = Mapping[str, "str | os.PathLike[str] | None"]


#: Every file a commit of this process placed, in order (what a Ctrl-C after it keeps).
WRITTEN: list[Path] = []


class OutputError(CalibPinError):
    """An output file that must not be written, or one that could not be written.

    Must not: an input, a folder, or an existing file without ``--force``; could not:
    nothing was then changed.
    """


def _same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name one file (either may not exist yet)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        try:
            return a.resolve() == b.resolve()
        except (OSError, RuntimeError, ValueError):  # a symbolic link loop, a NUL in the name
            return os.path.abspath(a) == os.path.abspath(b)


def input_role(path: str | os.PathLike[str], inputs: Inputs) -> str | None:
    """The label of the input ``path`` is (compared as files), or None."""
    for label, given in inputs.items():
        if given is not None and str(given) != "" and _same_file(Path(path), Path(given)):
            return label
    return None


def refuse_input(path: str | os.PathLike[str], inputs: Inputs) -> None:
    """Refuse an output ``path`` that is one of ``inputs`` (always, whatever ``--force``).

    Args:
        path: The output file.
        inputs: The caller's input files by label.

    Raises:
        OutputError: naming the file and the input it is.
    """
    label = input_role(path, inputs)
    if label is not None:
        raise OutputError(f"{path} is an input of this command ({label}): choose another output "
                          "(--force never replaces an input)")


class Outputs:
    """The output files of one run.

    Args:
        folder: Where they go (created when the first file is committed).
        force: Replace existing files (the command's ``--force``). False: an existing
            output is refused. Library callers that own their folder (``calibrate``'s
            ``--out``, ``batch``) keep the default True.
        inputs: The command's input files by label (``{"--targets": "t.csv"}``): none
            of them is ever an output.
    """

    def __init__(self, folder: Path, *, force: bool = True, inputs: Inputs | None = None) -> None:
        self.folder = Path(folder)
        self.force = force
        self.inputs: dict[str, Any] = dict(inputs or {})
        self._pending: list[tuple[Path, Callable[[Path], Any]]] = []

    def check(self, path: str | os.PathLike[str]) -> Path:
        """Refuse ``path`` at once, before the work that makes it.

        Refused: an input, a folder, or an existing file without ``force``.

        Args:
            path: The output file.

        Raises:
            OutputError: one line naming the file (and ``--force`` where it helps).
        """
        path = Path(path)
        if not path.name:
            raise OutputError(f"'{path}' is not a file name")
        refuse_input(path, self.inputs)
        if path.is_dir():
            raise OutputError(f"{path} is a folder: give a file name")
        special = _special(path)
        if special:
            raise OutputError(f"{path} is {special}, not a file: give a file name (--force never replaces it)")
        if not self.force and os.path.lexists(path):
            raise OutputError(f"{path} exists: give --force to replace it")
        return path

    def add(self, path: str | os.PathLike[str], write: Callable[[Path], Any]) -> None:
        """Write ``path`` later, through ``write(temporary_path)``; refused at once as :meth:`check`."""
        self._pending.append((self.check(path), write))

    def commit(self) -> list[Path]:
        """Write every file under a temporary name, then rename them all into place.

        Returns:
            The files written, in the order added.

        Raises:
            OutputError: a file could not be written or renamed, or an output appeared
                meanwhile (without ``force``); every output is then as it was before.
        """
        staged: list[tuple[Path, Path]] = []
        try:
            for path, write in self._pending:
                self.check(path)  # again: a file may have appeared while the command worked
                _make_folder(path)
                tmp = _sibling(path, "tmp")
                staged.append((tmp, path))
                try:
                    write(tmp)
                    fsync_path(tmp)  # a rename must not publish a file still in cache
                except OSError as e:
                    raise OutputError(f"{path}: cannot write: {e.strerror or e}; no output was changed") from None
            self._place(staged)
        finally:
            for tmp, _ in staged:
                _remove(tmp)
        WRITTEN.extend(path for _, path in staged)
        for folder in dict.fromkeys(path.parent for _, path in staged):
            fsync_path(folder, strict=False)  # the renames
        return [path for _, path in staged]

    def _place(self, staged: list[tuple[Path, Path]]) -> None:
        """Rename each temporary file to its final name; on a failure, undo the ones done."""
        placed: list[tuple[Path, Path | None]] = []  # (final, backup of what it replaced)
        current = self.folder
        try:
            for tmp, current in staged:
                backup = _keep(current) if self.force else None
                try:
                    if self.force:
                        os.replace(tmp, current)
                    else:
                        _link_new(tmp, current)
                except BaseException:
                    if backup is not None:
                        _remove(backup)
                    raise
                placed.append((current, backup))
        except BaseException as e:
            for path, backup in reversed(placed):
                with contextlib.suppress(OSError):
                    if backup is not None:
                        os.replace(backup, path)
                    else:
                        path.unlink()
            if isinstance(e, OSError):
                raise OutputError(f"{current}: cannot rename into place: {e.strerror or e}; "
                                  "no output was changed") from None
            raise
        for _, backup in placed:
            if backup is not None:
                _remove(backup)


def _special(path: Path) -> str | None:
    """What ``path`` is when it exists but is neither a regular file nor a symbolic link, else None.

    A rename would replace ``/dev/null`` or a FIFO by a regular file.
    """
    try:
        mode = os.lstat(path).st_mode
    except (OSError, ValueError):
        return None
    if stat.S_ISREG(mode) or stat.S_ISLNK(mode) or stat.S_ISDIR(mode):
        return None
    return "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a pipe or socket"


def _make_folder(path: Path) -> None:
    """Create the folder of output ``path``.

    Raises:
        OutputError: it cannot be made (a file is in its way, a read-only disk).
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise OutputError(f"{path}: cannot create its folder {path.parent}: a file is in the way; "
                          "no output was changed") from None
    except OSError as e:
        raise OutputError(f"{path}: cannot create its folder {path.parent}: {e.strerror or e}; "
                          "no output was changed") from None


def _sibling(path: Path, kind: str) -> Path:
    """A hidden name beside ``path`` for this process: ``.NAME.PID.KIND``."""
    return path.with_name(f".{path.name}.{os.getpid()}.{kind}")


def _keep(path: Path) -> Path | None:
    """A second name for the file ``path`` replaces, to put it back if the commit fails.

    A hard link; a copy where the filesystem has none. None if there is none (or it is a
    folder, which the rename then refuses).
    """
    if not os.path.lexists(path) or (path.is_dir() and not path.is_symlink()):
        return None
    backup = _sibling(path, "old")
    _remove(backup)
    try:
        os.link(path, backup, follow_symlinks=False)
    except OSError as e:
        if e.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.EMLINK, errno.ENOTSUP):
            raise
        shutil.copy2(path, backup, follow_symlinks=False)
    return backup


def _link_new(tmp: Path, path: Path) -> None:
    """Give ``tmp`` the name ``path`` only if no file has it (atomic where hard links work)."""
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise OutputError(f"{path} exists: give --force to replace it") from None
    except OSError as e:
        if e.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.EMLINK, errno.ENOTSUP):
            raise
        if os.path.lexists(path):
            raise OutputError(f"{path} exists: give --force to replace it") from None
        os.replace(tmp, path)


def _remove(path: Path) -> None:
    """Remove ``path`` if it is there.

    A clean-up that fails (a read-only folder, where no such file was made) never hides
    the error being reported.
    """
    with contextlib.suppress(OSError):
        path.unlink()


__all__ = ["WRITTEN", "Inputs", "OutputError", "Outputs", "input_role", "refuse_input"]

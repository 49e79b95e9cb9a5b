"""A library writer's file is whole or absent: written beside its name, synced, renamed.

The low-level pieces every writer shares are here too: :func:`write_all` (every byte of
a buffer, a short write continued, no progress a full disk) and :func:`fsync_path`.

:func:`write_bytes` and :func:`write_text` are what the public writers
(:func:`calib_pin.measurements.write_measurements`, ``write_poses``, the calibration
file, the corrected URDF, ...) write through, so a library caller on a full disk keeps
the file that was there before instead of a cut one. The commands add their own rules
on top (:mod:`calib_pin.util.outputs`: ``--force``, inputs, all outputs or none).
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from pathlib import Path


def write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically: a temporary file beside it, fsync, then a rename.

    The temporary file is ``.NAME.PID.part``, renamed over the name; a symbolic link is
    written through (its target is replaced), and a device or pipe (``/dev/stdout``) is
    written to as it is.

    Args:
        path: The file to write.
        data: Its bytes.

    Raises:
        OSError: it could not be written; the earlier file, if any, is unchanged and no
            temporary file is left.
    """
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        mode = None
    if mode is not None and not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
        path.write_bytes(data)  # a device or a pipe has no whole-or-absent: written through
        return path
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    tmp = target.with_name(f".{target.name}.{os.getpid()}.part")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        try:
            write_all(fd, data, name=str(path))
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return path


def write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> Path:
    """:func:`write_bytes` of ``text`` encoded (default UTF-8)."""
    return write_bytes(path, text.encode(encoding))


def write_all(fd: int, data: bytes, written: list[int] | None = None, name: str | None = None) -> None:
    """Write every byte of ``data`` to the descriptor ``fd``.

    A short write is continued, a write that makes no progress is a full disk.

    Args:
        fd: An open file descriptor.
        data: The bytes to write.
        written: A one-item list; ``written[0]`` counts the bytes written.
        name: The file's name, for the error.

    Raises:
        OSError: not every byte was written (``name`` in the error, if given).
    """
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        if n <= 0:  # no progress: a full disk
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), name)
        if written is not None:
            written[0] += n
        view = view[n:]


def fsync_path(path: str | os.PathLike[str], strict: bool = True) -> None:
    """Flush a file, or a folder's entries (its renames), to the disk.

    Args:
        path: The file or folder.
        strict: Raise when it cannot be flushed; False: a filesystem that cannot is left
            as it is.

    Raises:
        OSError: with ``strict``, it could not be flushed.
    """
    try:
        fd = os.open(path, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError:
        if strict:
            raise


__all__ = ["fsync_path", "write_all", "write_bytes", "write_text"]

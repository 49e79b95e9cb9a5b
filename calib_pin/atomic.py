"""A library writer's file is whole or absent: written beside its name, synced, renamed.

:func:`write_bytes` and :func:`write_text` are what the public writers
(:func:`calib_pin.measurements.write_measurements`, ``write_poses``, the calibration
file, the corrected URDF, ...) write through, so a library caller on a full disk keeps
the file that was there before instead of a cut one. The commands add their own rules
on top (:mod:`calib_pin.export.outputs`: ``--force``, inputs, all outputs or none).
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from pathlib import Path


def write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically: a temporary file beside it (``.NAME.PID.part``),
    fsync, then a rename over the name; a symbolic link is written through (its target is
    replaced), and a device or pipe (``/dev/stdout``) is written to as it is.

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
            view = memoryview(data)
            while view:
                n = os.write(fd, view)
                if n <= 0:  # no progress: a full disk
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
                view = view[n:]
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


__all__ = ["write_bytes", "write_text"]

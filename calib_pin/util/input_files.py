"""An input file must be a regular file.

A device (``/dev/zero``), a pipe or a socket would be read for ever or block, and is no
measurement set, profile or calibration.
"""

from __future__ import annotations

import os
import stat

from ..exceptions import DataError


def check_regular(path: str | os.PathLike[str]) -> None:
    """Refuse ``path`` when it exists but is neither a regular file nor a folder.

    A missing file or a folder is left to the caller (its own message names what it
    expected there).

    Args:
        path: The input file.

    Raises:
        DataError: ``path`` is a device, a pipe or a socket.
    """
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        kind = "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a pipe or socket"
        raise DataError(str(path), f"is not a regular file ({kind}): give a file")


__all__ = ["check_regular"]

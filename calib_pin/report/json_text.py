"""JSON text a person can read, written fast at any size (report.json).

``json.dumps(obj, indent=2)`` puts every number of a list on a line of its own and runs
json's pure-Python encoder (the C one serves only unindented output), so a large
report.json runs to a line per number and is slow to write. :func:`dumps_readable` indents
the structure (objects, lists of objects or lists) and writes each list of plain values
(numbers, strings, booleans, null) on one line with the C encoder: the same JSON value,
parsed back equal, in far fewer lines.
"""

from __future__ import annotations

import json
import re
import secrets
from typing import Any

#: Separators of the one-line lists: a space after each comma, as the indented text has.
_INLINE_SEPARATORS = (", ", ": ")


def dumps_readable(obj: Any, indent: int = 2, allow_nan: bool = False) -> str:
    """``obj`` as JSON text: containers indented, each list (or tuple) of plain values on one line.

    Args:
        obj: A JSON-able value.
        indent: Spaces per level of objects and lists of containers.
        allow_nan: Write NaN and infinities (as :func:`json.dumps`).

    Raises:
        ValueError: a NaN or infinity with ``allow_nan`` False (as :func:`json.dumps`).
        TypeError: a value JSON cannot hold (as :func:`json.dumps`).
    """
    token = secrets.token_hex(8)  # placeholders no string of obj can equal
    inline: list[str] = []

    def skeleton(value: Any) -> Any:
        if isinstance(value, dict):
            return {k: skeleton(v) for k, v in value.items()}
        if isinstance(value, list | tuple):
            if value and not any(issubclass(t, dict | list | tuple) for t in set(map(type, value))):
                inline.append(json.dumps(value, separators=_INLINE_SEPARATORS, allow_nan=allow_nan))
                return f"@{token}:{len(inline) - 1}@"
            return [skeleton(v) for v in value]
        return value

    text = json.dumps(skeleton(obj), indent=indent, allow_nan=allow_nan)
    return re.sub(f'"@{token}:(\\d+)@"', lambda m: inline[int(m.group(1))], text)

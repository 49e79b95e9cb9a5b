"""A sensor's true set-up from a small JSON file (``simulate --geometry``, ``plan-poses --geometry``).

The file holds one sensor's set-up in the form its truth file writes it (its
``geometry_type.to_dict()``; a ``FILE.truth.json`` of one session is itself one), and the
sensor it is for as ``"data_kind"``. A contact fixture layout, for example::

    {"data_kind": "contact",
     "points_mm": {"A": [380, 120, 250], "B": [300, -250, 150], "C": [420, -40, 480]},
     "planes": {"F": {"normal": [1, 0.2, 1], "offset_mm": 500}},
     "distances_mm": [["A", "B"]],
     "tool_mm": [10, -5, 60]}

(points in the base frame; a plane n . p = offset, n normalised; a distance ``[A, B]`` is
the points' own, ``[A, B, L]`` states L; the tool point in the end frame, estimated unless
``"tool": "given"``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..exceptions import DataError


def read_geometry(path: str | Path, kinds: Sequence[str]) -> tuple[str, Any]:
    """The sensor kind and true set-up of ``path``, for one of ``kinds``.

    The kind is its file's ``data_kind``, or the one kind given.

    Args:
        path: A JSON geometry file.
        kinds: The sensors of the command.

    Raises:
        DataError: an unreadable file, no JSON object, a kind that is none of ``kinds``
            (or missing where there are several), or a set-up its sensor cannot read.
    """
    from .registry import sensor_for

    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as e:
        raise DataError(str(path), f"cannot read: {e.strerror or e}") from None
    except (ValueError, UnicodeDecodeError) as e:
        raise DataError(str(path), f"not JSON ({e})") from None
    if not isinstance(doc, dict):
        raise DataError(str(path), "expected a JSON object (a sensor's set-up)")
    kinds = tuple(dict.fromkeys(kinds))
    kind = doc.get("data_kind", kinds[0] if len(kinds) == 1 else None)
    if kind not in kinds:
        raise DataError(str(path), f"a set-up for {kind or 'no sensor named'}: give \"data_kind\" one of "
                        f"{', '.join(kinds)}", None, "data_kind")
    sensor = sensor_for(str(kind))
    try:
        return str(kind), sensor.geometry_type.from_dict(doc)
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as e:
        what = f"'{e.args[0]}' missing or unknown" if isinstance(e, KeyError) else str(e)
        raise DataError(str(path), f"not a set-up of {sensor.data_name}: {what}") from None

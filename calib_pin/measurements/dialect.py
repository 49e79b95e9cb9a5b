"""The CSV dialect of a measurement file: its separator and its decimal mark.

- The separator is the header line's: ``,`` (the standard, and what calib-pin writes),
  ``;``, or a tab when the header holds neither. A header holding both ``,`` and ``;`` is
  refused.
- With ``,`` the decimal mark is ``.``. With ``;`` or a tab it is the one the numeric
  fields use (joint angles, lengths, coordinates, and the scalar metadata
  ``length_offset_*`` and ``noise_*``): ``,`` or ``.``. A file using both is refused
  (``1.234`` beside ``5,6`` could be a thousands separator); a file using neither is read
  with ``,``.
- A ``# csv: sep=; decimal=,`` line before the header states either instead (``sep`` one
  of ``,`` ``;`` ``tab``, ``decimal`` one of ``.`` ``,``). It describes this file's text
  only, so it is not kept as a note (what calib-pin writes is always the standard dialect).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from ..exceptions import DataError

#: ``sep=`` names of the separators read.
SEPARATORS = {",": ",", ";": ";", "tab": "\t"}
#: Metadata key of the dialect line.
KEY = "csv"
_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")
#: Longest text quoted back in a message.
_QUOTE = 40


def quote(text: str) -> str:
    """Text for a message: control characters shown escaped, long text cut."""
    shown = repr(text.strip())[1:-1]
    return shown if len(shown) <= _QUOTE else shown[:_QUOTE] + "..."


def shown_separator(sep: str) -> str:
    """``','``, ``';'`` or ``tab`` for a message."""
    return "tab" if sep == "\t" else f"'{sep}'"


@dataclass(frozen=True)
class Dialect:
    """How a file's fields are separated (``sep``) and its decimals written (``decimal``)."""

    sep: str = ","
    decimal: str = "."


@dataclass(frozen=True)
class Override:
    """What a ``# csv:`` line states (None: detect), and its file line."""

    sep: str | None = None
    decimal: str | None = None
    line: int | None = None


def parse_override(text: str, path: Path, line: int) -> Override:
    """The settings of a ``# csv:`` line's value (``sep=; decimal=,``).

    Args:
        text: The line's value.
        path: The file, for messages.
        line: The line in the file (1-based).

    Raises:
        DataError: a setting that is not one of ``sep=,`` ``sep=;`` ``sep=tab`` ``decimal=.`` ``decimal=,``.
    """
    sep = decimal = None
    for item in text.split():
        key, _, value = item.partition("=")
        if key == "sep" and value in SEPARATORS:
            sep = SEPARATORS[value]
        elif key == "decimal" and value in (".", ","):
            decimal = value
        else:
            raise DataError(str(path), f"'{quote(item)}' is not a csv setting (sep=, sep=; sep=tab decimal=. decimal=,)",
                            line, KEY)
    if sep is None and decimal is None:
        raise DataError(str(path), "states nothing (sep=, sep=; sep=tab decimal=. decimal=,)", line, KEY)
    return Override(sep, decimal, line)


def separator(header: str, override: Override, path: Path, line: int) -> str:
    """The file's separator: the ``# csv:`` line's, else the one the header line uses.

    Args:
        header: The header line.
        override: The ``# csv:`` line's settings.
        path: The file, for messages.
        line: The header's line in the file (1-based).

    Raises:
        DataError: the header holds both ``,`` and ``;`` and no ``# csv: sep=`` says which.
    """
    if override.sep is not None:
        sep = override.sep
    elif "," in header and ";" in header:
        raise DataError(str(path), "the header mixes ',' and ';' as separators: use one (or state it with "
                        "'# csv: sep=;' above the header)", line)
    elif ";" in header:
        sep = ";"
    elif "," not in header and "\t" in header:
        sep = "\t"
    else:
        sep = ","
    if override.decimal == "," and sep == ",":
        raise DataError(str(path), "a decimal comma needs ';' or tab as the separator", override.line, KEY)
    return sep


def decimal_mark(sep: str, override: Override, samples: Iterable[tuple[str, int, str]], path: Path) -> str:
    """The file's decimal mark, from the numeric fields ``samples``.

    Args:
        sep: The file's separator.
        override: The ``# csv:`` line's settings.
        samples: The numeric fields as (text, file line, column).
        path: The file, for messages.

    Raises:
        DataError: a file with ``;`` or tab separators that uses both ``,`` and ``.``.
    """
    if sep == ",":
        return "."
    if override.decimal is not None:
        return override.decimal
    first: dict[str, tuple[str, int]] = {}
    for text, line, name in samples:
        for mark in (",", "."):
            if mark in text and mark not in first:
                first[mark] = (text, line)
                other = "," if mark == "." else "."
                if other in first:
                    kind = {".": "point", ",": "comma"}
                    seen, seen_line = first[other]
                    raise DataError(str(path), f"decimal {kind[mark]} in '{quote(text)}', but line {seen_line} has a "
                                    f"decimal {kind[other]} ({quote(seen)}): use one decimal mark", line, name)
    return "." if "." in first else ","


def number(text: str, path: Path | str, line: int | None, name: str, decimal: str = ".") -> float:
    """A finite decimal number written with decimal mark ``decimal``, or a DataError naming the place."""
    t = text.strip()
    readable = decimal == "." or "." not in t
    plain = t.replace(",", ".") if decimal == "," else t
    if readable and _NUMBER.match(plain):
        value = float(plain)
        if abs(value) <= 1e12:  # also False for an exponent beyond float's range (inf)
            return value
        raise DataError(str(path), f"'{quote(text)}' is out of range", line, name)
    if t.lower().lstrip("+-") in ("nan", "inf", "infinity"):
        raise DataError(str(path), f"'{quote(text)}' is not a finite number", line, name)
    mark = " (this file's decimal mark is ',')" if decimal == "," and "." in t else ""
    raise DataError(str(path), f"'{quote(text)}' is not a number{mark}", line, name)


def as_number(text: str, decimal: str = ".") -> float | None:
    """The number ``text`` writes with decimal mark ``decimal``, or None.

    ``1e-3`` is allowed; ``1_0``, a thousands separator, ``inf`` and ``nan`` are not.
    """
    t = text.strip()
    if decimal == ",":
        if "." in t:
            return None
        t = t.replace(",", ".")
    return float(t) if _NUMBER.match(t) else None


def vector_parts(text: str, decimal: str) -> list[tuple[str, str]]:
    """The numbers of a metadata vector (``anchor_mm``) with the decimal mark of each.

    With ``.``: separated by ``,``, ``;`` or spaces. With ``,``: by ``;``, spaces or a ``,``
    followed by a space (``600,5; 200; 0``, ``600,5 200 0``, ``600,5, 200, 0``), or by
    bare commas when there is nothing else (``600,200,0``, read with ``.``).
    """
    text = text.strip()
    if decimal == ".":
        return [(p, ".") for p in re.split(r"[,;\s]+", text) if p]
    parts = [p for p in re.split(r"\s*;\s*|,\s+|\s+", text) if p]
    if len(parts) == 1 and "," in parts[0]:
        return [(p, ".") for p in parts[0].split(",")]
    return [(p, ",") for p in parts]

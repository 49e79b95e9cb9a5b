"""The paths the documentation and the docstrings name exist: each file (``calib_pin/x/y.py``,
``estimators/subspace.py``) is there, each dotted module (``calib_pin.studies.comparison_figures``)
is a module of today's layout, not a deprecated path, with the name it is followed by."""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

import calib_pin

ROOT = Path(calib_pin.__file__).resolve().parent.parent
#: What is read: the site, the README, and the package's own text (the alias table excepted).
TEXTS = sorted([*ROOT.joinpath("docs").rglob("*.md"), ROOT / "README.md",
                *(p for p in ROOT.joinpath("calib_pin").rglob("*.py") if p != ROOT / "calib_pin" / "__init__.py")])
FOLDERS = (ROOT, ROOT / "calib_pin", ROOT / "tests", ROOT / "scripts")


def _where(path: Path, text: str, at: int) -> str:
    return f"{path.relative_to(ROOT)}:{text.count(chr(10), 0, at) + 1}"


def named_files() -> list[str]:
    """``where: path`` of each named .py file (lower-case: ``COMMAND.py`` is a placeholder)
    found under none of :data:`FOLDERS` (a bare name: anywhere in them)."""
    bad = []
    for path in TEXTS:
        text = path.read_text(encoding="utf-8")
        for m in re.finditer(r"(?<![\w./<-])((?:[a-z_][a-z0-9_]*/)*[a-z_][a-z0-9_]*\.py)(?![\w/])", text):
            name = m.group(1)
            if "/" in name:
                found = any((folder / name).is_file() for folder in FOLDERS)
            else:
                found = any(next(folder.rglob(name), None) is not None for folder in FOLDERS[1:]) or (ROOT / name).is_file()
            if not found:
                bad.append(f"{_where(path, text, m.start())}: {name}")
    return bad


def named_modules() -> list[str]:
    """``where: dotted.path`` of each ``calib_pin.x.y`` that is no module of the package (or
    a deprecated one), or whose module has no such name."""
    bad = []
    for path in TEXTS:
        text = path.read_text(encoding="utf-8")
        for m in re.finditer(r"\bcalib_pin(?:\.[A-Za-z_]\w*)+", text):
            parts = m.group(0).split(".")
            cut = max(k for k in range(1, len(parts) + 1)
                      if ROOT.joinpath(*parts[:k]).with_suffix(".py").is_file()
                      or ROOT.joinpath(*parts[:k], "__init__.py").is_file())
            module = ".".join(parts[:cut])
            if cut < len(parts) and not hasattr(importlib.import_module(module), parts[cut]):
                bad.append(f"{_where(path, text, m.start())}: {m.group(0)}")
    return bad


def test_every_named_file_exists():
    assert named_files() == []


def test_every_named_module_is_one_of_the_layout():
    assert named_modules() == []


def test_the_library_page_gives_predicts_arguments():
    """docs/library.md's result table spells ``predict`` with every argument it takes."""
    row = re.search(r"\| `predict\(([^)]*)\)`", (ROOT / "docs" / "library.md").read_text(encoding="utf-8"))
    assert row is not None
    documented = [part.split("=")[0].strip() for part in row.group(1).split(",")]
    assert documented == list(inspect.signature(calib_pin.CalibrationResult.predict).parameters)[1:]

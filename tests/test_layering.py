"""The library's layers: no module outside calib_pin/cli/ imports calib_pin.cli, and the
measurement sets sit below the sensors (imports parsed with ast, relative ones resolved)."""

from __future__ import annotations

import ast
from pathlib import Path

import calib_pin

PACKAGE = Path(calib_pin.__file__).parent


def _module(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(source: str, module: str, is_package: bool = False) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in ``source`` (the text of ``module``),
    ``from X import Y`` giving X and X.Y."""
    package = module.split(".") if is_package else module.split(".")[:-1]
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            name = ".".join([*base, *([node.module] if node.module else [])])
            found.append((node.lineno, name))
            found += [(node.lineno, f"{name}.{alias.name}") for alias in node.names]
    return found


def cli_imports_outside_cli() -> list[str]:
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.relative_to(PACKAGE).parts[0] == "cli":
            continue
        for line, module in _imports(path.read_text(encoding="utf-8"), _module(path), path.name == "__init__.py"):
            if module == "calib_pin.cli" or module.startswith("calib_pin.cli."):
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {module}")
    return bad


def test_no_module_outside_cli_imports_the_cli():
    assert cli_imports_outside_cli() == []


#: The packages above the measurement sets: they read, write or fit measurement sets.
ABOVE_MEASUREMENTS = ("sensors", "simulation", "calibration", "analysis", "estimators", "report", "studies", "cli",
                      "export", "hardware")


def measurement_imports_above() -> list[str]:
    bad = []
    for path in sorted((PACKAGE / "measurements").rglob("*.py")):
        for line, module in _imports(path.read_text(encoding="utf-8"), _module(path), path.name == "__init__.py"):
            parts = module.split(".")
            if parts[0] == "calib_pin" and len(parts) > 1 and parts[1] in ABOVE_MEASUREMENTS:
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {module}")
    return bad


def test_the_measurement_sets_import_nothing_above_them():
    """calib_pin/measurements/ learns a kind's file from its schema (measurements/schema.py),
    never from the sensors: no import of the sensors or anything above, not even inside a
    function or under TYPE_CHECKING."""
    assert measurement_imports_above() == []


def test_the_check_resolves_relative_and_absolute_imports():
    """What batch.py once had (``from .cli.outputs import Outputs``, inside a function) is
    found, as are ``from ..cli import main`` and ``import calib_pin.cli.common``; a module
    whose name merely starts with 'cli' is not the CLI."""
    source = ("def f():\n    from .cli.outputs import Outputs\n"
              "from ..cli import main\nimport calib_pin.cli.common\nfrom .client import x\n")
    top = [m for _, m in _imports(source, "calib_pin.batch")]
    assert "calib_pin.cli.outputs" in top and "calib_pin.cli.outputs.Outputs" in top
    nested = [m for _, m in _imports(source, "calib_pin.export.bundle")]
    assert "calib_pin.cli" in nested and "calib_pin.cli.main" in nested and "calib_pin.cli.common" in nested
    assert "calib_pin.export.cli.outputs" in nested  # level 1 inside export/ is export's, not the CLI
    assert "calib_pin.client" in top and not any(m.startswith("calib_pin.cli.") for m in top if "client" in m)

"""The library's layers: no module outside calib_pin/cli/ imports calib_pin.cli, and the
measurement sets sit below the sensors (imports parsed with ast, relative ones resolved)."""

from __future__ import annotations

import ast
from pathlib import Path

import calib_pin

PACKAGE = Path(calib_pin.__file__).parent

#: The package's folders from the ground up: a module imports only from its own folder and
#: the folders below it (the public ``__init__`` names everything, lazily, from the top).
LAYERS = ("exceptions", "util", "robot", "parameters", "export", "measurements", "estimators", "sensors",
          "simulation", "analysis", "calibration", "report", "hardware", "studies", "cli")
#: The command line: the top layer, which no other module imports.
CLI = LAYERS[-1]
#: The packages above the measurement sets: they read, write or fit measurement sets.
ABOVE_MEASUREMENTS = LAYERS[LAYERS.index("measurements") + 1:]


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
        if path.relative_to(PACKAGE).parts[0] == CLI:
            continue
        for line, module in _imports(path.read_text(encoding="utf-8"), _module(path), path.name == "__init__.py"):
            if module == f"calib_pin.{CLI}" or module.startswith(f"calib_pin.{CLI}."):
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {module}")
    return bad


def test_no_module_outside_cli_imports_the_cli():
    assert cli_imports_outside_cli() == []


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



def _resolved(name: str) -> str | None:
    """The module ``name`` is or is in (``calib_pin.a.b.c`` -> ``calib_pin.a.b`` when ``c``
    is a name inside it), or None outside the package."""
    if not name.startswith("calib_pin"):
        return None
    parts = name.split(".")
    while len(parts) > 1:
        path = PACKAGE.parent.joinpath(*parts)
        if path.with_suffix(".py").is_file() or (path / "__init__.py").is_file():
            return ".".join(parts)
        parts = parts[:-1]
    return "calib_pin"


def _graph() -> dict[str, set[tuple[str, int]]]:
    """Module -> the package's modules it imports (with the line), every import counted:
    inside functions and under ``TYPE_CHECKING`` too."""
    graph: dict[str, set[tuple[str, int]]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        module = _module(path)
        found = set()
        for line, name in _imports(path.read_text(encoding="utf-8"), module, path.name == "__init__.py"):
            target = _resolved(name)
            if target is not None and target != module:
                found.add((target, line))
        graph[module] = found
    return graph


def _layer(module: str) -> str:
    parts = module.split(".")
    return "__init__" if len(parts) == 1 else parts[1]


def test_no_top_level_module_but_the_public_init_and_the_errors():
    """The top level holds the public ``__init__``, the errors and the folders; every other
    module lives in the folder named for what it holds."""
    loose = sorted(p.name for p in PACKAGE.glob("*.py") if p.name not in ("__init__.py", "exceptions.py"))
    assert loose == []
    folders = sorted(p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file())
    assert set(folders) <= set(LAYERS), set(folders) - set(LAYERS)


def imports_up(graph: dict[str, set[tuple[str, int]]]) -> list[str]:
    """``module:line -> target`` of each import in ``graph`` that runs back up :data:`LAYERS`."""
    rank = {name: k for k, name in enumerate(LAYERS)}
    bad = []
    for module, targets in graph.items():
        mine = _layer(module)
        if mine == "__init__":
            continue
        for target, line in sorted(targets):
            theirs = _layer(target)
            if theirs == "__init__" or rank[theirs] > rank[mine]:
                bad.append(f"{module}:{line} -> {target}")
    return bad


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The modules of ``graph`` that import each other through any chain, each group sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []

    def visit(node: str) -> None:  # Tarjan's strongly connected components
        index[node] = low[node] = len(index)
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_every_import_runs_down_the_layers():
    """No import runs back up: each module imports its own folder's and the folders below."""
    assert imports_up(_graph()) == []


def test_no_import_cycle():
    """No module imports one that imports it back, through any chain of imports."""
    assert cycles({m: {t for t, _ in targets} for m, targets in _graph().items()}) == []


def test_the_rank_and_cycle_checks_fail_on_a_bad_graph():
    """A small graph with an import back up (robot -> sensors), one into the public
    ``__init__`` and a cycle of three (a -> b -> c -> a) beside a chain that is none."""
    graph = {"calib_pin.robot.chain": {("calib_pin.sensors.base", 3), ("calib_pin.util.arguments", 4)},
             "calib_pin.sensors.base": {("calib_pin", 7)},
             "calib_pin.util.arguments": set()}
    assert imports_up(graph) == ["calib_pin.robot.chain:3 -> calib_pin.sensors.base",
                                 "calib_pin.sensors.base:7 -> calib_pin"]
    ring = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": {"e"}, "e": set()}
    assert cycles(ring) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_the_layer_lists_agree():
    """What sits above the measurement sets, and the command line, are read from LAYERS."""
    assert "export" not in ABOVE_MEASUREMENTS and "sensors" in ABOVE_MEASUREMENTS and CLI == "cli"


def test_the_layer_check_sees_a_cycle_and_an_import_back_up():
    """What the checks would catch: an import inside a function counts, and so does one under
    TYPE_CHECKING."""
    source = ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..cli import main\n"
              "def f():\n    from ..sensors import x\n")
    found = [m for _, m in _imports(source, "calib_pin.robot.chain")]
    assert "calib_pin.cli" in found and "calib_pin.sensors" in found

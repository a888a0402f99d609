"""The import order the package obeys: every import points down, and no two files import each other.

Each module of ``azgym/`` belongs to one layer (``LAYERS``, lowest first); a module may import
modules of its own unit and of lower layers only. Units sharing a layer (``logs`` and
``localize`` do not, ``learn``, ``placement`` and ``experiments`` do) may not import each other.
Every import counts: at the top of a file, inside a function (a lazy import is still a
dependency) or under ``TYPE_CHECKING``. The package's own ``__init__`` is the public façade on
top, which nothing inside imports. docs/architecture.md draws the same order.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "azgym"

LAYERS: tuple[tuple[str, ...], ...] = (
    ("_version", "build_hook"), ("errors",), ("registry",), ("core",),
    ("fields",), ("arguments", "hyperparameters", "files", "untrusted", "profile", "progress"),
    ("jit", "torch_kernels"),
    ("metrics",),
    ("site",), ("sensing",), ("world",), ("localize",), ("track",), ("logs",), ("mapping",),
    ("nav",),
    ("envs",), ("bench",), ("learn", "placement", "experiments"), ("cli",), ("precompile",),
    ("__init__",), ("__main__",),
)
"""The units, lowest first; a unit is a top-level module or subpackage of ``azgym``."""

ALLOWED: frozenset[tuple[str, str]] = frozenset()
"""(importing module, imported module) pairs that break the order today: none."""


def module_name(path: Path) -> str:
    """The dotted name of a file of the package."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def unit(module: str) -> str:
    """The unit of a module: ``azgym.bench.run.runner`` -> ``bench``; the package: __init__."""
    parts = module.split(".")
    if len(parts) == 1:
        return "__init__"
    return "cli" if parts[1].startswith("cli") else parts[1]


def layer(module: str) -> int:
    """The layer of a module's unit (its place in LAYERS)."""
    name = unit(module)
    for rank, units in enumerate(LAYERS):
        if name in units:
            return rank
    raise AssertionError(f"{module}: unit {name!r} is in no layer of tests/test_layers.py")


def imported(text: str, name: str, is_package: bool, modules: set[str]) -> set[str]:
    """The package's modules a module (its source, name, whether a package's __init__) imports,
    anywhere in it; ``from X import Y`` counts as X.Y when that is a module, else as X."""
    package = name if is_package else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(text, name)):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([node.module] if node.module else []))
            for alias in node.names:
                full = f"{base}.{alias.name}"
                found.add(full if full in modules else base)
    return {m for m in found if m == "azgym" or m.startswith("azgym.")}


def graph() -> dict[str, set[str]]:
    """Every module of the package and the package's modules it imports."""
    files = {module_name(path): path for path in PACKAGE.rglob("*.py")}
    modules = set(files)
    return {name: {m for m in imported(path.read_text(), name, path.name == "__init__.py",
                                       modules) if m != name}
            for name, path in files.items()}


def test_every_import_points_down_the_layers():
    wrong = set()
    for source, targets in graph().items():
        for target in targets:
            if unit(target) == unit(source):
                continue
            if layer(target) >= layer(source):
                wrong.add((source, target))
    assert wrong - ALLOWED == set(), "imports against the order:\n" + "\n".join(
        f"  {a} -> {b}" for a, b in sorted(wrong - ALLOWED))
    assert ALLOWED - wrong == set(), f"allowed but no longer there: {sorted(ALLOWED - wrong)}"


def test_no_two_files_import_each_other():
    edges = graph()
    # Tarjan's strongly connected components over the file graph (the package's own __init__
    # files excepted as the targets of `from pkg import x`, which resolve to the submodule).
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in edges.get(node, ()):
            if other not in edges:
                continue
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for node in sorted(edges):
        if node not in index:
            visit(node)
    assert cycles == [], "files that import each other:\n" + "\n".join(
        "  " + " <-> ".join(cycle) for cycle in cycles)


def test_the_checker_sees_every_kind_of_import():
    # A lazy import inside a function, one under TYPE_CHECKING and a relative one all count.
    text = ("from typing import TYPE_CHECKING\n"
            "if TYPE_CHECKING:\n    from azgym.track import base\n"
            "def f():\n    from azgym.bench.run import runner\n    return runner\n"
            "from . import sibling\n")
    modules = {"azgym.bench.run.runner", "azgym.track.base", "azgym.localize.sibling"}
    assert imported(text, "azgym.localize.probe", False, modules) == modules


def test_every_public_module_says_what_it_exports():
    # A module's public surface is its __all__; a private module (a leading underscore) has none.
    silent = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name.startswith("_") and path.name != "__init__.py":
            continue
        tree = ast.parse(path.read_text(), str(path))
        named = any(isinstance(target, ast.Name) and target.id == "__all__"
                    for node in tree.body if isinstance(node, (ast.Assign, ast.AnnAssign))
                    for target in (node.targets if isinstance(node, ast.Assign)
                                   else [node.target]))
        if not named and path.name != "__init__.py":
            silent.append(module_name(path))
    assert silent == [], f"modules without __all__: {silent}"

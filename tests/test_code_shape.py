"""The shape the code keeps: small modules and functions that say what they hold.

A newcomer reads a module of at most 400 lines and a function of at most 60; every module opens
with a docstring; and the cache guard of the compiled kernels watches every module that has
kernels (one left out would let its callers keep running its old code from numba's cache).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from azgym.jit import KERNEL_MODULES, PACKAGE_DIR

MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 60
MODULES = sorted(PACKAGE_DIR.rglob("*.py"))


def relative(path: Path) -> str:
    return path.relative_to(PACKAGE_DIR).as_posix()


def compiles_kernels(tree: ast.Module) -> bool:
    """Whether a module defines a function decorated with ``@jit`` or ``@jit(...)``."""
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            for decorator in node.decorator_list:
                target = decorator.func if isinstance(decorator, ast.Call) else decorator
                if isinstance(target, ast.Name) and target.id == "jit":
                    return True
    return False


@pytest.mark.parametrize("path", MODULES, ids=relative)
def test_every_module_is_short_documented_and_made_of_short_functions(path):
    text = path.read_text(encoding="utf-8")
    tree = ast.parse(text)
    assert len(text.splitlines()) <= MAX_MODULE_LINES
    assert ast.get_docstring(tree), "a module says what it holds"
    long = [f"{node.name} ({node.end_lineno - node.lineno + 1} lines)" for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]
    assert long == []


def imported_modules(tree: ast.Module) -> set[str]:
    """The azgym modules a module imports names from, as paths relative to the package."""
    found = set()
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("azgym."):
            base = PACKAGE_DIR.joinpath(*node.module.split(".")[1:])
            for alias in node.names:  # a submodule (`from azgym.localize import _kernels`)?
                if base.joinpath(f"{alias.name}.py").is_file():
                    found.add(relative(base / f"{alias.name}.py"))
            if base.with_suffix(".py").is_file():
                found.add(relative(base.with_suffix(".py")))
    return found


def test_the_cache_guard_watches_every_module_with_kernels_and_what_they_import():
    watched = set(KERNEL_MODULES)
    for path in MODULES:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        if compiles_kernels(tree):
            missing = ({relative(path)} | imported_modules(tree)) - watched
            assert not missing, f"{relative(path)}: not watched: {missing}"
    assert all((PACKAGE_DIR / module).is_file() for module in KERNEL_MODULES)

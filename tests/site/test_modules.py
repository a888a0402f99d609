"""The site package's modules stay small: none over 400 lines, each says what it holds."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import azgym.site

MAX_LINES = 400
MODULES = sorted(Path(azgym.site.__file__).parent.rglob("*.py"))


def test_the_site_package_has_modules():
    assert {path.name for path in MODULES} >= {"parse.py", "reader.py", "parse_layout.py",
                                                "parse_sensor.py"}


@pytest.mark.parametrize("path", MODULES, ids=lambda path: path.name)
def test_no_site_module_exceeds_the_line_limit(path):
    lines = len(path.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_LINES, f"{path.name} has {lines} lines (limit {MAX_LINES})"


@pytest.mark.parametrize("path", MODULES, ids=lambda path: path.name)
def test_every_site_module_has_a_docstring(path):
    assert ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))

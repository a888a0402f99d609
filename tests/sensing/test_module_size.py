"""The sensing package keeps its modules small enough to read: none over 400 lines."""

from __future__ import annotations

from pathlib import Path

import azgym.sensing

MAX_LINES = 400
SENSING_DIR = Path(azgym.sensing.__file__).parent


def test_no_sensing_module_is_over_400_lines():
    modules = sorted(SENSING_DIR.rglob("*.py"))
    assert modules, f"no modules found under {SENSING_DIR}"
    long = {str(path.relative_to(SENSING_DIR)): count for path in modules
            if (count := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"

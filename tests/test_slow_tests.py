"""The suite's selection: a plain ``python -m pytest`` leaves out the tests marked slow, and
``--slow``, ``-m`` or a test's name brings them back (tests/conftest.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]

FILE = "tests/bench/test_fork_server.py"
SLOW = f"{FILE}::test_the_fork_server_compiles_the_named_built_in_only_and_never_imports_a_plug_in"


def collected(*arguments: str) -> list[str]:
    """The test ids ``python -m pytest --collect-only`` lists, given these arguments."""
    done = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-n0",
                           "-p", "no:cacheprovider", *arguments],
                          capture_output=True, text=True, timeout=120, check=True, cwd=ROOT)
    return [line for line in done.stdout.splitlines() if "::" in line]


@pytest.mark.slow  # four collections in fresh processes
def test_the_slow_tests_run_only_when_asked_for() -> None:
    plain, everything = collected(FILE), collected(FILE, "--slow")
    assert SLOW not in plain and sorted([*plain, SLOW]) == sorted(everything)
    assert collected(FILE, "-m", "slow") == [SLOW] and collected(SLOW) == [SLOW]

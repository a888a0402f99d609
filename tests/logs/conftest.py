"""The mini log as a fixture."""

from __future__ import annotations

from pathlib import Path

import pytest
from logs.mini_log import mini_files, write_log


@pytest.fixture
def mini_log(tmp_path) -> Path:
    return write_log(tmp_path / "mini", mini_files())

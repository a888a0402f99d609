"""The suite's own rule for Ray: every test that starts it is in a file conftest.py names."""

from __future__ import annotations

import pytest
from conftest import ray_file


def test_every_test_that_starts_ray_is_in_a_file_run_one_after_another(
        request: pytest.FixtureRequest) -> None:
    # a Ray test elsewhere could run beside another and join or wait on its instance
    root = request.config.rootpath
    assert [item.nodeid for item in request.session.items
            if item.get_closest_marker("ray") and not ray_file(item.path, root)] == []

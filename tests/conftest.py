"""Shared fixtures: the paper room and noise-free frames seen from a known pose; the Ray tests
run one at a time."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from helpers import ideal_frame
from hypothesis import settings

import azgym
from azgym.core import BeaconMap, Measurements

FrameMaker = Callable[..., Measurements]

# The same examples on every run: a red CI must mean a regression, not an unlucky draw. To draw
# fresh examples locally: HYPOTHESIS_PROFILE=explore python -m pytest
settings.register_profile("repeatable", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))


@pytest.fixture(scope="session")
def ray_modules(request: pytest.FixtureRequest) -> set[Path]:
    """The test files with a test that starts Ray."""
    return {item.path for item in request.session.items if item.get_closest_marker("ray")}


@pytest.fixture(scope="module", autouse=True)
def one_ray_module_at_a_time(request: pytest.FixtureRequest, ray_modules: set[Path],
                             tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Run the test files that start Ray one after another, whichever test process runs them.

    Ray's ``address="auto"`` joins any instance it finds among the machine's processes, and an
    instance takes seconds to end: a Ray test beside another would join or wait on the other's.
    A lock in the folder every test process of the run keeps its temporary files in, held for
    the whole file, as a file's Ray instance may serve all its tests.
    """
    if request.node.path not in ray_modules:
        yield
        return
    import fcntl  # POSIX: the Ray tests are skipped on Windows

    lock = tmp_path_factory.getbasetemp().parent / "ray-tests.lock"
    with lock.open("a") as held:
        fcntl.flock(held, fcntl.LOCK_EX)  # released as the file closes
        yield


@pytest.fixture(scope="session")
def paper_room() -> azgym.Scenario:
    """The reconstructed room of Rátosi & Simon (2021), Sec. 3.1."""
    return azgym.load_scenario("paper-room")


@pytest.fixture(scope="session")
def paper_beacons(paper_room: azgym.Scenario) -> BeaconMap:
    """The paper room's 12 beacons."""
    return paper_room.beacons


@pytest.fixture(scope="session")
def make_frame() -> FrameMaker:
    """``make_frame(x, y, heading, beacons)``: a noise-free frame from that pose."""
    return ideal_frame

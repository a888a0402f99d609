"""Shared fixtures: the paper room and noise-free frames seen from a known pose; the Ray tests
run one at a time, on one test process; the tests marked slow run when asked for."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from helpers import ideal_frame
from hypothesis import settings
from xdist.remote import Producer
from xdist.scheduler import LoadGroupScheduling

import azgym
from azgym.core import BeaconMap, Measurements

FrameMaker = Callable[..., Measurements]

# The same examples on every run: a red CI must mean a regression, not an unlucky draw. To draw
# fresh examples locally: HYPOTHESIS_PROFILE=explore python -m pytest
settings.register_profile("repeatable", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))


RAY_FILES = frozenset({"tests/bench/test_profiles.py", "tests/bench/test_ray_backend.py",
                       "tests/bench/test_sequences.py", "tests/hostile/test_hostile_ray.py",
                       "tests/hostile/test_hostile_runner.py"})
"""The test files with a test that starts Ray (marked ``ray``), relative to the root (such a
test elsewhere fails: :func:`pytest_runtest_setup`)."""


def ray_file(path: Path, root: Path) -> bool:
    """Whether the test file at ``path`` is one of :data:`RAY_FILES`."""
    return path.relative_to(root).as_posix() in RAY_FILES


def outside_the_ray_files(item: pytest.Item) -> bool:
    """Whether ``item`` starts Ray (marked ``ray``) outside :data:`RAY_FILES`: it could run beside
    another Ray test and join or wait on its instance."""
    return item.get_closest_marker("ray") is not None and not ray_file(item.path,
                                                                        item.config.rootpath)


def pytest_runtest_setup(item: pytest.Item) -> None:
    """A test that starts Ray outside :data:`RAY_FILES` fails before it starts it."""
    if outside_the_ray_files(item):
        pytest.fail("it starts Ray (marked ray) outside the files RAY_FILES names in "
                    "tests/conftest.py, where it could run beside another Ray test", pytrace=False)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--slow", action="store_true",
                     help="run the tests marked slow too: the whole suite (left out by default)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Leave out the tests marked ``slow`` unless the command line asks for them.

    It does with ``--slow`` (the whole suite), with a ``-m`` expression of its own (``-m slow``
    runs those alone) or by naming them (``FILE::NAME``). The slow tests are the end-to-end
    checks: the committed leaderboard recomputed, first runs that compile, Ray, training. A test
    outside the Ray files is kept, slow or not, to fail (:func:`pytest_runtest_setup`).
    """
    if (config.getoption("--slow") or config.option.markexpr
            or any("::" in arg for arg in config.args)):
        return
    slow = [item for item in items
            if item.get_closest_marker("slow") is not None and not outside_the_ray_files(item)]
    if slow:
        config.hook.pytest_deselected(items=slow)
        left_out = set(slow)
        items[:] = [item for item in items if item not in left_out]


class RayFilesTogether(LoadGroupScheduling):
    """pytest-xdist's ``loadgroup`` with every test of :data:`RAY_FILES` in one group: one test
    process runs them all, one after another, while the other runs the rest instead of waiting
    on the lock below. (xdist's own groups, from ``xdist_group`` marks, rename the tests in a
    way pytest 9.2 no longer sees.)"""

    def _split_scope(self, nodeid: str) -> str:
        return "ray" if nodeid.partition("::")[0] in RAY_FILES else nodeid


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Producer) -> RayFilesTogether | None:
    """``--dist loadgroup`` (addopts) schedules with :class:`RayFilesTogether`."""
    return RayFilesTogether(config, log) if config.getvalue("dist") == "loadgroup" else None


@pytest.fixture(scope="module", autouse=True)
def one_ray_module_at_a_time(request: pytest.FixtureRequest,
                             tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Run the test files that start Ray one after another, whichever test process runs them.

    Ray's ``address="auto"`` joins any instance it finds among the machine's processes, and an
    instance takes seconds to end: a Ray test beside another would join or wait on the other's.
    The scheduler above keeps them on one test process; this lock, in the folder every test
    process of the run keeps its temporary files in, keeps them apart under any other ``--dist``
    too. It is held for the whole file, as a file's Ray instance may serve all its tests.
    """
    if not ray_file(request.node.path, request.config.rootpath):
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

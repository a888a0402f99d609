"""Trackers in the runner: whole sequences in order, with their motion, whatever the workers."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import pytest

from azgym.bench.run.contenders import Contender
from azgym.bench.run.runner import batch_bounds, run_contenders
from azgym.bench.suites import get_suite
from azgym.bench.suites.base import Case

PLUGINS = Path(__file__).parents[1] / "hostile" / "plugins"


def plugin(stem: str) -> Contender:
    """The hostile plug-in in ``tests/hostile/plugins/STEM.py``."""
    path = PLUGINS / f"{stem}.py"
    name = re.search(r"^class (\w+)", path.read_text(), re.MULTILINE).group(1)
    return Contender(stem, f"{path}:{name}")


CHECKER = '''
    import azgym


    class Checker(azgym.Tracker):
        """Raises unless it is reset with a start pose once per route and then fed every
        odometry sample of the route in order, with no gap; answers the origin."""

        name = "checker"

        def __init__(self):
            self._validate_once()

        def _reset(self, rng, initial):
            if initial is None:
                raise AssertionError("reset without the route's start pose")
            self.last = None

        def _predict(self, motion):
            times = motion.odometry.time
            if times.size and self.last is not None and times[0] - self.last > 0.021:
                raise AssertionError(f"odometry gap from {self.last} to {times[0]}")
            if times.size:
                self.last = times[-1]

        def _update(self, measurements, beacons):
            return azgym.Estimate(0.0, 0.0, 0.0, inliers=measurements.ids >= 0)
'''


@pytest.fixture(scope="module")
def checker(tmp_path_factory):
    path = tmp_path_factory.mktemp("tracker") / "checker.py"
    path.write_text(textwrap.dedent(CHECKER))
    return Contender("checker", f"{path}:Checker")


def case(sequence):
    return Case("s", None, (0.0, 0.0, 0.0), "clean", "g", sequence=sequence)


@pytest.mark.parametrize(("sequences", "size", "expected"), [
    (["", "", "", ""], 2, [(0, 2), (2, 4)]),
    (["a", "a", "a", "b", "b"], 1, [(0, 3), (3, 5)]),
    (["", "a", "a", "", "", ""], 2, [(0, 1), (1, 3), (3, 5), (5, 6)]),
    (["a", "a", "a", "a"], 2, [(0, 4)]),
])
def test_batches_never_split_a_sequence(sequences, size, expected):
    assert batch_bounds([case(s) for s in sequences], size) == expected


def test_a_tracker_sees_each_route_whole_and_in_order_whatever_the_workers(checker):
    cases = get_suite("warehouse-routes").build(11, True)
    assert len({case.sequence for case in cases}) == 2  # quick: one route in each warehouse
    for workers in (1, 2):
        outcome = run_contenders(cases, [checker], workers=workers)["checker"]
        assert outcome.ok.all(), [e for e in outcome.errors if e][:3]


@pytest.fixture(scope="module")
def route():
    """The first route of warehouse-routes' quick version, its first 40 frames."""
    cases = get_suite("warehouse-routes").build(11, True)
    return [case for case in cases if case.sequence == cases[0].sequence][:40]


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["local", pytest.param("ray", marks=pytest.mark.ray)])
def test_a_tracker_cannot_find_its_route_s_next_frames_anywhere_in_its_process(route, backend):
    # It walks its call stack, every object gc knows and its shared memory for frames later
    # than the one it is asked about: a worker gets a route one frame at a time.
    if backend == "ray":
        pytest.importorskip("ray", reason="ray is not installed")
        # A walk of every object and shared mapping a Ray worker holds is slow: the route's
        # first 6 frames (each of the first 5 has frames ahead to find), under a wide limit, as
        # what is checked is what the walk finds.
        route = route[:6]
    outcome = run_contenders(route, [plugin("clairvoyant")], workers=1, backend=backend,
                             time_limit=60.0)["clairvoyant"]
    assert outcome.errors == [""] * len(route)  # it answered every frame: "no future here"

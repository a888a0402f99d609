"""The Monte Carlo check agrees with the prediction where the localizer is efficient."""

from __future__ import annotations

import re

import numpy as np
import pytest

from azgym.errors import InvalidInputError
from azgym.placement.analysis import agreement, predict
from azgym.placement.floor import floor_grid
from azgym.placement.monte_carlo import monte_carlo


def test_ransac_matches_the_predicted_sigma_on_the_paper_room(paper_room):
    floor = floor_grid(paper_room, 7.0)  # 4 x 4 cells, from a corner to the middle
    prediction = predict(paper_room, floor)
    checked = monte_carlo(paper_room, floor.points, prediction.seen, "ransac", 400, seed=5)
    ratio = checked.rms / prediction.sigma
    assert np.all(np.abs(ratio - 1) < 0.1), ratio  # 400 frames: ~3 % sampling error
    assert np.all(checked.bias < 0.3 * checked.rms)
    figures = agreement(prediction.sigma, checked)
    assert figures["cells_compared"] == 16 and figures["failed_share"] == 0.0


def test_cells_seeing_under_three_beacons_are_not_run(paper_room):
    floor = floor_grid(paper_room, 7.0)
    seen = np.zeros((len(floor.points), 12), dtype=bool)
    seen[:, :2] = True
    checked = monte_carlo(paper_room, floor.points, seen, "ransac", 3)
    assert np.isnan(checked.rms).all() and (checked.failed == 1.0).all()


def test_the_draws_are_the_seeds(paper_room):
    floor = floor_grid(paper_room, 10.0)
    seen = predict(paper_room, floor).seen
    first = monte_carlo(paper_room, floor.points, seen, "lsq", 5, seed=1)
    again = monte_carlo(paper_room, floor.points, seen, "lsq", 5, seed=1)
    other = monte_carlo(paper_room, floor.points, seen, "lsq", 5, seed=2)
    np.testing.assert_array_equal(first.rms, again.rms)
    assert not np.allclose(first.rms, other.rms)


PLUGINS = '''
import math
import time

import numpy as np

from azgym.core import Estimate


class Raises:
    def localize(self, measurements, beacons):
        raise RuntimeError("boom")


class Exits:
    def localize(self, measurements, beacons):
        raise SystemExit(3)


class Tuple:
    def localize(self, measurements, beacons):
        return (1.0, 2.0, 0.0)


class Sleeps:
    def localize(self, measurements, beacons):
        time.sleep(100)


class NanOk:
    def localize(self, measurements, beacons):
        return Estimate(math.nan, math.nan, 0.0, np.ones(len(measurements.ids), bool))


class InfOk:
    def localize(self, measurements, beacons):
        return Estimate(math.inf, 0.0, 0.0, np.ones(len(measurements.ids), bool))
'''


@pytest.mark.parametrize(("plugin", "reason"), [
    ("Raises", "RuntimeError: boom"), ("Exits", "SystemExit: 3"),
    ("Tuple", "AttributeError: 'tuple' object has no attribute 'ok'"),
    ("Sleeps", "timed out: took longer than the 0.5 s limit"), ("NanOk", None), ("InfOk", None)])
def test_a_failing_plugin_costs_its_frames_not_the_run(paper_room, tmp_path, plugin, reason):
    """Raising, exiting, hanging or answering garbage: each frame has no fix, with the reason."""
    path = tmp_path / "plugins.py"
    path.write_text(PLUGINS)
    floor = floor_grid(paper_room, 10.0)
    seen = predict(paper_room, floor).seen[:1]
    checked = monte_carlo(paper_room, floor.points[:1], seen, f"{path}:{plugin}", 3,
                          time_limit=0.5)
    assert np.isnan(checked.rms).all() and (checked.failed == 1.0).all()
    if reason is None:  # ok=True without a finite pose is no fix, and no exception
        assert checked.problems == {}
    else:
        assert sum(checked.problems.values()) >= 1
        assert any(reason in problem for problem in checked.problems), checked.problems


def test_a_seed_outside_0_to_2_31_is_refused(paper_room):
    floor = floor_grid(paper_room, 10.0)
    for seed in (-1, 2**31, 1e23, True):
        with pytest.raises(InvalidInputError, match=re.escape(
                f"seed must be an integer in [0, 2147483648), got {seed!r}")):
            monte_carlo(paper_room, floor.points, predict(paper_room, floor).seen, "lsq", 1,
                        seed=seed)

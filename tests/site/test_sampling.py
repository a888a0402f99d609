"""Random free poses: uniform over the free floor, clear of walls and racks, repeatable."""

from __future__ import annotations

import math

import numpy as np

import azgym
from azgym.site.sampling import RACK_CLEARANCE, WALL_CLEARANCE, random_free_pose


def test_poses_keep_clear_of_walls_and_racks_and_cover_every_heading():
    scenario = azgym.load_scenario("warehouse-small")
    rng = np.random.default_rng(0)
    poses = np.array([random_free_pose(scenario, rng) for _ in range(2000)])
    x_min, y_min, x_max, y_max = scenario.bounds
    low = np.array([x_min, y_min]) + WALL_CLEARANCE
    high = np.array([x_max, y_max]) - WALL_CLEARANCE
    assert (poses[:, :2] >= low).all() and (poses[:, :2] <= high).all()
    for x, y, _ in poses:
        assert not any(rack.contains(x, y, margin=-RACK_CLEARANCE) for rack in scenario.racks)
    headings = poses[:, 2]
    assert headings.min() >= -math.pi and headings.max() < math.pi
    # Uniform headings: each quarter of the circle holds a quarter of them (±4 sigma).
    counts = np.histogram(headings, bins=4, range=(-math.pi, math.pi))[0]
    assert np.abs(counts - 500).max() < 4 * math.sqrt(2000 * 0.25 * 0.75)


def test_the_same_generator_state_gives_the_same_poses():
    scenario = azgym.load_scenario("warehouse-paper")
    first = [random_free_pose(scenario, np.random.default_rng(5)) for _ in range(3)]
    again = [random_free_pose(scenario, np.random.default_rng(5)) for _ in range(3)]
    assert first == again


def test_a_site_without_free_floor_is_refused_instead_of_searched_forever():
    import dataclasses

    import pytest

    from azgym.site.elements import Rack

    room = azgym.load_scenario("paper-room")
    full = dataclasses.replace(room, racks=(Rack(center=(0.0, 0.0), size=(21.0, 21.0), angle=0.0,
                                                  height=3.0),))
    with pytest.raises(azgym.ScenarioError, match="paper-room: no free floor for a camera pose"):
        random_free_pose(full, np.random.default_rng(0))

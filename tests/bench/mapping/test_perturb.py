"""The perturbations of a site's world: seeded, within their ranges, where a beacon can be."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.bench.mapping.perturb import (
    BEACON_MOVE,
    RACK_MOVE,
    SITE_MARGIN,
    move_beacons,
    move_rack,
    true_map,
)
from azgym.errors import InvalidInputError
from azgym.site import load_scenario

SITES = ("warehouse-small", "warehouse-paper", "robot-arena")


def crosses(a, b, c, d) -> bool:
    def side(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    return side(a, b, c) * side(a, b, d) < 0 and side(c, d, a) * side(c, d, b) < 0


@pytest.mark.parametrize("name", SITES)
def test_moved_beacons_go_0_3_to_3_m_inside_the_site_outside_racks_not_through_walls(name):
    scenario = load_scenario(name)
    ids = scenario.beacons.ids.tolist()
    x0, y0, x1, y1 = scenario.bounds
    for seed in range(30):
        count = 1 + seed % 3
        changed = move_beacons(scenario, np.random.default_rng(seed), count, ids)
        assert len(changed.moved) == count == len(set(changed.moved))
        before, after = scenario.beacon_positions, changed.world.beacon_positions
        shifted = np.flatnonzero((before != after).any(axis=1))
        assert scenario.beacons.ids[shifted].tolist() == list(changed.moved)
        for row in shifted:
            step = math.dist(before[row, :2], after[row, :2])
            assert BEACON_MOVE[0] <= step <= BEACON_MOVE[1]
            assert after[row, 2] == before[row, 2]
            x, y = after[row, :2]
            assert x0 + SITE_MARGIN < x < x1 - SITE_MARGIN
            assert y0 + SITE_MARGIN < y < y1 - SITE_MARGIN
            assert not any(r.contains(x, y, margin=-0.1) for r in changed.world.racks)
            assert not any(crosses(before[row, :2], after[row, :2], w.start, w.end)
                           for w in scenario.walls)
        # the map is the map as it was; the truth is the world's
        assert np.array_equal(changed.world.beacons.xyz, scenario.beacons.xyz)
        assert np.array_equal(true_map(changed.world).xyz, after)


def test_a_perturbation_is_its_seeds_and_only_its_seeds():
    scenario = load_scenario("warehouse-small")
    ids = scenario.beacons.ids.tolist()
    first = move_beacons(scenario, np.random.default_rng(4), 3, ids)
    again = move_beacons(scenario, np.random.default_rng(4), 3, ids)
    other = move_beacons(scenario, np.random.default_rng(5), 3, ids)
    assert first.moved == again.moved
    assert first.world.beacon_positions.tobytes() == again.world.beacon_positions.tobytes()
    assert first.world.beacon_positions.tobytes() != other.world.beacon_positions.tobytes()
    rack = move_rack(scenario, np.random.default_rng(4), scenario.routes[0])
    assert rack.world.racks == move_rack(scenario, np.random.default_rng(4),
                                         scenario.routes[0]).world.racks


def test_moved_beacons_are_drawn_among_those_given():
    scenario = load_scenario("warehouse-small")
    for seed in range(10):
        assert set(move_beacons(scenario, np.random.default_rng(seed), 2, [3, 5, 7]).moved) \
            <= {3, 5, 7}
    with pytest.raises(InvalidInputError, match="only 1 to draw from"):
        move_beacons(scenario, np.random.default_rng(0), 2, [3, 99])


@pytest.mark.parametrize("name", ["warehouse-small", "warehouse-paper"])
def test_a_moved_rack_slides_along_its_axis_with_its_beacons_clear_of_the_route(name):
    scenario = load_scenario(name)
    for seed in range(20):
        route = scenario.routes[seed % len(scenario.routes)]
        changed = move_rack(scenario, np.random.default_rng(seed), route)
        moved = [(old, new) for old, new in zip(scenario.racks, changed.world.racks,
                                                strict=True) if old != new]
        assert len(moved) == 1
        old, new = moved[0]
        shift = np.subtract(new.center, old.center)
        assert RACK_MOVE[0] <= np.hypot(*shift) <= RACK_MOVE[1]
        assert abs(math.cos(old.angle) * shift[1] - math.sin(old.angle) * shift[0]) < 1e-9
        before, after = scenario.beacon_positions, changed.world.beacon_positions
        rows = np.flatnonzero((before != after).any(axis=1))
        assert rows.size and scenario.beacons.ids[rows].tolist() == list(changed.moved)
        assert np.allclose(after[rows, :2] - before[rows, :2], shift)
        # the route passes no closer to the rack than before (or 1.5 m)
        points = np.concatenate([np.linspace(a, b, 200) for a, b in
                                 zip(route.waypoints[:-1], route.waypoints[1:], strict=True)])
        assert not new.contains(points[:, 0], points[:, 1], margin=-1.0).any() or \
            old.contains(points[:, 0], points[:, 1], margin=-1.0).any()


def test_a_site_without_racks_has_no_rack_to_move():
    scenario = load_scenario("robot-arena")
    with pytest.raises(InvalidInputError, match="robot-arena has no rack to move"):
        move_rack(scenario, np.random.default_rng(0), scenario.routes[0])

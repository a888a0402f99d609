"""SPL's shortest path: exact on hand-worked floors, a lower bound of every drive the forklift
makes, its premise (the body's centre keeps out of the inflated obstacles) held by the physics."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from azgym.bench.navigation.results_file import FORKLIFT
from azgym.bench.navigation.scoring import drive
from azgym.errors import InvalidInputError
from azgym.nav import geodesic as G
from azgym.nav.policy_file import load_policy
from azgym.nav.spots import spots_of
from azgym.site import load_scenario
from azgym.world.world import World

RHO = G.BODY_CLEARANCE


def test_the_body_clearance_is_half_the_width_less_the_collision_slop():
    import pymunk

    assert RHO == pytest.approx(0.5)
    assert pymunk.Space().collision_slop == pytest.approx(G.COLLISION_SLOP)


def test_a_straight_line_in_an_empty_room_stops_at_the_goal_circle():
    room = load_scenario("warehouse-small")
    walls_only = dataclasses.replace(room, racks=())
    lengths = G.shortest_lengths(G.obstacles_of(walls_only), [[2.0, 2.0], [5.0, 5.0]],
                                 [[12.0, 2.0], [5.5, 5.0]], 1.0)
    # 10 m apart, the goal region 1 m round the goal; a start within it has nothing to drive
    assert lengths[0, 0] == pytest.approx(9.0, abs=1e-12)
    assert lengths[1, 1] == 0.0


def test_round_one_rectangle_the_path_hugs_its_corners():
    square = np.array([[4.0, -1.0], [6.0, -1.0], [6.0, 1.0], [4.0, 1.0]])
    # (0, 0) → (4, 1) → (6, 1) → (10, 0): 2 √17 + 2
    assert G.shortest_lengths([square], [[0.0, 0.0]], [[10.0, 0.0]], 0.0)[0, 0] == \
        pytest.approx(2 * math.sqrt(17) + 2, abs=1e-12)
    # clockwise corners are the same obstacle once inflated
    assert G.shortest_lengths([G.inflated(square[::-1], 0.5)], [[0.0, 0.0]], [[10.0, 0.0]],
                              0.0)[0, 0] == G.shortest_lengths(
        [G.inflated(square, 0.5)], [[0.0, 0.0]], [[10.0, 0.0]], 0.0)[0, 0]


def _round_the_rounded_rectangle(radius: float) -> float:
    """(0, 0) to (10, 0) round [4, 6] × [-1, 1] inflated by ``radius``, exactly: tangent to
    the circle of radius ``radius`` round (4, 1), along its arc, 2 m along the top, and back
    down symmetrically."""
    centre = math.hypot(4.0, 1.0)
    tangent = math.sqrt(centre ** 2 - radius ** 2)
    arc = math.atan2(1.0, 4.0) + math.asin(radius / centre)
    return 2 * (tangent + radius * arc) + 2.0


def test_round_an_inflated_rack_the_length_lies_within_the_stated_bound():
    rack = np.array([[4.0, -1.0], [6.0, -1.0], [6.0, 1.0], [4.0, 1.0]])
    length = G.shortest_lengths([G.inflated(rack, RHO)], [[0.0, 0.0]], [[10.0, 0.0]],
                                0.0)[0, 0]
    assert _round_the_rounded_rectangle(RHO * math.cos(G.ARC_STEP / 2)) <= length
    assert length <= _round_the_rounded_rectangle(RHO)
    # the bound is tight: under 1 cm on 10.55 m
    assert _round_the_rounded_rectangle(RHO) - _round_the_rounded_rectangle(
        RHO * math.cos(G.ARC_STEP / 2)) < 0.01


def test_a_goal_circle_half_hidden_is_reached_where_it_crosses_the_obstacle():
    # The goal (0, 0) lies in the obstacle; of its 1 m circle only y ≥ 0.5 is free. From (5, 1)
    # the circle's nearest point is inside, so the path ends where the circle crosses the
    # obstacle's top edge, (√0.75, 0.5).
    block = np.array([[-0.5, -10.0], [10.0, -10.0], [10.0, 0.5], [-0.5, 0.5]])
    lengths = G.shortest_lengths([block], [[5.0, 1.0], [5.0, 3.0]], [[0.0, 0.0]], 1.0)
    assert lengths[0, 0] == pytest.approx(math.hypot(5.0 - math.sqrt(0.75), 0.5), abs=1e-12)
    assert lengths[1, 0] == pytest.approx(math.sqrt(34.0) - 1.0, abs=1e-12)  # in plain sight


def test_an_enclosed_goal_is_out_of_reach_and_a_start_in_an_obstacle_is_refused():
    ring = [G.inflated(np.array([a, b]), 0.1) for a, b in (
        ([-2.0, -2.0], [2.0, -2.0]), ([2.0, -2.0], [2.0, 2.0]), ([2.0, 2.0], [-2.0, 2.0]),
        ([-2.0, 2.0], [-2.0, -2.0]))]
    assert G.shortest_lengths(ring, [[5.0, 0.0]], [[0.0, 0.0]], 1.0)[0, 0] == math.inf
    with pytest.raises(InvalidInputError, match=r"start \(2, 0\) lies inside an obstacle"):
        G.shortest_lengths(ring, [[2.0, 0.0]], [[0.0, 0.0]], 1.0)
    scenario = load_scenario("warehouse-small")
    with pytest.raises(InvalidInputError, match=r"spot \(8.75, 3.1\) is closer than 0.50 m to "
                                                r"a rack or a wall"):
        G.shortest_paths_for(scenario, np.array([[2.0, 1.7], [8.75, 3.1]]), 1.0)


def _grid_lengths(scenario, spots, radius, resolution=0.05):
    """An independent check: 16-neighbour Dijkstra on cells whose centres are outside the
    inflated obstacles, from the cells of the spots to the cells within ``radius`` of them.
    Such a path is at most 2.7 % longer than the straight line it stands for."""
    x0, y0, x1, y1 = scenario.bounds
    xs = np.arange(x0, x1 + resolution / 2, resolution)
    ys = np.arange(y0, y1 + resolution / 2, resolution)
    x, y = np.meshgrid(xs, ys)
    blockers = G._Obstacles(G.obstacles_of(scenario))
    free = ~blockers.inside(np.column_stack((x.ravel(), y.ravel()))).reshape(x.shape)
    ny, nx = free.shape
    index = np.arange(ny * nx).reshape(ny, nx)
    sources, targets, weights = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1), (1, 2), (2, 1), (2, -1), (1, -2)):
        rows = slice(max(0, -dr), ny - max(0, dr))
        cols = slice(max(0, -dc), nx - max(0, dc))
        moved = (slice(rows.start + dr, rows.stop + dr), slice(cols.start + dc, cols.stop + dc))
        allowed = free[rows, cols] & free[moved]
        if abs(dr) + abs(dc) == 3:  # a knight's move needs the two cells it cuts across
            hr, hc = (dr // 2 if abs(dr) == 2 else 0), (dc // 2 if abs(dc) == 2 else 0)
            for r, c in ((hr, hc), (dr - hr, dc - hc)):
                allowed &= free[rows.start + r:rows.stop + r, cols.start + c:cols.stop + c]
        sources.append(index[rows, cols][allowed])
        targets.append(index[moved][allowed])
        weights.append(np.full(allowed.sum(), resolution * math.hypot(dr, dc)))
    graph = coo_matrix((np.concatenate(weights),
                        (np.concatenate(sources), np.concatenate(targets))),
                       shape=(ny * nx, ny * nx)).tocsr()
    cells = [int(round((sy - y0) / resolution)) * nx + int(round((sx - x0) / resolution))
             for sx, sy in spots]
    distance = dijkstra(graph, directed=False, indices=cells)
    return np.array([[distance[i][(np.hypot(x - gx, y - gy) < radius).ravel()].min()
                      for gx, gy in spots] for i in range(len(spots))])


def test_on_the_warehouse_floor_a_fine_grid_agrees_within_its_own_error():
    scenario = load_scenario("warehouse-small")
    spots = spots_of(scenario)[:4]
    exact = G.shortest_paths_for(scenario, spots, 1.0)
    grid = _grid_lengths(scenario, spots, 1.0)
    off = ~np.eye(len(spots), dtype=bool)
    # a grid path is a real path (less the cells' snapping, 5 cm at each end), and no more
    # than 2.7 % longer than the shortest
    assert (grid[off] >= exact[off] - 0.1).all()
    assert (grid[off] <= 1.027 * exact[off] + 0.1).all()


def test_the_body_centre_keeps_out_of_the_inflated_obstacles_when_rammed_into_them():
    """The premise of the lower bound: full throttle into racks and walls, at every steering."""
    scenario = load_scenario("warehouse-small")
    blockers = G._Obstacles(G.obstacles_of(scenario))
    rng = np.random.default_rng(0)
    spots = spots_of(scenario)
    positions, contacts = [], 0
    for _ in range(24):
        world = World(scenario, (*spots[rng.integers(len(spots))], rng.uniform(-math.pi, math.pi)))
        for step in range(400):
            if step % 50 == 0:
                throttle, steer = rng.choice([1.0, -1.0]), rng.uniform(-1.0, 1.0)
            world.step(throttle, steer)
            positions.append(world.forklift.pose[:2])
        contacts += len(world.contacts)
    assert contacts > 50  # it did hit things
    assert not blockers.inside(np.array(positions)).any()


@pytest.mark.parametrize(("navigator", "localizer"), [("pure-pursuit", "truth"),
                                                      ("pure-pursuit", "lsq"), ("ppo", "truth")])
def test_no_drive_is_shorter_than_its_shortest_path_nor_faster_than_the_forklift(
        navigator, localizer):
    if navigator == "ppo":
        pytest.importorskip("stable_baselines3")
    env = gym.make("azgym/Navigate-WarehouseSmall-v2", localizer=localizer)
    episodes = drive(env, load_policy(navigator, env), 12, seed=2300)["episodes"]
    assert sum(e["success"] for e in episodes) >= 6
    for k, episode in enumerate(episodes):
        assert episode["shortest_path"] == env.unwrapped.shortest_path(2300 + k)
        assert episode["travelled"] <= FORKLIFT.max_centre_distance(episode["time"])
        if episode["success"]:
            assert episode["travelled"] > episode["shortest_path"]
            assert episode["spl"] < 1.0


def test_the_environment_reports_the_geodesic_of_the_spots_it_draws():
    env = gym.make("azgym/Navigate-WarehouseSmall-v2", localizer="truth")
    inner = env.unwrapped
    for seed in range(5):
        _, info = env.reset(seed=seed)
        start = int(np.argmin(np.hypot(*(inner.spots - info["true_pose"][:2]).T)))
        goal = int(np.argmin(np.hypot(*(inner.spots - info["goal"]).T)))
        assert info["shortest_path"] == inner.shortest_paths[start, goal] == \
            inner.shortest_path(seed)
        # the straight line to the goal circle is the least any floor allows
        assert info["shortest_path"] >= math.hypot(*(inner.spots[goal] - inner.spots[start])) - 1

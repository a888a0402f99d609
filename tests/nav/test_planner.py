"""The navigation planner, path follower, pose keeper, scripted driver and scores."""

from __future__ import annotations

import importlib.resources
import math

import gymnasium as gym
import numpy as np
import pytest

import azgym.envs  # noqa: F401  (registers the environments)
from azgym import InvalidInputError
from azgym.bench.navigation.scoring import drive, summarize
from azgym.nav._descent import follow, points_at
from azgym.nav.grid import INFLATION, RESOLUTION, build_grid
from azgym.nav.planner import planner_for
from azgym.nav.pose_keeper import JUMP_MARGIN, LOST_AFTER, PoseKeeper
from azgym.nav.pursuit import PurePursuit
from azgym.nav.spots import aisle_headings, spots_of
from azgym.site import load_scenario
from azgym.world.forklift import ForkliftSpec

NAVIGATE = "azgym/Navigate-WarehouseSmall-v2"


@pytest.fixture(scope="module")
def warehouse():
    scenario = load_scenario("warehouse-small")
    return scenario, planner_for(scenario, spots_of(scenario))


def test_clearance_is_the_distance_to_the_nearest_rack_or_wall(warehouse):
    scenario, planner = warehouse
    grid = planner.grid
    # The aisle at y = 6 runs between rack faces at y = 4.6 and 7.4: 1.4 m either side.
    assert grid.clearance[grid.cell(10.0, 6.0)] == pytest.approx(1.4, abs=RESOLUTION)
    assert grid.clearance[grid.cell(10.0, 4.0)] == 0.0  # inside a rack
    assert grid.clearance[grid.cell(0.5, 10.0)] == pytest.approx(0.5, abs=RESOLUTION)  # wall
    # No free cell lies within the inflation of a rack's footprint (up to a cell).
    ys, xs = np.nonzero(grid.free)
    x = grid.origin[0] + RESOLUTION * xs
    y = grid.origin[1] + RESOLUTION * ys
    for rack in scenario.racks:  # the shipped racks are aligned with the axes
        dx = np.maximum(np.abs(x - rack.center[0]) - 0.5 * rack.size[0], 0.0)
        dy = np.maximum(np.abs(y - rack.center[1]) - 0.5 * rack.size[1], 0.0)
        assert np.hypot(dx, dy).min() >= INFLATION - RESOLUTION


def test_every_planned_path_stays_free_and_is_near_shortest(warehouse):
    _, planner = warehouse
    free, grid = planner.grid.free, planner.grid
    for goal in range(len(planner.spots)):
        for start in planner.spots:
            path = planner.path(goal, *start)
            assert all(free[grid.cell(x, y)] for x, y in path)
            length = float(np.hypot(*np.diff(path, axis=0).T).sum())
            assert length >= math.dist(start, planner.spots[goal]) - 1e-9
            # The potential never rises along the path (the reward telescopes).
            costs = [planner.cost_to_go(goal, x, y) for x, y in path[1:-1]]
            assert all(b <= a + 1e-9 for a, b in zip(costs, costs[1:], strict=False))
    # Down a straight aisle the path is the straight line: (2, 1.7) to (28, 1.7) is 26 m.
    goal = int(np.flatnonzero((planner.spots == [28.0, 1.7]).all(axis=1))[0])
    assert planner.plan(goal, 2.0, 1.7)[1][-1] == pytest.approx(26.0, abs=0.05)


def test_a_spot_the_forklift_cannot_reach_is_refused(tmp_path):
    text = importlib.resources.files("azgym.site.scenarios").joinpath(
        "warehouse-small.toml").read_text()
    # Pallets narrow the aisle at y = 14 to 1.5 m on both sides of the spot (22, 14): the route
    # keeps the 0.7 m a scenario file needs, the forklift (it needs 2 x 0.8 m) cannot pass.
    pallets = "".join(f"\n[[racks]]\ncenter = [{x}, {y}]\nsize = [1.0, 0.5]\nheight = 1.0\n"
                      for x in (18.5, 24.5) for y in (13.0, 15.0))
    path = tmp_path / "blocked.toml"
    path.write_text(text.replace("[[beacons]]", pallets + "\n[[beacons]]", 1))
    with pytest.raises(InvalidInputError, match=r"cannot be reached from spot \(22, 14\)"):
        gym.make(NAVIGATE, scenario=str(path))


def test_a_floor_too_large_for_the_planner_is_refused():
    scenario = load_scenario("warehouse-small")
    huge = type(scenario)(**{**scenario.__dict__, "bounds": (0.0, 0.0, 1000.0, 1000.0)})
    with pytest.raises(InvalidInputError, match="planner cells"):
        build_grid(huge)


def test_a_pose_is_projected_onto_the_path_near_where_it_was():
    path = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    along = np.array([0.0, 10.0, 20.0])
    segment, arc, distance = follow(path, along, 3.0, 1.0, 0, 1.0, 4.0)
    assert (segment, arc, distance) == (0, 3.0, 1.0)
    out = np.empty((3, 2))
    points_at(path, along, segment, arc + np.array([1.5, 9.0, 30.0]), out)
    np.testing.assert_allclose(out, [[4.5, 0.0], [10.0, 2.0], [10.0, 10.0]])
    # Near (9, 9) the second leg is nearer, but it lies beyond the search window of arc 0.
    assert follow(path, along, 9.0, 9.0, 0, 1.0, 4.0)[0] == 0
    assert follow(path, along, 9.0, 9.0, 1, 1.0, 4.0)[1] == pytest.approx(19.0)


def test_the_pose_keeper_dead_reckons_and_gates_jumps():
    keeper = PoseKeeper(ForkliftSpec())
    assert keeper.offer((5.0, 5.0, 0.0), 6)
    for _ in range(50):  # 1 s straight ahead at 1 m/s
        keeper.coast(1.0, 0.0, 0.02)
    assert keeper.pose == pytest.approx((6.0, 5.0, 0.0))
    assert keeper.age == pytest.approx(1.0)
    assert not keeper.offer((16.0, 5.0, 0.0), 3)  # a ghost 10 m away
    assert keeper.rejected == 1 and keeper.pose == pytest.approx((6.0, 5.0, 0.0))
    assert keeper.offer((6.0 + JUMP_MARGIN, 5.0, 0.0), 4)  # within the margin
    keeper.coast(0.0, 0.0, LOST_AFTER + 0.1)
    assert keeper.offer((16.0, 5.0, 0.0), 3)  # lost: the next answer is taken


def test_starts_stand_along_an_aisle(warehouse):
    scenario, planner = warehouse
    headings = aisle_headings(scenario, planner.spots)
    # (2, 10): the loop comes in from the east and leaves to the north.
    corner = int(np.flatnonzero((planner.spots == [2.0, 10.0]).all(axis=1))[0])
    np.testing.assert_allclose(sorted(headings[corner]), [-math.pi / 2, 0.0, math.pi / 2,
                                                         math.pi])


def test_progress_rewards_telescope_to_the_fall_of_the_cost_to_go():
    env = gym.make(NAVIGATE, localizer="truth")
    _, info = env.reset(seed=4)
    inner = env.unwrapped
    start = inner._cost_to_go()
    total, pursuit = 0.0, PurePursuit()
    observation = env.reset(seed=4)[0]
    for _ in range(80):
        observation, _, terminated, truncated, info = env.step(pursuit.act(observation))
        total += info["rewards"]["progress"]
        if terminated or truncated:
            break
    assert total == pytest.approx(start - inner._cost_to_go(), abs=1e-9)


def test_pure_pursuit_reaches_the_goal_with_truth_and_ransac_but_less_with_lsq():
    results = {localizer: drive(gym.make(NAVIGATE, localizer=localizer), PurePursuit(), 30, 0)
               for localizer in ("truth", "ransac", "lsq")}
    assert results["truth"]["success"] >= 0.9 and results["ransac"]["success"] >= 0.85
    assert results["lsq"]["success"] < results["ransac"]["success"] - 0.1
    assert results["truth"]["error_median_cm"] == 0.0


def test_scores_are_success_spl_and_the_errors_of_answered_steps():
    records = [
        {"success": True, "spl": 10.0 / 12.5, "collisions": 1, "time": 8.0,
         "errors": np.array([0.01, math.nan, 0.03])},
        {"success": False, "spl": 0.0, "collisions": 3, "time": 60.0,
         "errors": np.array([0.02, math.nan])},
    ]
    summary = summarize(records)
    assert summary["success"] == 0.5 and summary["spl"] == pytest.approx(0.4)
    assert summary["collisions"] == 2.0 and summary["time_to_goal"] == 8.0
    assert summary["answered"] == pytest.approx(0.6)
    assert summary["error_median_cm"] == pytest.approx(2.0)


def test_discrete_pursuit_gives_valid_actions():
    env = gym.make("azgym/NavigateDiscrete-WarehouseSmall-v2", localizer="truth")
    observation, _ = env.reset(seed=0)
    pursuit = PurePursuit(discrete=True)
    for _ in range(20):
        action = pursuit.act(observation)
        assert env.action_space.contains(action)
        observation, *_ = env.step(action)

"""The top-down render shows where the vehicle is going: goal, planned path, poses, a legend."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import azgym.envs  # noqa: F401  (registers the ids)
from azgym.envs import render as R
from azgym.site import load_scenario


class _Navigating:
    """A stand-in for a navigation environment: a scenario, poses, a goal and a path."""

    goal_radius = 1.0

    def __init__(self) -> None:
        self.scenario = load_scenario("warehouse-small")
        self.last_observation = None

    def true_pose(self) -> tuple[float, float, float]:
        return (2.0, 2.0, 0.0)

    def last_estimate(self) -> tuple[float, float, float]:
        return (2.3, 2.1, 0.1)

    def goal(self) -> tuple[float, float]:
        return (20.0, 10.0)

    def planned_path(self) -> np.ndarray:
        return np.array([[2.0, 2.0], [20.0, 2.0], [20.0, 10.0]])


def _has(image: np.ndarray, colour: tuple[int, int, int]) -> int:
    """Pixels of an RGB image in a drawing colour (given as OpenCV's BGR)."""
    return int(np.count_nonzero(np.all(image == colour[::-1], axis=2)))


def test_the_render_draws_the_goal_the_planned_path_and_a_legend():
    env = _Navigating()
    image = R.draw(env)
    assert _has(image, R.GOAL) > 100 and _has(image, R.PATH) > 100
    assert _has(image, R.TRUE_POSE) > 20 and _has(image, R.ESTIMATE) > 20
    # The legend is a strip below the floor, so it hides nothing of the room: it names the
    # goal and the path beside their colours.
    strip = image[-R.LEGEND_ROW:]
    assert _has(strip, R.GOAL) and _has(strip, R.PATH) and _has(strip, R.ESTIMATE)
    assert np.array_equal(image, R.draw(env))  # the same state, the same picture


def test_a_localization_render_has_the_legend_but_no_goal_or_path():
    env = gym.make("azgym/Localize-WarehouseSmall-v1", render_mode="rgb_array")
    env.reset(seed=0)
    image = env.render()
    assert _has(image, R.GOAL) == 0 and _has(image, R.PATH) == 0
    assert _has(image[-R.LEGEND_ROW:], R.TRUE_POSE)


def test_a_navigation_render_shows_its_own_goal_and_planned_path():
    env = gym.make("azgym/Navigate-WarehouseSmall-v2", render_mode="rgb_array")
    env.reset(seed=0)
    image = env.render()
    floor = image[:-R.LEGEND_ROW]
    assert _has(floor, R.GOAL) > 50 and _has(floor, R.PATH) > 50
    assert env.unwrapped.planned_path().shape[1] == 2
    env.step(env.action_space.sample())
    assert np.array_equal(env.render(), env.render())

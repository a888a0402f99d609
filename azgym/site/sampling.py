"""Random camera poses on a site's floor: one rule for every suite, study and environment."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from azgym.core import Pose
from azgym.errors import ScenarioError
from azgym.site.scenario import Scenario

__all__ = ["RACK_CLEARANCE", "WALL_CLEARANCE", "clear_of_racks", "random_free_pose"]

WALL_CLEARANCE = 0.5
"""A random pose keeps this far inside the room's bounds [m]."""
RACK_CLEARANCE = 0.8
"""A random pose keeps this far from every rack's footprint [m]: where a forklift can stand."""
MAX_TRIES = 10_000
"""Draws before giving up: a site whose free floor is under about 0.1 % of its room has none."""


def random_free_pose(scenario: Scenario, rng: np.random.Generator) -> Pose:
    """A pose uniform over the free floor, with a uniform heading.

    The position is drawn uniformly in the room shrunk by ``WALL_CLEARANCE`` until it is
    ``RACK_CLEARANCE`` clear of every rack (rejection sampling: uniform over the free floor);
    then the heading is drawn uniformly from [−π, π).

    Raises:
        ScenarioError: No free floor found in ``MAX_TRIES`` draws.
    """
    x_min, y_min, x_max, y_max = scenario.bounds
    low = (x_min + WALL_CLEARANCE, y_min + WALL_CLEARANCE)
    high = (x_max - WALL_CLEARANCE, y_max - WALL_CLEARANCE)
    for _ in range(MAX_TRIES):
        x, y = rng.uniform(low, high)
        if clear_of_racks(scenario, x, y):
            return float(x), float(y), float(rng.uniform(-math.pi, math.pi))
    raise ScenarioError(
        f"{scenario.name}: no free floor for a camera pose: {MAX_TRIES} random points in the "
        f"room were all within {WALL_CLEARANCE} m of a wall or {RACK_CLEARANCE} m of a rack")


def clear_of_racks(scenario: Scenario, x: Any, y: Any) -> Any:
    """Whether (x, y) is ``RACK_CLEARANCE`` clear of every rack: where a camera can stand.

    The one rule for random poses and the layout planner's floor: a bool for one point, an array
    for arrays of points.
    """
    clear = np.ones(np.shape(x), dtype=bool)
    for rack in scenario.racks:
        clear &= np.logical_not(rack.contains(x, y, margin=-RACK_CLEARANCE))
    return clear if clear.ndim else bool(clear)

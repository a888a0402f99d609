"""The pick and drop spots of a scenario: where navigation episodes start and end."""

from __future__ import annotations

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.site import Scenario

MIN_GOAL_DISTANCE = 5.0
"""A goal spot is at least this far from the start, in a straight line [m]."""


def spots_of(scenario: Scenario) -> FloatArray:
    """Every route's waypoints (aisle ends and crossings), once each, shape (S, 2) [m].

    Raises:
        InvalidInputError: The scenario has no routes, or no two spots are
            :data:`MIN_GOAL_DISTANCE` apart, so no episode can start.
    """
    if not scenario.routes:
        raise InvalidInputError(
            f"scenario {scenario.name!r} has no routes, whose waypoints are the navigation "
            "spots; add [[routes]] to it")
    spots = np.unique(np.concatenate([route.waypoints for route in scenario.routes]), axis=0)
    spread = np.hypot(*(spots[:, None, :] - spots[None, :, :]).transpose(2, 0, 1))
    if spread.max() < MIN_GOAL_DISTANCE:
        raise InvalidInputError(
            f"scenario {scenario.name!r}: no two spots (route waypoints) are "
            f"{MIN_GOAL_DISTANCE} m apart, so no start and goal can be drawn")
    return spots

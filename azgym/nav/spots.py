"""The pick and drop spots of a scenario: where navigation episodes start and end."""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.site import Scenario

__all__ = ["HEADING_SPREAD", "aisle_headings", "draw_route", "spots_of"]

MIN_GOAL_DISTANCE = 5.0
"""A goal spot is at least this far from the start, in a straight line [m]."""
HEADING_SPREAD = math.radians(15.0)
"""A start heading lies within this of an aisle's direction at the spot [rad]."""


def spots_of(scenario: Scenario) -> FloatArray:
    """Every route's waypoints (aisle ends and crossings), once each, shape (S, 2) [m].

    Raises:
        InvalidInputError: The scenario has no routes, or no two spots are
            :data:`MIN_GOAL_DISTANCE` apart, so no episode can start; or a differential-drive
            robot drives it (navigation drives a forklift).
    """
    if scenario.differential_drive:
        raise InvalidInputError(
            f"scenario {scenario.name!r}: its vehicle is a differential-drive robot; navigation "
            "drives a forklift (give a scenario whose [vehicle] is a forklift)")
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


def draw_route(rng: np.random.Generator, spots: FloatArray) -> tuple[int, int]:
    """An episode's start and goal: two spots :data:`MIN_GOAL_DISTANCE` apart or more, by index.

    The pair is drawn uniformly, drawing again until it is that far apart.
    """
    while True:
        start, goal = rng.choice(len(spots), size=2, replace=False)
        if np.hypot(*(spots[goal] - spots[start])) >= MIN_GOAL_DISTANCE:
            return int(start), int(goal)


def aisle_headings(scenario: Scenario, spots: FloatArray) -> list[FloatArray]:
    """For each spot, the directions [rad] of the route legs that meet there, both ways.

    A forklift at a pick or drop spot stands along the aisle it came by: these are the headings
    an episode may start with (give or take :data:`HEADING_SPREAD`).
    """
    headings: list[list[float]] = [[] for _ in spots]
    for route in scenario.routes:
        points = np.asarray(route.waypoints, dtype=np.float64)
        for a, b in zip(points[:-1], points[1:], strict=True):
            direction = math.atan2(b[1] - a[1], b[0] - a[0])
            for end in (a, b):
                k = int(np.argmin(np.hypot(*(spots - end).T)))
                headings[k] += [direction, direction - math.copysign(math.pi, direction)]
    return [np.unique(np.round(h, 12)) for h in headings]

"""The rules that relate a scenario's tables: beacons in the room, routes clear of the walls.

Every shipped scenario keeps them; a wall-mounted beacon (on the room's bounds, or a few
centimetres past them) is accepted, one farther out is refused, and so is a route whose leg
crosses a wall or passes within ``ROUTE_CLEARANCE`` of one (the forklift would drive into
pymunk's solid wall).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import azgym
from azgym import ScenarioError
from azgym.site import parse_scenario
from azgym.site.elements import ROUTE_CLEARANCE, Wall, leg_wall_distance
from azgym.site.parse_layout import ON_WALL_TOLERANCE


def scenario_data(beacons=None, walls=(), routes=()):
    """A 10 m x 10 m room with three beacons (or the given ones), walls and routes."""
    return {"name": "rules", "description": "layout rules", "version": 1,
            "room": {"bounds": [0.0, 0.0, 10.0, 10.0]},
            "beacons": beacons or [{"id": 1, "xy": [0.0, 0.0]}, {"id": 2, "xy": [10.0, 0.0]},
                                   {"id": 3, "xy": [0.0, 10.0]}],
            "walls": list(walls), "routes": list(routes)}


@pytest.mark.parametrize("name", azgym.list_scenarios())
def test_every_shipped_scenario_keeps_the_rules(name):
    scenario = azgym.load_scenario(name)
    x_min, y_min, x_max, y_max = scenario.bounds
    xy = scenario.beacon_positions[:, :2]
    assert ((xy >= [x_min - ON_WALL_TOLERANCE, y_min - ON_WALL_TOLERANCE])
            & (xy <= [x_max + ON_WALL_TOLERANCE, y_max + ON_WALL_TOLERANCE])).all()
    assert (scenario.beacons.ids >= 0).all()


@pytest.mark.parametrize("xy", [[10.0, 5.0], [0.0, 0.0], [10.04, 5.0], [5.0, -0.049]],
                         ids=["on-east-wall", "in-a-corner", "on-east-wall-face",
                              "on-south-wall-face"])
def test_a_beacon_on_a_wall_is_accepted(xy):
    beacons = [{"id": 1, "xy": [0.0, 0.0]}, {"id": 2, "xy": [10.0, 0.0]}, {"id": 3, "xy": xy}]
    assert parse_scenario(scenario_data(beacons)).beacons.xy[2].tolist() == xy


@pytest.mark.parametrize(("entry", "field", "where"), [
    ({"id": 3, "xy": [10.06, 5.0]}, "xy", "(10.06, 5)"),
    ({"id": 3, "xyz": [5.0, 1e4, 2.0]}, "xyz", "(5, 10000)"),
    ({"id": 3, "xy": [5.0, 5.0], "moved_to": [5.0, -1.0]}, "moved_to", "(5, -1)"),
])
def test_a_beacon_outside_the_room_is_refused_naming_it_and_the_bounds(entry, field, where):
    beacons = [{"id": 1, "xy": [0.0, 0.0]}, {"id": 2, "xy": [10.0, 0.0]}, entry]
    with pytest.raises(ScenarioError, match=re.escape(
            f"rules.toml: beacons[2].{field}: beacon 3 at {where} is outside the room [0, 10] x "
            f"[0, 10] (by more than {ON_WALL_TOLERANCE:g} m)")):
        parse_scenario(scenario_data(beacons), "rules.toml")


WALL = {"start": [5.0, 0.0], "end": [5.0, 6.0], "height": 3.0}


@pytest.mark.parametrize(("waypoints", "problem"), [
    ([[2.0, 3.0], [8.0, 3.0]], "crosses walls[0]"),
    ([[2.0, 3.0], [5.0, 3.0]], "crosses walls[0]"),  # ends on the wall
    ([[2.0, 6.5], [8.0, 6.5]], f"passes within {ROUTE_CLEARANCE} m of walls[0]"),  # its end
    ([[4.5, 1.0], [4.5, 5.0]], f"passes within {ROUTE_CLEARANCE} m of walls[0]"),  # alongside
])
def test_a_route_into_a_wall_is_refused_naming_route_and_leg(waypoints, problem):
    (x0, y0), (x1, y1) = waypoints
    route = {"name": "bad", "waypoints": waypoints}
    with pytest.raises(ScenarioError, match=re.escape(
            f"rules.toml: routes[0].waypoints: leg 0 from ({x0:g}, {y0:g}) to ({x1:g}, {y1:g}) "
            f"{problem} (route 'bad')")):
        parse_scenario(scenario_data(walls=[WALL], routes=[route]), "rules.toml")


def test_a_route_through_a_door_is_accepted():
    walls = [WALL, {"start": [5.0, 8.0], "end": [5.0, 10.0], "height": 3.0}]  # a 2 m door
    route = {"name": "door", "waypoints": [[2.0, 7.0], [8.0, 7.0]]}
    assert parse_scenario(scenario_data(walls=walls, routes=[route])).routes[0].name == "door"


DIAGONAL, ALONG_X = ((0.0, 0.0), (1.0, 1.0)), ((0.0, 0.0), (1.0, 0.0))


@pytest.mark.parametrize(("wall", "start", "end", "expected"), [
    (DIAGONAL, (0.0, 1.0), (1.0, 0.0), 0.0),              # crosses
    (DIAGONAL, (0.0, 1.0), (2.0, 1.0), 0.0),              # touches its end (1, 1)
    (DIAGONAL, (0.0, 2.0), (2.0, 2.0), 1.0),              # parallel to the x axis, above it
    (DIAGONAL, (1.0, 0.0), (2.0, -1.0), math.sqrt(0.5)),  # from (1, 0), away from it
    (ALONG_X, (3.0, 0.0), (4.0, 0.0), 2.0),               # collinear, past its end
    (ALONG_X, (0.5, 0.0), (0.5, 0.0), 0.0),               # a point on it
    (ALONG_X, (0.5, 0.3), (0.5, 0.3), 0.3),               # a point above it
])
def test_leg_wall_distance_hand_values(wall, start, end, expected):
    wall = Wall(start=wall[0], end=wall[1], height=2.0)
    assert leg_wall_distance(np.array(start), np.array(end), wall) == pytest.approx(expected)

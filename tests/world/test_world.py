"""The pymunk world: forklift kinematics by hand, routes, collisions, repeatability."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from azgym import ScenarioError, list_scenarios, load_scenario
from azgym.site import parse_scenario
from azgym.world.driver import PurePursuit
from azgym.world.forklift import ForkliftSpec
from azgym.world.world import World


def open_floor(walls=(), racks=(), routes=()):
    """A 40 m × 40 m floor with three beacons in a corner, and the given obstacles."""
    return parse_scenario({
        "name": "floor", "description": "open floor", "version": 1,
        "room": {"bounds": [-20.0, -20.0, 20.0, 20.0]},
        "beacons": [{"id": k, "xyz": [-19.0, -19.0 + k, 4.0]} for k in range(3)],
        "walls": list(walls), "racks": list(racks), "routes": list(routes),
    }, "floor.toml")


def drive(world, throttle, steer, seconds):
    for _ in range(round(seconds / world.dt)):
        world.step(throttle, steer)


def test_full_throttle_from_rest_covers_half_a_t_squared():
    spec = ForkliftSpec()
    world = World(open_floor(), (0.0, 0.0, 0.0), spec)
    drive(world, 1.0, 0.0, 1.5)  # 1.5 m/s² for 1.5 s: below the 3 m/s limit
    x, y, heading = world.forklift.pose
    assert x == pytest.approx(0.5 * spec.max_accel * 1.5**2, rel=0.03)
    assert abs(y) < 1e-9 and abs(heading) < 1e-9
    assert world.forklift.speed == pytest.approx(spec.max_accel * 1.5, rel=0.03)


def test_constant_steering_turns_at_v_tan_delta_over_wheelbase():
    spec = ForkliftSpec()
    world = World(open_floor(), (0.0, 0.0, 0.0), spec)
    drive(world, 1.0, 0.0, 1.0)  # reach 1.5 m/s
    drive(world, 0.0, 0.5, 2.0)  # coast (the throttle holds the speed) with half lock
    speed = world.forklift.speed
    rate = speed * math.tan(0.5 * spec.max_steer) / spec.wheelbase
    start_heading = world.forklift.pose[2]
    drive(world, 0.0, 0.5, 1.0)
    assert world.forklift.pose[2] - start_heading == pytest.approx(rate * 1.0, rel=0.03)


def test_a_wall_stops_the_forklift_and_the_contact_is_recorded():
    wall = {"start": [5.0, -5.0], "end": [5.0, 5.0], "height": 4.0}
    world = World(open_floor(walls=[wall]), (0.0, 0.0, 0.0))
    drive(world, 1.0, 0.0, 6.0)
    x, _, _ = world.forklift.pose
    assert x < 5.0 - 0.5 * world.forklift.spec.length + 0.1  # never through the wall
    assert world.contacts and world.contacts[0].obstacle == ("wall", 0)
    assert abs(world.forklift.speed) < 0.2


ROUTES = [(name, route.name) for name in list_scenarios()
          for route in load_scenario(name).routes
          if not load_scenario(name).differential_drive]  # a robot's: tests/world/test_robot.py


def run_route(scenario_name, route_name, max_steps=40_000):
    scenario = load_scenario(scenario_name)
    route = next(r for r in scenario.routes if r.name == route_name)
    world = World(scenario, route.start_pose())
    driver = PurePursuit(route, world.forklift.spec)
    trajectory = []
    while not driver.done and world.steps < max_steps:
        x, y, heading = world.forklift.pose
        world.step(*driver.command(x, y, heading, world.forklift.speed))
        trajectory.append(world.forklift.pose)
    return scenario, route, world, driver, np.array(trajectory)


@pytest.mark.parametrize(("scenario_name", "route_name"), ROUTES)
def test_every_shipped_route_is_driven_to_its_end_without_touching_anything(scenario_name,
                                                                            route_name):
    scenario, route, world, driver, trajectory = run_route(scenario_name, route_name)
    assert driver.done
    assert world.contacts == []
    x_min, y_min, x_max, y_max = scenario.bounds
    assert (trajectory[:, 0] > x_min).all() and (trajectory[:, 0] < x_max).all()
    assert (trajectory[:, 1] > y_min).all() and (trajectory[:, 1] < y_max).all()
    reference = driver._reference(*world.forklift.pose)
    assert np.hypot(*(reference - route.waypoints[-1])) < 0.3


def test_the_same_route_gives_a_bit_identical_trajectory():
    scenario_name, route_name = ROUTES[1]
    first = run_route(scenario_name, route_name, max_steps=600)[4]
    again = run_route(scenario_name, route_name, max_steps=600)[4]
    assert np.array_equal(first, again)


@pytest.mark.parametrize(
    ("route", "message"),
    [
        ({"name": "r", "waypoints": [[0.0, -5.0], [0.0, 5.0]]},
         "routes[0].waypoints: leg 0 from (0, -5) to (0, 5) passes within 0.7 m of racks[0]"),
        ({"name": "r", "waypoints": [[0.0, -5.0], [30.0, -5.0]]},
         "routes[0].waypoints[1]: (30, -5) is outside the room"),
        ({"name": "r", "waypoints": [[-5.0, -5.0], [5.0, -5.0]], "reverse": [False, True]},
         "routes[0].reverse: must be a list of 1 booleans, one per leg"),
        ({"name": "r", "waypoints": [[-5.0, -5.0]]},
         "routes[0].waypoints: must be a list of at least 2 [x, y] points"),
        ({"name": "r", "waypoints": [[-5.0, -5.0], [5.0, -5.0]], "sped": 2.0},
         "routes[0]: unknown key 'sped'. Did you mean 'speed'?"),
    ],
)
def test_malformed_routes_are_reported(route, message):
    rack = {"center": [0.0, 0.0], "size": [4.0, 1.0], "height": 3.0}
    with pytest.raises(ScenarioError, match=re.escape(f"floor.toml: {message}")):
        open_floor(racks=[rack], routes=[route])


def test_duplicate_route_names_are_reported():
    route = {"name": "r", "waypoints": [[-5.0, -5.0], [5.0, -5.0]]}
    with pytest.raises(ScenarioError, match=re.escape("routes[1].name: duplicate route name")):
        open_floor(routes=[route, route])

"""A robot's scenario: the vehicle it declares, a forward camera, markers the map lacks."""

from __future__ import annotations

import math

import pytest

from azgym import ScenarioError
from azgym.profile import parse_profile, profile_toml
from azgym.site import load_scenario, parse_scenario


def arena(**tables):
    """A 4 m x 3 m arena of three landmarks, driven by a differential-drive robot."""
    data = {"name": "arena", "description": "a robot's arena", "version": 1,
            "room": {"bounds": [0.0, 0.0, 4.0, 3.0]},
            "vehicle": {"kind": "differential-drive", "camera_ahead": 0.1},
            "camera": {"height": 0.35, "min_elevation_deg": -30.0, "field_of_view_deg": 60.0,
                       "rate_hz": 5.0},
            "beacons": [{"id": 1, "xyz": [1.0, 1.0, 0.4]}, {"id": 2, "xyz": [3.0, 1.0, 0.4]},
                        {"id": 3, "xyz": [2.0, 2.5, 0.4]}],
            "routes": [{"name": "there", "waypoints": [[0.5, 0.5], [3.5, 0.5]], "speed": 0.3}]}
    data.update(tables)
    return data


def test_robot_arena_declares_its_vehicle_and_sensor_as_a_profile():
    scenario = load_scenario("robot-arena")
    profile = scenario.profile
    assert scenario.differential_drive
    assert (profile.vehicle.kind, profile.vehicle.camera_ahead) == ("differential-drive", 0.1)
    assert profile.sensor.field_of_view == pytest.approx(1.2, abs=1e-12)
    assert profile.sensor.delta_alpha_d == pytest.approx(math.radians(0.866))
    assert profile.sensor.coverage is False
    assert scenario.camera.rate_hz == 5.0
    assert len(scenario.beacons) == 15 and len(scenario.unmapped) == 3
    assert scenario.bounds == (0.0, 0.0, 8.0, 6.0)
    # What a log's manifest writes reads back as the same profile.
    problems = []
    assert parse_profile(profile_toml(profile), problems.append) == profile and not problems


def test_a_forklift_scenario_states_its_kind_and_a_camera_that_sees_all_round():
    profile = load_scenario("warehouse-small").profile
    assert profile.vehicle.kind == "forklift" and profile.vehicle.camera_ahead is None
    assert profile.sensor.field_of_view == 2 * math.pi


def test_the_parsed_arena_keeps_what_the_tables_say():
    scenario = parse_scenario(arena(unmapped=[{"id": 9, "xy": [0.0, 1.5]}]))
    assert scenario.vehicle.camera_ahead == 0.1
    assert scenario.camera.field_of_view == pytest.approx(math.radians(60.0))
    assert scenario.unmapped.ids.tolist() == [9]
    assert scenario.unmapped.xyz.tolist() == [[0.0, 1.5, 0.0]]
    assert parse_scenario(arena(vehicle={"kind": "differential-drive"})).vehicle.camera_ahead == 0


@pytest.mark.parametrize(("change", "message"), [
    ({"vehicle": {"kind": "tank"}}, "vehicle.kind: must be one of 'forklift', "
                                    "'differential-drive', got 'tank'"),
    ({"vehicle": {"kind": "forklift", "camera_ahead": 0.2}},
     "vehicle.camera_ahead: a forklift's camera sits where its model puts it"),
    ({"vehicle": {"kind": "differential-drive", "wheels": 2}}, "vehicle: unknown key 'wheels'"),
    ({"vehicle": {"kind": "differential-drive", "camera_ahead": 11.0}},
     "vehicle.camera_ahead: must be in [-10, 10]"),
    ({"routes": [{"name": "back", "waypoints": [[0.5, 0.5], [3.5, 0.5], [0.5, 0.5]],
                  "reverse": [False, True]}]},
     "routes[0].reverse[1]: a differential-drive robot drives its routes forwards"),
    ({"unmapped": [{"id": 2, "xy": [0.0, 1.0]}]},
     "unmapped[0].id: 2 is a map beacon's id (beacons[1])"),
    ({"unmapped": [{"id": 7, "xy": [0.0, 1.0]}, {"id": 7, "xy": [4.0, 1.0]}]},
     "unmapped[1].id: duplicate id 7"),
    ({"unmapped": [{"id": 7, "xy": [9.0, 1.0]}]}, "unmapped[0].xy: beacon 7 at (9, 1) is outside"),
    ({"unmapped": [{"id": 7, "xy": [1.0, 1.0], "moved_to": [2.0, 1.0]}]},
     "unmapped[0]: unknown key 'moved_to'"),
    ({"unmapped": {"id": 7}}, "unmapped: must be an array of [[unmapped]] tables"),
    ({"camera": {"field_of_view_deg": 361.0}}, "camera.field_of_view_deg: must be in (0, 360]"),
    ({"camera": {"field_of_view_deg": 0.0}}, "camera.field_of_view_deg: must be > 0"),
    ({"camera": {"rate_hz": 5000.0}}, "camera.rate_hz: must be from 0.1 to 1000 [Hz]"),
])
def test_a_bad_vehicle_camera_or_marker_is_named(change, message):
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(arena(**change), "arena.toml")
    assert f"arena.toml: {message}" in str(caught.value)


def test_an_unmapped_marker_inside_a_rack_is_named():
    racks = [{"center": [2.0, 1.5], "size": [0.4, 0.4], "height": 1.0}]
    with pytest.raises(ScenarioError, match=r"unmapped\[0\]: beacon 7 at \(2, 1.5\) is inside "
                                            r"racks\[0\]"):
        parse_scenario(arena(racks=racks, routes=[],
                             unmapped=[{"id": 7, "xy": [2.0, 1.5]}]))

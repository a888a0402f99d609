"""Hostile scenario files: each is refused with a short ScenarioError naming file and field.

The corpus in ``scenarios/`` holds small files a careless or malicious author could write (a
beacon outside the room, a route through a wall, ``coverage = "no"``, a 400-digit id, a
200000 x 200000 fisheye image, invalid UTF-8, ...), each pinned to its message; files too big to
commit (more than the size limit, 5000 nested arrays, too many tables or legs) are made here.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from azgym import ScenarioError
from azgym.site import load_scenario, parse_scenario
from azgym.site.load import MAX_FILE_BYTES
from azgym.site.parse_layout import MAX_LEG_PAIRS
from azgym.site.reader import MAX_ENTRIES

CORPUS = Path(__file__).parent / "scenarios"
EXPECTED = {
    "01-beacon-outside-room.toml":
        "beacons[1].xy: beacon 2 at (500, 0) is outside the room [0, 10] x [0, 10] (by more "
        "than 0.05 m)",
    "02-beacon-just-past-the-wall.toml":
        "beacons[2].xy: beacon 3 at (0, 10.2) is outside the room [0, 10] x [0, 10]",
    "03-moved-beacon-outside-room.toml":
        "beacons[0].moved_to: beacon 1 at (-3, 4) is outside the room",
    "04-beacon-south-of-the-room.toml":
        "beacons[1].xyz: beacon 2 at (10, -20) is outside the room",
    "05-route-through-wall.toml":
        "routes[0].waypoints: leg 1 from (3, 5) to (8, 5) crosses walls[0] (route 'ghost')",
    "06-route-grazes-wall.toml":
        "routes[0].waypoints: leg 0 from (2, 1.5) to (8, 1.5) passes within 0.7 m of walls[0] "
        "(route 'scrape')",
    "07-route-into-wall-end.toml":
        "routes[0].waypoints: leg 1 from (4, 8) to (8, 5) passes within 0.7 m of walls[0] "
        "(route 'corner')",
    "08-negative-beacon-id.toml":
        "beacons[1].id: must be >= 0 (-1 marks an empty slot in observations), got -1",
    "09-boolean-beacon-id.toml": "beacons[1].id: must be an integer in [0, 2147483647], got True",
    "10-400-digit-beacon-id.toml":
        "beacons[1].id: must be an integer in [0, 2147483647], got 9999999999...99999999999",
    "11-coverage-no.toml": "error_model.coverage: must be true or false, got 'no'",
    "12-coverage-zero.toml": "error_model.coverage: must be true or false, got 0",
    "13-reverse-yes.toml": "routes[0].reverse[0]: must be true or false, got 'yes'",
    "14-400-digit-width.toml":
        "beacon_defaults.width: must be <= 100000, got 9999999999...99999999999",
    "15-huge-float-bound.toml": "room.bounds[2]: must be in [-100000, 100000], got 1e+300",
    "16-infinite-camera-range.toml": "camera.max_range: must be a finite number, got inf",
    "17-nan-rack-height.toml": "racks[0].height: must be a finite number, got nan",
    "18-negative-wall-height.toml": "walls[0].height: must be > 0, got -3.0",
    "19-negative-bump-size.toml":
        "bumps[0].size: must be positive [length, depth], got [-1.0, 1.0]",
    "20-huge-fisheye-image.toml":
        "fisheye.image_size[0]: must be an integer in [1, 4096], got 200000",
    "21-boolean-image-size.toml":
        "fisheye.image_size[0]: must be an integer in [1, 4096], got True",
    "22-huge-version.toml":
        "version: must be an integer in [1, 2147483647], got 99999999999999999999",
    "23-speeding-route.toml": "routes[0].speed: must be <= 20, got 300.0",
    "24-rack-turned-1e9-degrees.toml":
        "racks[0].angle_deg: must be in [-360, 360], got 1000000000.0",
    "25-light-power-1e30.toml": "lights[0].power: must be <= 100000, got 1e+30",
    "26-escape-in-description.toml":
        r"description: must be one line of printable characters, got 'clear screen \x1b[2J'",
    "27-huge-text-name.toml": "name: must be at most 1000 characters, got 1001",
    "28-long-unknown-key.toml": f"unknown key '{'k' * 37}...'. Valid keys: beacon_defaults,",
    "29-nested-bounds.toml": "room.bounds: must be a list of 4 numbers, got [[[...]]]",
    "30-datetime-version.toml":
        "version: must be an integer in [1, 2147483647], got datetime.date(1979, 5, 27)",
    "31-invalid-utf8.toml": "not UTF-8 text: byte 0xe9 at offset 35",
}
LONGEST_MESSAGE = 400
"""No message is longer [characters], whatever the file holds."""


def test_the_corpus_is_complete():
    assert sorted(path.name for path in CORPUS.glob("*.toml")) == sorted(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_every_hostile_file_is_refused_with_its_own_short_message(name):
    path = CORPUS / name
    with pytest.raises(ScenarioError, match=re.escape(f"{path}: {EXPECTED[name]}")) as info:
        load_scenario(path)
    assert len(str(info.value)) - len(str(path)) <= LONGEST_MESSAGE


def write(tmp_path: Path, data: bytes | str) -> Path:
    path = tmp_path / "made.toml"
    if isinstance(data, str):
        data = data.encode("utf-8")
    path.write_bytes(data)
    return path


VALID = """\
name = "made"
description = "a valid base for the files made here"
version = 1
[room]
bounds = [0.0, 0.0, 10.0, 10.0]
[[beacons]]
id = 1
xy = [0.0, 0.0]
[[beacons]]
id = 2
xy = [10.0, 0.0]
[[beacons]]
id = 3
xy = [0.0, 10.0]
"""


def test_the_base_of_the_made_files_loads(tmp_path):
    assert load_scenario(write(tmp_path, VALID)).name == "made"


def test_a_file_past_the_size_limit_is_refused_unread(tmp_path):
    padding = "# " + "x" * 1000 + "\n"
    path = write(tmp_path, VALID + padding * (MAX_FILE_BYTES // len(padding) + 1))
    with pytest.raises(ScenarioError, match=re.escape(
            f"{path}: too large: a scenario file has at most {MAX_FILE_BYTES} bytes")):
        load_scenario(path)


def test_5000_nested_arrays_are_a_scenario_error_not_a_recursion_error(tmp_path):
    path = write(tmp_path, VALID + "deep = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(ScenarioError, match=re.escape(
            f"{path}: not valid TOML: arrays or tables nested too deeply")):
        load_scenario(path)


@pytest.mark.parametrize("value", ["[" + ", ".join(["1.0"] * 100_000) + "]",
                                   "[" * 200 + "]" * 200, '"' + "y" * 100_000 + '"'])
def test_a_huge_or_deep_value_makes_a_short_message(tmp_path, value):
    path = write(tmp_path, VALID.replace("bounds = [0.0, 0.0, 10.0, 10.0]", f"bounds = {value}"))
    with pytest.raises(ScenarioError, match=re.escape(f"{path}: room.bounds: must be a list of 4 "
                                                      "numbers, got ")) as info:
        load_scenario(path)
    assert len(str(info.value)) - len(str(path)) <= LONGEST_MESSAGE


def made_data(**tables) -> dict:
    """A valid 10 m x 10 m scenario's data (three beacons), with the given tables added."""
    return {"name": "made", "description": "made", "version": 1,
            "room": {"bounds": [0.0, 0.0, 10.0, 10.0]},
            "beacons": [{"id": k, "xy": [float(k), 0.0]} for k in range(3)], **tables}


def test_an_array_of_too_many_tables_is_refused_before_they_are_read():
    walls = [{"start": [0.0, 0.0], "end": [1.0, 0.0], "height": 1.0}] * (MAX_ENTRIES + 1)
    with pytest.raises(ScenarioError, match=re.escape(
            f"made.toml: walls: must have at most {MAX_ENTRIES} entries, got {MAX_ENTRIES + 1}")):
        parse_scenario(made_data(walls=walls), "made.toml")


def test_routes_that_would_take_long_to_check_against_the_racks_are_refused():
    # Every (leg, rack) pair counts, whether their boxes meet or not: a crafted file whose legs
    # all came near the racks would have each pair measured exactly, for minutes.
    racks = [{"center": [9.0, 9.0], "size": [0.1, 0.1], "height": 1.0}] * 500
    legs = MAX_LEG_PAIRS // len(racks) + 1
    route = {"name": "long", "waypoints": [[1.0, 1.0], [8.0, 1.5]] * (legs // 2 + 1)}
    with pytest.raises(ScenarioError, match=re.escape(
            "made.toml: routes[0].waypoints: too many legs to check against 500 racks and 0 "
            f"walls: a scenario's routes may make at most {MAX_LEG_PAIRS} (leg, rack or wall) "
            "pairs")):
        parse_scenario(made_data(racks=racks, routes=[route]), "made.toml")

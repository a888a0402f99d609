"""Scenario files: the shipped paper room, and errors that name the file and the field."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import azgym
from azgym import ScenarioError, UnknownNameError
from azgym.site import load_scenario, parse_scenario

THIRD = 22.0 / 3.0
# docs/paper-room.md: counter-clockwise from the east wall, three a wall at −22/3, 0, +22/3 m.
PAPER_XY = {
    1: (11.0, -THIRD), 2: (11.0, 0.0), 3: (11.0, THIRD),
    4: (THIRD, 11.0), 5: (0.0, 11.0), 6: (-THIRD, 11.0),
    7: (-11.0, THIRD), 8: (-11.0, 0.0), 9: (-11.0, -THIRD),
    10: (-THIRD, -11.0), 11: (0.0, -11.0), 12: (THIRD, -11.0),
}


def test_paper_room_is_listed_and_loads(paper_room):
    assert "paper-room" in azgym.list_scenarios()
    assert paper_room.name == "paper-room"
    assert paper_room.version >= 1
    assert paper_room.description
    assert paper_room.bounds == (-11.0, -11.0, 11.0, 11.0)


def test_paper_room_beacons_are_at_the_design_positions(paper_beacons):
    assert sorted(paper_beacons.ids.tolist()) == list(range(1, 13))
    for beacon_id, (x, y) in PAPER_XY.items():
        row = paper_beacons.index_of(beacon_id)
        assert paper_beacons.xy[row] == pytest.approx([x, y], abs=1e-12), beacon_id
    assert (paper_beacons.width == 0.03).all()
    assert (paper_beacons.xyz[:, 2] == 2.5).all()


def test_paper_room_wall_centres_and_the_circle(paper_beacons):
    radius = dict(zip(paper_beacons.ids.tolist(), np.hypot(*paper_beacons.xy.T), strict=True))
    for wall_centre in (2, 5, 8, 11):
        assert radius[wall_centre] == pytest.approx(11.0, abs=1e-12)
    # sqrt(11² + (22/3)²) = sqrt(1573/9) = 13.2204...
    for on_circle in (1, 3, 4, 6, 7, 9, 10, 12):
        assert radius[on_circle] == pytest.approx(math.sqrt(1573.0) / 3.0, abs=1e-12)
        assert radius[on_circle] == pytest.approx(13.22, abs=5e-3)


def test_paper_room_is_numbered_counter_clockwise_from_east(paper_beacons):
    order = np.argsort(paper_beacons.ids)
    bearing = np.unwrap(np.arctan2(paper_beacons.xy[order, 1], paper_beacons.xy[order, 0]))
    assert (np.diff(bearing) > 0).all()
    assert bearing[-1] - bearing[0] < 2 * math.pi
    assert bearing[1] == pytest.approx(0.0, abs=1e-12)  # B2 faces due east


def test_paper_room_error_model(paper_room):
    assert paper_room.error_model.delta_alpha_d == pytest.approx(math.radians(0.4), rel=1e-12)
    assert paper_room.error_model.coverage is True


def test_loading_a_scenario_object_returns_it(paper_room):
    assert azgym.load_scenario(paper_room) is paper_room


def test_unknown_scenario_suggests_the_closest_name():
    with pytest.raises(UnknownNameError, match=re.escape("Did you mean 'paper-room'?")):
        azgym.load_scenario("paper-rom")


def test_unknown_scenario_lists_the_valid_names():
    with pytest.raises(UnknownNameError, match=re.escape("paper-room")) as info:
        azgym.load_scenario("zzzzzz")
    assert "Did you mean" not in str(info.value)
    assert isinstance(info.value, KeyError)


def test_missing_scenario_file_is_reported(tmp_path):
    with pytest.raises(ScenarioError, match=re.escape("no such scenario file")):
        azgym.load_scenario(tmp_path / "nothing-here.toml")


# --------------------------------------------------------------------------- user files

VALID = """\
name = "tiny"
description = "three beacons in a small room"
version = 2

[room]
bounds = [-5.0, -4.0, 5.0, 4.0]

[error_model]
delta_alpha_d_deg = 0.5
coverage = false

[beacon_defaults]
width = 0.05
z = 2.0

[[beacons]]
id = 10
xy = [5.0, 0.0]

[[beacons]]
id = 20
xyz = [0.0, 4.0, 3.0]
width = 0.1

[[beacons]]
id = 30
xy = [-5.0, 0.0]
z = 1.0
"""


def write(tmp_path, text: str, name: str = "tiny.toml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_valid_user_file_loads_with_defaults_and_overrides(tmp_path):
    path = write(tmp_path, VALID)
    scenario = azgym.load_scenario(path)
    assert scenario.name == "tiny"
    assert scenario.version == 2
    assert scenario.source == path
    assert scenario.bounds == (-5.0, -4.0, 5.0, 4.0)
    assert scenario.beacons.ids.tolist() == [10, 20, 30]
    assert scenario.beacons.xyz.tolist() == [[5.0, 0.0, 2.0], [0.0, 4.0, 3.0], [-5.0, 0.0, 1.0]]
    assert scenario.beacons.width.tolist() == [0.05, 0.1, 0.05]
    assert scenario.error_model.delta_alpha_d == pytest.approx(math.radians(0.5))
    assert scenario.error_model.coverage is False
    # A path given as a string works too.
    assert azgym.load_scenario(str(path)).name == "tiny"


def test_error_model_from_camera_pixels(tmp_path):
    text = VALID.replace("delta_alpha_d_deg = 0.5",
                         "center_error_px = 1.0\nhorizon_radius_px = 150")
    scenario = azgym.load_scenario(write(tmp_path, text))
    assert scenario.error_model.delta_alpha_d == pytest.approx(math.atan2(1.0, 150.0))


def drop_line(text: str, line: str) -> str:
    assert line + "\n" in text
    return text.replace(line + "\n", "", 1)


MALFORMED = [
    pytest.param(drop_line(VALID, 'name = "tiny"'), "name: missing", id="missing-name"),
    pytest.param(VALID.replace("version = 2", "versoin = 2"),
                 "unknown key 'versoin'. Did you mean 'version'?", id="unknown-top-key"),
    pytest.param(VALID.replace("z = 1.0", "wdith = 1.0"),
                 "beacons[2]: unknown key 'wdith'. Did you mean 'width'?", id="unknown-beacon-key"),
    pytest.param(VALID.replace("coverage = false", "coverge = false"),
                 "error_model: unknown key 'coverge'. Did you mean 'coverage'?",
                 id="unknown-error-model-key"),
    pytest.param(VALID.replace("id = 30", "id = 10"),
                 "beacons[2].id: duplicate id 10 (also beacons[0])", id="duplicate-id"),
    pytest.param(VALID.replace("width = 0.1", "width = -0.01"), "beacons[1].width: must be > 0",
                 id="negative-width"),
    pytest.param(VALID.replace("width = 0.1", "width = 0"), "beacons[1].width: must be > 0",
                 id="zero-width"),
    pytest.param(VALID.replace("width = 0.05", "width = 0.0"), "beacon_defaults.width: must be > 0",
                 id="zero-default-width"),
    pytest.param(VALID.split("[[beacons]]\nid = 30")[0], "beacons: must be an array of at least 3",
                 id="two-beacons"),
    pytest.param(VALID.replace("[-5.0, -4.0, 5.0, 4.0]", "[5.0, -4.0, -5.0, 4.0]"),
                 "room.bounds: must be [x_min, y_min, x_max, y_max] with max > min",
                 id="bounds-inverted"),
    pytest.param(VALID.replace("[-5.0, -4.0, 5.0, 4.0]", "[-5.0, -4.0, 5.0]"),
                 "room.bounds: must be a list of 4 numbers", id="bounds-short"),
    pytest.param(VALID.replace("[-5.0, -4.0, 5.0, 4.0]", '[-5.0, -4.0, "5", 4.0]'),
                 "room.bounds[2]: must be a finite number", id="bounds-text"),
    pytest.param(VALID.replace("[-5.0, -4.0, 5.0, 4.0]", "[-5.0, -4.0, inf, 4.0]"),
                 "room.bounds[2]: must be a finite number", id="bounds-inf"),
    pytest.param(VALID.replace("xy = [5.0, 0.0]", "xy = [5.0, 0.0]\nxyz = [5.0, 0.0, 1.0]"),
                 "beacons[0].xy: give exactly one of xy", id="both-xy-and-xyz"),
    pytest.param(VALID.replace("xy = [5.0, 0.0]\n", ""),
                 "beacons[0].xy: give exactly one of xy", id="neither-xy-nor-xyz"),
    pytest.param(VALID.replace("width = 0.1", "width = 0.1\nz = 1.0"),
                 "beacons[1].z: z is already given by xyz", id="xyz-and-z"),
    pytest.param(VALID.replace("id = 20", 'id = "20"'), "beacons[1].id: must be an integer",
                 id="text-id"),
    pytest.param(VALID.replace("id = 20", "id = 2.5"), "beacons[1].id: must be an integer",
                 id="float-id"),
    pytest.param(VALID.replace("version = 2", "version = 0"),
                 "version: must be an integer in [1, 2147483647], got 0",
                 id="version-zero"),
    pytest.param(VALID.replace("delta_alpha_d_deg = 0.5", "delta_alpha_d_deg = 95"),
                 "error_model.delta_alpha_d_deg: must be in [0, 90)", id="huge-delta"),
    pytest.param(VALID.replace("delta_alpha_d_deg = 0.5",
                               "delta_alpha_d_deg = 0.5\ncenter_error_px = 1.0"),
                 "error_model.delta_alpha_d_deg: give either", id="two-error-models"),
    pytest.param(VALID.replace("coverage = false", 'coverage = "no"'),
                 "error_model.coverage: must be true or false", id="coverage-text"),
    pytest.param(VALID.replace('name = "tiny"', 'name = "  "'), "name: must be a non-empty string",
                 id="blank-name"),
    pytest.param(VALID.replace("[room]\nbounds = [-5.0, -4.0, 5.0, 4.0]\n", ""), "room: missing",
                 id="missing-room"),
    pytest.param(VALID.replace("version = 2", "version = true"),
                 "version: must be an integer in [1, 2147483647], got True", id="version-boolean"),
    pytest.param(VALID.replace("version = 2", "version = 2\nfaults = 0.5"),
                 "faults: must be a table", id="faults-not-a-table"),
    pytest.param(VALID + "\n[faults]\nmisdecode_rate = 1.5\n",
                 "faults.misdecode_rate: must be in [0, 1], got 1.5", id="rate-above-one"),
    pytest.param(VALID + "\n[[racks]]\ncenter = [0.0, -2.0]\nsize = [1.0, 1.0]\nheight = 2.0\n"
                 "reflectivity = -0.5\n", "racks[0].reflectivity: must be in [0, 1], got -0.5",
                 id="negative-reflectivity"),
    pytest.param(VALID + "\n[[bumps]]\ncenter = [0.0, -2.0]\nsize = [1.0, 1.0]\ntilt_deg = 50\n",
                 "bumps[0].tilt_deg: must be in [0, 45), got 50", id="steep-bump"),
]


PLAIN_NAME = ("must be a plain file name (ASCII letters, digits, '-', '_' and '.', starting with "
              "a letter or a digit, at most 100 characters), got ")


@pytest.mark.parametrize("name", ["/tmp/attack/ABS", "../../up", "a/b", "a\\b", "..", ".hidden",
                                  "-option", "two words", "é", "x" * 101])
def test_a_name_that_is_not_a_plain_file_name_is_refused(tmp_path, name):
    """Output files are named after the scenario: a separator or ``..`` would write elsewhere."""
    path = write(tmp_path, VALID.replace('name = "tiny"', f"name = {name!r}".replace("'", '"')))
    with pytest.raises(ScenarioError, match=re.escape(f"{path}: name: {PLAIN_NAME}")):
        azgym.load_scenario(path)


@pytest.mark.parametrize("name", ["tiny", "hall-b-2026-03-04", "warehouse_small.v2", "A-B-C-D",
                                  "x" * 100])
def test_plain_names_pass(tmp_path, name):
    path = write(tmp_path, VALID.replace('name = "tiny"', f'name = "{name}"'))
    assert azgym.load_scenario(path).name == name


def test_every_shipped_scenario_has_a_plain_name():
    assert all(azgym.load_scenario(name).name == name for name in azgym.list_scenarios())


@pytest.mark.parametrize(("text", "message"), MALFORMED)
def test_malformed_file_names_file_and_field(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(ScenarioError, match=re.escape(f"{path}: {message}")):
        azgym.load_scenario(path)


def test_bad_toml_syntax_names_the_file(tmp_path):
    path = write(tmp_path, VALID.replace('name = "tiny"', 'name = "tiny'))
    with pytest.raises(ScenarioError, match=re.escape(f"{path}: not valid TOML")):
        azgym.load_scenario(path)


def test_scenario_error_is_a_value_error(tmp_path):
    with pytest.raises(ValueError):
        azgym.load_scenario(write(tmp_path, drop_line(VALID, 'name = "tiny"')))


def test_parse_scenario_uses_the_given_origin():
    with pytest.raises(ScenarioError, match=re.escape("memory.toml: name: missing")):
        parse_scenario({}, "memory.toml")


BROKEN = Path(__file__).parent / "data" / "broken"
EXPECTED_PROBLEMS = {
    "01-missing-name.toml": "name: missing",
    "02-unknown-room-key.toml": "room: unknown key 'colour'",
    "03-duplicate-id.toml": "beacons[3].id: duplicate id 2 (also beacons[1])",
    "04-beacon-inside-rack.toml": "beacons[3]: beacon 4 at (5, 5) is inside racks[0]",
    "05-negative-rack-size.toml": "racks[0].size: must be positive",
    "06-route-through-rack.toml": "routes[0].waypoints: leg 0 from (5, 1) to (5, 9) passes within "
                                  "0.7 m of racks[0] (route 'through')",
    "07-inverted-bounds.toml": "room.bounds: must be [x_min, y_min, x_max, y_max] with max > min",
    "08-two-beacons.toml": "beacons: must be an array of at least 3",
    "09-zero-width.toml": "beacons[0].width: must be > 0",
    "10-reflectivity-above-one.toml": "walls[0].reflectivity: must be in [0, 1]",
    "11-camera-typo.toml": "camera: unknown key 'heigth'. Did you mean 'height'?",
    "12-conflicting-error-model.toml": "error_model.delta_alpha_d_deg: give either",
    "13-not-toml.toml": "not valid TOML",
    "14-route-leaves-room.toml": "routes[0].waypoints[1]: (15, 5) is outside the room",
    "15-negative-misdecode-rate.toml": "faults.misdecode_rate: must be in [0, 1]",
    "16-light-without-height.toml": "lights[0].xyz: must be a list of 3 numbers",
    "17-light-without-power.toml": "lights[0].power: must be > 0",
}


def test_the_broken_corpus_is_complete():
    assert sorted(path.name for path in BROKEN.glob("*.toml")) == sorted(EXPECTED_PROBLEMS)


@pytest.mark.parametrize("name", sorted(EXPECTED_PROBLEMS))
def test_every_broken_scenario_file_gets_its_own_clear_error(name):
    path = BROKEN / name
    with pytest.raises(ScenarioError, match=re.escape(f"{path}: {EXPECTED_PROBLEMS[name]}")):
        load_scenario(path)

"""Generated warehouses: the same seed gives the same site, every seed a valid and drivable one.

A learned localizer trains on these and is scored on held-out seeds, so a seed must mean one
site bit for bit (its TOML text too), seeds must differ, every site must pass the checks a
scenario file passes (it is built by the parser), its routes must be drivable without touching a
rack or a wall, and its camera must see enough beacons to localize from most of the floor.
"""

from __future__ import annotations

import math
import subprocess
import sys
import tomllib

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from azgym import InvalidInputError, ScenarioError
from azgym.cli import main
from azgym.site import Scenario, generate, load_scenario, parse_scenario
from azgym.site.elements import ROUTE_CLEARANCE, leg_hits_rack
from azgym.site.generator import SIDE, generate_data, generate_toml, write_generated
from azgym.site.generator_layout import AISLE
from azgym.site.toml_writer import to_toml


def same_scenario(a: Scenario, b: Scenario) -> bool:
    """Field by field, arrays by value (``Scenario.__eq__`` cannot compare arrays or routes)."""
    def plain(scenario: Scenario) -> dict:
        fields = {k: v for k, v in scenario.__dict__.items() if k not in ("source", "routes")}
        fields["beacons"] = (scenario.beacons.ids.tolist(), scenario.beacons.xyz.tolist(),
                             scenario.beacons.width.tolist())
        fields["physical_xyz"] = scenario.beacon_positions.tolist()
        fields["routes"] = [(r.name, r.waypoints.tolist(), r.reverse, r.speed)
                            for r in scenario.routes]
        return fields

    return plain(a) == plain(b)


def test_the_same_seed_gives_the_same_site_bit_for_bit():
    assert same_scenario(generate(7), generate(7))
    assert generate_toml(7) == generate_toml(7)
    assert generate_data(7) == generate_data(7)


def test_different_seeds_give_different_sites():
    texts = {generate_toml(seed).split("\n", 3)[3] for seed in range(20)}  # past the header
    assert len(texts) == 20


def test_sites_vary_over_seeds_within_the_documented_ranges():
    sites = [generate(seed) for seed in range(50)]
    sides = np.array([s.bounds[2:] for s in sites])
    racks = [len(s.racks) for s in sites]
    beacons = [len(s.beacons) for s in sites]
    assert (sides >= SIDE[0]).all() and (sides <= SIDE[1]).all()
    assert np.ptp(sides) > 30 and len(set(racks)) > 8 and len(set(beacons)) > 15
    heights = [rack.height for s in sites for rack in s.racks]
    assert min(heights) >= 2.0 and max(heights) <= 8.0 and np.ptp(heights) >= 5.0
    assert any(rack.reflectivity > 0 for s in sites for rack in s.racks)
    assert any(wall.reflectivity > 0 for s in sites for wall in s.walls)
    assert 10 < sum(s.physical_xyz is not None for s in sites) < 40  # a moved beacon: half
    assert len({s.racks[0].size[0] > s.racks[0].size[1] for s in sites}) == 2  # both ways
    assert all(s.lights and s.faults.misdecode_rate <= 0.02 for s in sites)


@given(st.integers(min_value=0, max_value=2**63))
def test_every_seed_makes_a_valid_site_whose_file_reads_back_the_same(seed):
    data = generate_data(seed)
    text = generate_toml(seed)
    assert tomllib.loads(text) == data
    assert same_scenario(parse_scenario(tomllib.loads(text)), generate(seed))


def test_two_hundred_seeds_are_valid_and_keep_their_routes_in_the_aisles():
    for seed in range(200):
        scenario = generate(seed)
        assert {r.name for r in scenario.routes} == {"perimeter", "serpentine", "cross-aisle",
                                                     "pick-and-back"}
        for route in scenario.routes:  # half an aisle off every rack, above the file's rule
            for start, end in zip(route.waypoints[:-1], route.waypoints[1:], strict=True):
                assert not any(leg_hits_rack(start, end, rack, AISLE[0] / 2 - 0.01)
                               for rack in scenario.racks)
        assert AISLE[0] / 2 > ROUTE_CLEARANCE


def test_a_given_size_is_kept_and_the_seed_still_decides_the_rest():
    scenario = generate(3, size=(20.0, 45.5))
    assert scenario.bounds == (0.0, 0.0, 20.0, 45.5)
    assert same_scenario(generate(3, size=np.array([20, 45.5])), scenario)
    assert not same_scenario(scenario, generate(4, size=(20.0, 45.5)))


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"seed": -1}, r"seed must be an integer >= 0, got -1"),
    ({"seed": 1.5}, r"seed must be an integer >= 0"),
    ({"seed": True}, r"seed must be an integer >= 0"),
    ({"seed": 1, "size": (5.0, 30.0)}, r"size must be two sides .* from 15 to 100 m"),
    ({"seed": 1, "size": (30.0, 1e9)}, r"size must be two sides"),
    ({"seed": 1, "size": (30.0, math.nan)}, r"size must be two sides"),
    ({"seed": 1, "size": 30.0}, r"size must be two sides"),
    ({"seed": 1, "size": (30.0, 30.0, 30.0)}, r"size must be two sides"),
    ({"seed": 1, "name": "two\nlines"}, r"name must be a plain file name"),
    ({"seed": 1, "name": "../up"}, r"name must be a plain file name .*, got '../up'"),
])
def test_bad_arguments_are_refused_by_name(kwargs, message):
    with pytest.raises(InvalidInputError, match=message):
        generate(**kwargs)


def test_the_file_written_loads_back_to_the_same_site_named_after_it(tmp_path):
    path = tmp_path / "site" / "hall-7.toml"
    loaded = write_generated(path, 7)
    assert loaded.name == "hall-7" and loaded.source == path
    assert same_scenario(loaded, generate(7, name="hall-7"))
    assert same_scenario(load_scenario(path), loaded)
    with pytest.raises(InvalidInputError, match=r"path must name a \.toml file"):
        write_generated(tmp_path / "hall.txt", 7)


def test_the_command_writes_the_file_and_refuses_a_bad_seed(tmp_path, capsys):
    path = tmp_path / "g.toml"
    assert main(["generate", "--seed", "11", "--out", str(path), "--size", "20", "30"]) == 0
    assert "loads back to the same scenario" in capsys.readouterr().out
    assert same_scenario(load_scenario(path), generate(11, size=(20, 30), name="g"))
    assert main(["generate", "--seed", "-3", "--out", str(path)]) == 2
    assert "seed must be an integer >= 0" in capsys.readouterr().err


def test_the_writer_round_trips_odd_text_and_refuses_what_toml_cannot_hold():
    data = {"name": 'quote " back\\slash é \x7f', "x": 0.1 + 0.2, "tiny": 1e-300,
            "room": {"bounds": [0.0, -0.0, 1e5, 3]}, "beacons": [{"id": 1, "xy": [1.0, 2.0]}],
            "routes": [{"waypoints": [[0.0, 1.0], [2.0, 3.0]], "reverse": [True]}]}
    assert tomllib.loads(to_toml(data, "a comment\nof two lines")) == data
    with pytest.raises(InvalidInputError, match=r"room\.bounds\[0\]: must be finite"):
        to_toml({"room": {"bounds": [math.inf, 0.0]}})
    with pytest.raises(InvalidInputError, match=r"x: cannot be written as TOML: NoneType"):
        to_toml({"x": None})


def test_an_invalid_site_is_never_written(monkeypatch, tmp_path):
    """A generator bug that breaks a rule fails in the parser, naming the field, before writing."""
    import azgym.site.generator as generator

    monkeypatch.setattr(generator, "beacons_data", lambda plan, rng: [{"id": 1, "xy": [1.0, 1.0]}])
    with pytest.raises(ScenarioError, match=r"beacons: must be an array of at least 3"):
        write_generated(tmp_path / "bad.toml", 1)
    assert not (tmp_path / "bad.toml").exists()


def test_the_camera_sees_three_beacons_from_most_of_the_free_floor():
    from azgym.sensing.geometry.sensor import GeometrySensor
    from azgym.sensing.labels import DIRECT, MOVED, PARTIAL
    from azgym.site.sampling import random_free_pose

    shares = []
    for seed in range(8):
        scenario = generate(seed)
        sensor = GeometrySensor(scenario)
        sensor.reset(seed)
        rng = np.random.default_rng(seed)
        seen = [np.isin(sensor.observe(random_free_pose(scenario, rng), rng).truth.label,
                        [DIRECT, PARTIAL, MOVED]).sum() for _ in range(100)]
        shares.append(np.mean(np.array(seen) >= 3))
    assert np.mean(shares) >= 0.85 and min(shares) >= 0.6  # the shipped warehouses: 0.86-0.95


def drive_every_route(seed: int) -> None:
    from azgym.world.drive import simulate

    scenario = generate(seed)
    for route in scenario.routes:
        frames = list(simulate(scenario, route, seed))
        assert sum(frame.contacts for frame in frames) == 0, route.name
        assert frames[-1].time < 600.0  # stopped at its end, not at the time limit
        assert math.dist(frames[-1].pose[:2], route.waypoints[-1]) < 1.0, route.name


@pytest.mark.parametrize("seed", [1, 5])
def test_every_route_is_driven_to_its_end_without_a_collision(seed):
    """Seeds 1 and 5 back out of an aisle into an end aisle: the tail must stop off the wall."""
    drive_every_route(seed)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(100, 120))
def test_every_route_of_more_seeds_is_driven_without_a_collision(seed):
    drive_every_route(seed)


def test_generate_is_public_and_loads_no_heavy_library():
    code = ("import sys, azgym.site; azgym.site.generate(1); print(sorted(m for m in ('pymunk', "
            "'numba', 'scipy', 'cv2', 'gymnasium') if m in sys.modules))")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip() == "[]"

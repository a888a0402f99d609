"""Candidate places, the placement search, and the scenario file it writes."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import azgym
from azgym.errors import InvalidInputError
from azgym.placement.analysis import predict
from azgym.placement.candidates import MIN_SEPARATION, candidate_places
from azgym.placement.floor import floor_grid
from azgym.placement.objective import objective
from azgym.placement.optimize import MAX_ADD, check_add, place_beacons
from azgym.placement.scenario_file import with_new_beacons, write_scenario


@pytest.fixture(scope="module")
def warehouse():
    return azgym.load_scenario("warehouse-small")


def test_candidates_hang_on_walls_and_rack_ends_apart_from_the_beacons(warehouse):
    candidates = candidate_places(warehouse, 2.0)
    xy = candidates.xyz[:, :2]
    on_wall = (np.isclose(xy[:, 0], 0) | np.isclose(xy[:, 0], 30) | np.isclose(xy[:, 1], 0)
               | np.isclose(xy[:, 1], 20))
    kinds = np.array(candidates.kind)
    assert on_wall[kinds == "wall"].all() and not on_wall[kinds == "rack end"].any()
    assert (kinds == "rack end").sum() >= 8
    for rack in warehouse.racks:
        assert not rack.contains(xy[:, 0], xy[:, 1]).any()
    gaps = np.hypot(*(xy[:, None, :] - warehouse.beacons.xy[None, :, :]).transpose(2, 0, 1))
    assert gaps.min() >= MIN_SEPARATION
    # Rack-end places hang over their rack's top, so the aisles on both sides see them.
    tops = {round(rack.center[1], 3): rack.height for rack in warehouse.racks}
    for _x, y, z in candidates.xyz[kinds == "rack end"]:
        assert z > tops[round(y, 3)]


def test_a_bad_spacing_or_count_is_refused_by_name(warehouse):
    with pytest.raises(InvalidInputError, match="spacing must be > 0 m"):
        candidate_places(warehouse, 0.0)
    with pytest.raises(InvalidInputError, match="candidate places; use a larger spacing"):
        candidate_places(warehouse, 1e-3)
    candidates = candidate_places(warehouse, 2.0)
    for add in (0, -2, 1.5, True):
        with pytest.raises(InvalidInputError, match="add must be an integer >= 1"):
            check_add(add, candidates)
    with pytest.raises(InvalidInputError, match=f"add must be at most {len(candidates)} .*"
                       f"one run places is {MAX_ADD}.*got 1000000"):
        check_add(10**6, candidates)


def test_placing_beacons_lowers_the_p95_and_raises_sigma_nowhere(paper_room):
    floor = floor_grid(paper_room, 2.0)
    candidates = candidate_places(paper_room, 4.0)
    placement = place_beacons(paper_room, floor, candidates, 2)
    assert placement.score < float(objective(placement.before))
    assert placement.score <= placement.greedy_score
    assert (placement.after <= placement.before * (1 + 1e-12)).all()
    assert len(set(placement.chosen)) == 2


def test_the_greedy_pass_takes_the_best_single_beacon(warehouse):
    floor = floor_grid(warehouse, 1.0)
    candidates = candidate_places(warehouse, 3.0)
    one = place_beacons(warehouse, floor, candidates, 1)
    # Brute force: every candidate alone, scored through the full prediction.
    best = min(
        float(objective(place_beacons_score(warehouse, floor, candidates.xyz[c], one.width)))
        for c in range(len(candidates)))
    assert one.score == pytest.approx(best, rel=1e-12)
    assert one.score < float(objective(one.before))


def place_beacons_score(scenario, floor, xyz, width):
    """The predicted σ with one beacon more, through the analysis' own path."""
    beacons = scenario.beacons
    grown = azgym.BeaconMap(np.r_[beacons.ids, beacons.ids.max() + 1],
                            np.r_[beacons.xyz, xyz[None]], np.r_[beacons.width, width])
    return predict(dataclasses.replace(scenario, beacons=grown, physical_xyz=None), floor).sigma


def test_the_new_scenario_file_loads_with_fresh_ids(warehouse, tmp_path):
    floor = floor_grid(warehouse, 1.0)
    placement = place_beacons(warehouse, floor, candidate_places(warehouse), 3)
    data = with_new_beacons(warehouse, placement.new_xyz, placement.width, "warehouse-plus")
    loaded = write_scenario(tmp_path / "warehouse-plus.toml", data, "a test")
    assert loaded.name == "warehouse-plus" and len(loaded.beacons) == 18
    assert set(loaded.beacons.ids[-3:]) == {16, 17, 18}
    np.testing.assert_array_equal(loaded.beacons.xyz[-3:], placement.new_xyz)
    np.testing.assert_array_equal(loaded.beacons.xyz[:15], warehouse.beacons.xyz)
    assert loaded.racks == warehouse.racks and math.isclose(
        loaded.error_model.delta_alpha_d, warehouse.error_model.delta_alpha_d)

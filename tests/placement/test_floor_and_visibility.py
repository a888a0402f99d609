"""The floor grid keeps the sampling rule's clearances; visibility is the geometry sensor's."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import azgym
from azgym.errors import InvalidInputError
from azgym.placement.analysis import predict
from azgym.placement.floor import MAX_CELLS, floor_grid
from azgym.placement.visibility import visible_beacons
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.site.elements import Camera
from azgym.site.sampling import RACK_CLEARANCE, WALL_CLEARANCE


@pytest.fixture(scope="module")
def warehouse():
    return azgym.load_scenario("warehouse-small")


def test_cells_keep_clear_of_walls_and_racks(warehouse):
    floor = floor_grid(warehouse, 0.5)
    x, y = floor.points.T
    x_min, y_min, x_max, y_max = warehouse.bounds
    assert x.min() >= x_min + WALL_CLEARANCE and x.max() <= x_max - WALL_CLEARANCE
    assert y.min() >= y_min + WALL_CLEARANCE and y.max() <= y_max - WALL_CLEARANCE
    for rack in warehouse.racks:
        assert not rack.contains(x, y, margin=-RACK_CLEARANCE).any()
    # ... and it is the free floor, not less: the aisle between two rack rows has cells.
    assert np.any((np.abs(y - 10.0) < 0.3) & (np.abs(x - 8.0) < 0.3))


@pytest.mark.parametrize(("step", "message"), [
    (0.0, "step must be > 0 m, got 0.0"), (-1.0, "step must be > 0 m, got -1.0"),
    (math.nan, r"step must be a finite number \[m\], got nan"), (25.0, "larger than the room"),
    (0.01, f"more than {MAX_CELLS}")])
def test_a_bad_step_is_refused_by_name(warehouse, step, message):
    with pytest.raises(InvalidInputError, match=message):
        floor_grid(warehouse, step)


def test_visibility_is_the_sensors_at_every_heading(warehouse):
    # The map's places are the physical ones here (the planner's view of a moved beacon).
    scenario = dataclasses.replace(warehouse, physical_xyz=None)
    sensor = GeometrySensor(scenario)
    floor = floor_grid(scenario, 1.0)
    rng = np.random.default_rng(3)
    points = floor.points[rng.choice(len(floor.points), size=40, replace=False)]
    seen = visible_beacons(scenario, points, scenario.beacons.xyz, scenario.beacons.width)
    hidden_somewhere = False
    for p, (x, y) in enumerate(points):
        for heading in (0.0, 2.0, -2.5):
            truth = sensor.observe((x, y, heading), rng).truth
            direct = set(truth.beacon[truth.mirrored == 0].tolist())
            assert direct == set(np.flatnonzero(seen[p]).tolist())
        hidden_somewhere |= not seen[p].all()
    assert hidden_somewhere  # the racks do hide beacons: the test compares something


def test_beacons_below_the_lens_are_not_seen(paper_room):
    # The paper room's beacons hang at 2.5 m; a lens at 3 m with a horizon limit sees none.
    raised = dataclasses.replace(paper_room, camera=Camera(height=3.0, min_elevation=0.0))
    prediction = predict(raised, floor_grid(raised, 2.0))
    assert prediction.visible.max() == 0 and np.isinf(prediction.sigma).all()
    level = predict(paper_room, floor_grid(paper_room, 2.0))
    assert (level.visible == 12).all() and np.isfinite(level.sigma).all()

"""The forklift's limits that bound any drive: its centre's top speed and reach from rest."""

from __future__ import annotations

import math

import numpy as np
import pytest
from world.test_world import open_floor

from azgym.world.forklift import ForkliftSpec
from azgym.world.world import World


def test_hand_worked_limits():
    spec = ForkliftSpec()  # 3 m/s, 1.5 m/s², 60° lock: the centre at most √(1 + 3/4) as fast
    assert spec.max_centre_speed == pytest.approx(3.0 * math.sqrt(1.75))
    assert spec.max_centre_distance(1.0) == pytest.approx(0.75 * math.sqrt(1.75))  # a t² / 2
    assert spec.max_centre_distance(2.0) == pytest.approx(3.0 * math.sqrt(1.75))  # top speed at 2 s
    assert spec.max_centre_distance(4.0) == pytest.approx(3.0 * 3.0 * math.sqrt(1.75))


@pytest.mark.parametrize("steer", [0.0, 1.0, -1.0])
def test_no_drive_from_rest_goes_further_than_the_reach(steer):
    spec = ForkliftSpec()
    world = World(open_floor(), (0.0, 0.0, 0.0), spec)
    previous, travelled = np.array(world.forklift.body.position), 0.0
    for step in range(1, 481):  # 8 s at full throttle
        world.step(1.0, steer)
        here = np.array(world.forklift.body.position)
        travelled += float(np.hypot(*(here - previous)))
        previous = here
        assert travelled <= spec.max_centre_distance(step * world.dt + world.dt)
    # Straight on, the bound is tight: within a step's worth of the reach.
    if steer == 0.0:
        assert travelled > spec.max_centre_distance(480 * world.dt) / math.sqrt(1.75) - 0.1

"""Shared fixtures: the paper room and noise-free frames seen from a known pose."""

from __future__ import annotations

import math
import os
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import settings

import azgym
from azgym.core import BeaconMap, Measurements, wrap_angle
from azgym.sensing.synthetic import ideal_azimuths

FrameMaker = Callable[..., Measurements]

# The same examples on every run: a red CI must mean a regression, not an unlucky draw. To draw
# fresh examples locally: HYPOTHESIS_PROFILE=explore python -m pytest
settings.register_profile("repeatable", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))


def ideal_frame(x: float, y: float, heading: float, beacons: BeaconMap) -> Measurements:
    """Every beacon measured once, without error, from the pose (x, y, heading)."""
    azimuth, _ = ideal_azimuths(x, y, heading, beacons)
    return Measurements(beacons.ids, azimuth)


def pose_error(estimate: azgym.Estimate, x: float, y: float, heading: float) -> tuple[float, float]:
    """(position error [m], absolute wrapped heading error [rad]) of an estimate."""
    return (math.hypot(estimate.x - x, estimate.y - y),
            abs(wrap_angle(estimate.heading - heading)))


def beacon_map(xy, width: float = 0.03, first_id: int = 1) -> BeaconMap:
    """A beacon map from horizontal positions, ids counting up from ``first_id``, z = 2.5 m."""
    xy = np.asarray(xy, dtype=float)
    return BeaconMap(np.arange(first_id, first_id + len(xy)), np.c_[xy, np.full(len(xy), 2.5)],
                     width=width)


@pytest.fixture(scope="session")
def paper_room() -> azgym.Scenario:
    """The reconstructed room of Rátosi & Simon (2021), Sec. 3.1."""
    return azgym.load_scenario("paper-room")


@pytest.fixture(scope="session")
def paper_beacons(paper_room: azgym.Scenario) -> BeaconMap:
    """The paper room's 12 beacons."""
    return paper_room.beacons


@pytest.fixture(scope="session")
def make_frame() -> FrameMaker:
    """``make_frame(x, y, heading, beacons)``: a noise-free frame from that pose."""
    return ideal_frame

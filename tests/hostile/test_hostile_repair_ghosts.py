"""Map repair against a moved beacon with a mirror ghost beside it in every frame, and against
one stray ray across parallel ones at the least spread the observability rule allows.

A beacon is measured at most once a frame: its ghost (the same id, seen in a mirror) is a second
detection of the same sighting. Its rays meet at the mirror image as consistently as the real
ones meet at the beacon, so counted as rays the two sets tie and neither is a majority; counted
as sightings, every one of them has a ray through the beacon.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import BeaconMap, Measurements
from azgym.localize.bearings import MIN_SPREAD
from azgym.site.error_model import ErrorModel
from azgym.track.repair import MapRepair

BEACONS = BeaconMap(np.array([1, 2, 3]), np.array([[0.0, 0.0, 3.0], [10.0, 0.0, 3.0],
                                                   [10.0, 10.0, 3.0]]), np.full(3, 0.03))
COV = np.diag([1e-4, 1e-4, 1e-6, 1e-8, 1e-6])
MOVED_TO = np.array([5.0, 8.0])
"""Where beacon 1 (the map's (0, 0)) now hangs."""
IMAGE = np.array([15.0, 8.0])
"""Its image in a mirror along x = 10 (the wall beacons 2 and 3 hang on): beyond the map's box,
and more often seen than it (the camera sees both in every frame, the image once more)."""


def repair_with(span: float) -> MapRepair:
    return MapRepair(sightings=3, after=0.2, span=span, max_std=0.1, threshold=10.83,
                     error_model=ErrorModel(), extra_sigma=0.0)


def test_a_moved_beacon_with_a_ghost_in_every_frame_is_repaired_where_it_is() -> None:
    repair = repair_with(math.radians(20.0))
    rng = np.random.default_rng(0)
    made = []
    for k in range(60):  # along y = 3 from x = 1 to x = 9, heading east, 0.1 s a frame
        camera = np.array([1.0 + 8.0 * k / 59, 3.0])
        state = np.array([camera[0], camera[1], 0.0, 0.0, 0.0])
        real, ghost = (math.atan2(*(target - camera)[::-1]) for target in (MOVED_TO, IMAGE))
        noise = rng.normal(0.0, 0.002, 2)
        frame = Measurements(np.array([1, 1, 2, 3]),
                             np.array([real + noise[0], ghost + noise[1], 0.0, 0.0]))
        if k % 10 == 9:  # the beacon itself hidden, its image not
            frame = Measurements(np.array([1, 2, 3]), np.array([ghost + noise[1], 0.0, 0.0]))
        beacons = repair.begin_frame(BEACONS)
        used = np.array([False] * (len(frame) - 2) + [True, True])
        used[0] = bool(made) and len(frame) == 4  # once repaired, the tracker uses it again
        made += repair.observe(0.1 * k, frame, used, beacons, state, COV, True)[1]
    assert [r.beacon for r in made] == [1], made
    assert math.dist(made[0].new, MOVED_TO) < 0.05


def test_one_stray_ray_across_parallel_ones_places_nothing_at_the_least_spread() -> None:
    # eleven parallel rays (east along y = 5) and one 25° across them, meeting them at (8, 5):
    # the twelve spread 13.5°, over MIN_SPREAD, yet the one stray ray alone fixes the point
    repair = repair_with(MIN_SPREAD)
    stray = math.radians(25.0)
    cameras = [(1.0 + 0.1 * k, 5.0) for k in range(11)]
    cameras.append((8.0 - 4.0 * math.cos(stray), 5.0 - 4.0 * math.sin(stray)))
    made = []
    for k, ((x, y), azimuth) in enumerate(zip(cameras, [0.0] * 11 + [stray], strict=True)):
        frame = Measurements(np.array([1, 2, 3]), np.array([azimuth, 0.0, 0.0]))
        repair.begin_frame(BEACONS)
        made += repair.observe(0.1 * k, frame, np.array([False, True, True]), BEACONS,
                               np.array([x, y, 0.0, 0.0, 0.0]), COV, True)[1]
    assert made == [], [(r.beacon, r.new) for r in made]
    assert repair.suspects == (1,)

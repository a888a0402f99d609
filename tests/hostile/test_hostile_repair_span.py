"""Map repair against one stray ray among parallel ones: the arc they cover is wide, the angle
they locate a point with is not, and the repair must not take the stray's crossing for the
beacon's new position."""

from __future__ import annotations

import math

import numpy as np

from azgym.core import BeaconMap, Measurements
from azgym.site.error_model import ErrorModel
from azgym.track.repair import MapRepair

BEACONS = BeaconMap(np.array([1, 2, 3]), np.array([[0.0, 0.0, 3.0], [10.0, 0.0, 3.0],
                                                   [10.0, 10.0, 3.0]]), np.full(3, 0.03))
COV = np.diag([1e-4, 1e-4, 1e-6, 1e-8, 1e-6])
STRAY = math.radians(25.0)
GHOST = np.array([8.0, 5.0])
"""Where the stray ray crosses the parallel ones: 2 m beyond where beacon 1 now is, (6, 5)."""


def test_a_stray_ray_across_parallel_ones_does_not_place_a_moved_beacon() -> None:
    repair = MapRepair(sightings=3, after=0.2, span=math.radians(20.0), max_std=0.1,
                       threshold=10.83, error_model=ErrorModel(), extra_sigma=0.0)
    # beacon 1 seen straight ahead (east) from 11 places along y = 5: parallel rays through
    # (6, 5) and GHOST alike, rejected by the map (it says (0, 0)) while 2 and 3 agree
    cameras = [(1.0 + 0.1 * k, 5.0, 0.0) for k in range(11)]
    # then one ray 25° across them, meeting their line at GHOST (a ghost's, a misread's)
    cameras.append((GHOST[0] - 4.0 * math.cos(STRAY), GHOST[1] - 4.0 * math.sin(STRAY), 0.0))
    azimuths = [0.0] * 11 + [STRAY]
    made = []
    for k, ((x, y, heading), azimuth) in enumerate(zip(cameras, azimuths, strict=True)):
        state = np.array([x, y, heading, 0.0, 0.0])
        frame = Measurements(np.array([1, 2, 3]), np.array([azimuth, 0.0, 0.0]))
        repair.begin_frame(BEACONS)
        made += repair.observe(0.1 * k, frame, np.array([False, True, True]), BEACONS, state,
                               COV, True)[1]
    assert made == [], [(r.beacon, r.new) for r in made]
    assert repair.suspects == (1,)  # set aside, its rays waiting for a wider spread

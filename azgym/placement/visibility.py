"""Which beacons the camera sees from each cell: the geometry sensor's own line-of-sight rule.

Visibility is decided by :func:`azgym.sensing.geometry.direct.direct_view`, the kernel every
geometry frame is made of: a beacon is seen when it is within the lens' range, at or above its
lowest elevation, and not wholly covered by racks or walls (2.5-D: a ray passes over an occluder
lower than itself there). A partly covered beacon is seen. Mirror images are not beacons seen,
and are left out. The camera looks straight up through a fisheye, so what it sees does not
depend on its heading: one test per cell serves every heading.

The beacons are taken at the places the map gives (a layout as designed; a beacon moved after
mapping is a fault, which the planner leaves out).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from azgym.core import BoolArray, FloatArray
from azgym.sensing.geometry.detections import FOUND_BEACON, FOUND_FLOAT_ROWS, FOUND_INT_ROWS
from azgym.sensing.geometry.direct import direct_view
from azgym.site import Scenario
from azgym.site.elements import occluder_table

__all__ = ["visible_beacons"]


def visible_beacons(scenario: Scenario, points: FloatArray, beacon_xyz: FloatArray,
                    beacon_width: FloatArray,
                    done: Callable[[int], None] | None = None) -> BoolArray:
    """Whether the camera at each point sees each beacon directly, shape (P, B).

    Each beacon is tested on its own, so the columns of one call with two sets of beacons are
    those of a call with each set.

    Args:
        scenario: The site: its racks and walls, the camera's height, lowest elevation and range.
        points: Camera positions (x, y), shape (P, 2) [m].
        beacon_xyz: Beacon positions, shape (B, 3) [m] (the scenario's or candidates').
        beacon_width: Beacon widths W, shape (B,) [m].
        done: Called with the number of points done as they are done (a progress count).
    """
    xyz = np.array(beacon_xyz, dtype=np.float64, order="C")
    xyz.setflags(write=False)  # as the sensor's: the same compiled kernel
    width = np.ascontiguousarray(beacon_width, dtype=np.float64)
    count = xyz.shape[0]
    segments = occluder_table(scenario.racks, scenario.walls)
    camera = scenario.camera
    lens = (float(camera.min_elevation), float(camera.max_range))
    not_moved = np.zeros(count, dtype=np.bool_)
    found = np.empty((FOUND_FLOAT_ROWS, count))
    found_ints = np.empty((FOUND_INT_ROWS, count), dtype=np.int64)
    seen = np.zeros((len(points), count), dtype=bool)
    height = float(camera.height)
    for p, (x, y) in enumerate(points):
        listed = direct_view((float(x), float(y), height), lens, xyz, width, not_moved, segments,
                             found, found_ints)
        seen[p, found_ints[FOUND_BEACON, :listed]] = True
        if done is not None:
            done(p + 1)
    return seen

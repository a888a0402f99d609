"""Every built-in suite by name: the one place a suite is registered and its version kept."""

from __future__ import annotations

from azgym.bench.run.profiles import DIFFERENTIAL_MOTION_NOISE, MOTION_NOISE, SENSOR_NOISE
from azgym.bench.suites import events, image, paper, robot, warehouse
from azgym.bench.suites.base import Suite
from azgym.profile import DIFFERENTIAL_DRIVE, FORKLIFT
from azgym.registry import Registry

__all__ = ["SUITES", "get_suite"]

SUITES: Registry[Suite] = Registry("suite", {suite.name: suite for suite in (
    Suite("paper", 1, "Rátosi & Simon Sec. 3: the paper room's 23 x 23 grid, 20 runs a point, "
          "K = 0, 1, 3, 5 (the runs of azgym reproduce paper)", 2021, paper.build,
          simulates=SENSOR_NOISE),
    Suite("warehouse-static", 1, "random poses in warehouse-small and warehouse-paper; faults "
          "clean, as shipped and heavy", 7, warehouse.static, simulates=SENSOR_NOISE),
    Suite("warehouse-routes", 3, "every route of warehouse-small and warehouse-paper, frame by "
          "frame at 10 Hz", 11, warehouse.routes, routes=True,
          simulates=SENSOR_NOISE + MOTION_NOISE, vehicle=FORKLIFT),
    Suite("image-routes", 3, "every route of warehouse-small and warehouse-paper through the "
          "fisheye image path: blobs detected from pixels, ids decoded from blinking (30 Hz "
          "camera, every third frame scored)", 17, image.routes, routes=True,
          simulates=MOTION_NOISE, vehicle=FORKLIFT),
    Suite("route-events", 1, "the first route of warehouse-small and warehouse-paper at 10 Hz "
          "with a 3 s outage and a 10 s kidnapping cut in (for trackers)", 19, events.build,
          routes=True, simulates=SENSOR_NOISE + MOTION_NOISE, vehicle=FORKLIFT),
    Suite("stress", 1, "warehouse-large (64 beacons) with heavy faults: 5 % misreads, bright "
          "mirrors", 13, warehouse.stress, simulates=SENSOR_NOISE),
    Suite("robot-routes", 1, "the four wander routes of robot-arena: a differential-drive "
          "robot, a forward camera of 1.2 rad seeing 1-2 of 15 landmarks, odometry of speed and "
          "turn rate stamped irregularly (5 Hz frames; for trackers)", 23, robot.routes,
          routes=True, simulates=SENSOR_NOISE + DIFFERENTIAL_MOTION_NOISE,
          vehicle=DIFFERENTIAL_DRIVE, defaults=robot.contender_defaults),
)})
"""The frame suites by name, in the order the leaderboard shows them."""


def get_suite(name: str) -> Suite:
    """The suite of that name ("Did you mean ...?" otherwise)."""
    return SUITES[name]

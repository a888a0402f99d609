"""Every built-in suite by name: the one place a suite is registered and its version kept."""

from __future__ import annotations

from azgym.bench.suites import events, image, paper, warehouse
from azgym.bench.suites.base import Suite
from azgym.errors import unknown_name

SUITES: dict[str, Suite] = {suite.name: suite for suite in (
    Suite("paper", 1, "Rátosi & Simon Sec. 3: the paper room's 23 x 23 grid, 20 runs a point, "
          "K = 0, 1, 3, 5 (the runs of azgym reproduce paper)", 2021, paper.build),
    Suite("warehouse-static", 1, "random poses in warehouse-small and warehouse-paper; faults "
          "clean, as shipped and heavy", 7, warehouse.static),
    Suite("warehouse-routes", 3, "every route of warehouse-small and warehouse-paper, frame by "
          "frame at 10 Hz", 11, warehouse.routes, routes=True),
    Suite("image-routes", 3, "every route of warehouse-small and warehouse-paper through the "
          "fisheye image path: blobs detected from pixels, ids decoded from blinking (30 Hz "
          "camera, every third frame scored)", 17, image.routes, routes=True),
    Suite("route-events", 1, "the first route of warehouse-small and warehouse-paper at 10 Hz "
          "with a 3 s outage and a 10 s kidnapping cut in (for trackers)", 19, events.build,
          routes=True),
    Suite("stress", 1, "warehouse-large (64 beacons) with heavy faults: 5 % misreads, bright "
          "mirrors", 13, warehouse.stress),
)}


def get_suite(name: str) -> Suite:
    """The suite of that name ("Did you mean ...?" otherwise)."""
    if name not in SUITES:
        raise unknown_name("suite", name, SUITES)
    return SUITES[name]

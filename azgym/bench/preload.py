"""What the workers' fork server loads before it forks any worker.

Importing this module (the fork server does, once) imports the worker and runs every built-in
localizer once on a small exact frame, which loads their compiled code (or compiles it, on a
machine's first run). Every worker forked afterwards starts with that code in memory instead of
loading it again, so starting one costs milliseconds. Nothing of a benchmark run is here: the
server starts from a fresh interpreter, not from the process that runs the benchmark.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.bench import worker  # noqa: F401 - imported for the workers that fork from here
from azgym.bench.contenders import default_contenders
from azgym.core import BeaconMap, Measurements
from azgym.localize.registry import make_localizer


def warm_up() -> None:
    """Run each built-in contender on one noise-free frame in a 10 m × 8 m room."""
    xyz = np.array([[0.0, 0.0, 3.0], [10.0, 0.0, 3.0], [10.0, 8.0, 3.0], [0.0, 8.0, 3.0],
                    [5.0, 8.0, 3.0]])
    beacons = BeaconMap(np.arange(5), xyz)
    x, y, heading = 3.0, 2.5, 0.3
    azimuth = [math.remainder(math.atan2(by - y, bx - x) - heading, math.tau)
               for bx, by, _ in xyz]
    measurements = Measurements(np.arange(5), azimuth)
    for contender in default_contenders():
        try:
            make_localizer(contender.spec, **contender.params).localize(measurements, beacons)
        except Exception:  # noqa: BLE001, S112 - a worker meets (and scores) the same failure
            continue


warm_up()

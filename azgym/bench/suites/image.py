"""The image-routes suite: the routes through the fisheye image path, ids decoded from blinking."""

from __future__ import annotations

from azgym.bench.run.profiles import AS_SHIPPED, SimulatedNoise
from azgym.bench.suites.base import Case, keep_every, route_cases
from azgym.bench.suites.warehouse import SCENARIOS
from azgym.sensing.image.sensor import ImageSensor
from azgym.site import load_scenario
from azgym.world.drive import simulate

__all__ = ["routes"]

SCORED_EVERY = 3
"""Every third frame of the blinking camera is scored, as a 10 Hz localizer would use them."""


def routes(seed: int, quick: bool, noise: SimulatedNoise = AS_SHIPPED) -> list[Case]:
    """Every route rendered, detected and decoded; every third frame (quick: one route, 12th).

    The azimuths come from pixels: ``noise`` sets the motion sensors' only.
    """
    cases = []
    every = 4 * SCORED_EVERY if quick else SCORED_EVERY
    for name in SCENARIOS:
        scenario = load_scenario(name)
        chosen = scenario.routes[:1] if quick else scenario.routes
        for k, route in enumerate(chosen):
            sensor = ImageSensor(scenario, ids="blink")
            frames = simulate(scenario, route, [seed, k], sensor=sensor,
                              odometry=noise.odometry(), imu=noise.imu())
            cases += keep_every(route_cases(name, f"{name}/{route.name}", frames, noise), every)
    return cases

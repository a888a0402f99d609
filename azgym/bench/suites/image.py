"""The image-routes suite: the routes through the fisheye image path, ids decoded from blinking."""

from __future__ import annotations

from azgym.bench.suites.base import Case, frame_cause
from azgym.bench.suites.warehouse import SCENARIOS
from azgym.sensing.image.sensor import ImageSensor
from azgym.site import load_scenario
from azgym.world.drive import simulate

SCORED_EVERY = 3
"""Every third frame of the blinking camera is scored, as a 10 Hz localizer would use them."""


def routes(seed: int, quick: bool) -> list[Case]:
    """Every route rendered, detected and decoded; every third frame (quick: one route, 12th)."""
    cases = []
    every = 4 * SCORED_EVERY if quick else SCORED_EVERY
    for name in SCENARIOS:
        scenario = load_scenario(name)
        chosen = scenario.routes[:1] if quick else scenario.routes
        for k, route in enumerate(chosen):
            sensor = ImageSensor(scenario, ids="blink")
            for frame in simulate(scenario, route, [seed, k], sensor=sensor):
                if frame.index % every == 0:
                    cases.append(Case(name, frame.measurements, frame.pose,
                                      frame_cause(frame.truth.label), f"{name}/{route.name}"))
    return cases

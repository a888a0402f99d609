"""route-events: driven routes with an outage and a kidnapping, for trackers to ride out.

Each warehouse's first route is driven at 10 Hz, then two events are cut into it:

- an **outage** at 30 % of the route: no frames for ``OUTAGE_S`` seconds, while the odometry
  and IMU go on (the frame after it carries every sample of the gap);
- a **kidnapping** at 60 %: the forklift is carried ``KIDNAP_S`` seconds further along its
  route with no motion data at all (the frame after it carries none).

A per-frame localizer does not notice either; a tracker must hold its estimate through the
outage and find the forklift again after the kidnapping. The first frame after each event is
marked (``Case.event``), so recovery is measured per event.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from azgym.bench.run.profiles import AS_SHIPPED, SimulatedNoise
from azgym.bench.suites.base import Case, route_cases
from azgym.bench.suites.warehouse import SCENARIOS
from azgym.errors import ScenarioError
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples, joined
from azgym.site import load_scenario
from azgym.world.drive import simulate

__all__ = ["build", "with_events"]

OUTAGE_AT, OUTAGE_S = 0.3, 3.0
"""Where in the route the outage starts (fraction of its frames) and how long it lasts [s]."""
KIDNAP_AT, KIDNAP_S = 0.6, 10.0
"""Where the kidnapping happens and how far along the route (in driving time) it carries [s]."""


def build(seed: int, quick: bool, noise: SimulatedNoise = AS_SHIPPED) -> list[Case]:
    """Both warehouses' first routes with their events (the suite is small: quick is the same)."""
    cases: list[Case] = []
    for k, name in enumerate(SCENARIOS):
        scenario = noise.scenario(load_scenario(name))
        route = scenario.routes[0]
        driven = simulate(scenario, route, seed=seed + k, odometry=noise.odometry(),
                          imu=noise.imu())
        frames = route_cases(name, f"{name}/{route.name}", driven, noise)
        cases += with_events(frames)
    return cases


def with_events(cases: list[Case]) -> list[Case]:
    """One route's cases (10 Hz) with the outage and the kidnapping cut in."""
    rate = 1.0 / float(np.median(np.diff([case.time for case in cases])))
    outage = int(OUTAGE_AT * len(cases))
    outage_end = outage + round(OUTAGE_S * rate)
    kidnap = int(KIDNAP_AT * len(cases))
    kidnap_end = kidnap + round(KIDNAP_S * rate)
    if kidnap_end >= len(cases):
        raise ScenarioError(f"a route of {len(cases)} frames is too short for its events")
    after_outage = cases[outage_end]
    missed = [case.motion for case in cases[outage:outage_end + 1] if case.motion is not None]
    after_kidnap = cases[kidnap_end]
    return (cases[:outage]
            + [dataclasses.replace(after_outage, motion=joined(missed), event="outage")]
            + cases[outage_end + 1:kidnap]
            + [dataclasses.replace(after_kidnap, motion=_still(after_kidnap.time),
                                   event="kidnap")]
            + cases[kidnap_end + 1:])


def _still(time: float) -> Motion:
    """No motion samples at all, up to ``time``: what a carried forklift's sensors give."""
    empty = np.zeros(0)
    return Motion(time, OdometrySamples(empty, empty, empty),
                  ImuSamples(empty, empty, np.zeros((0, 2)), empty))

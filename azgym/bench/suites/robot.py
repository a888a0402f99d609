"""The robot suite: a differential-drive robot's routes in robot-arena, for trackers.

The robot wanders an 8 m x 6 m arena among 15 landmarks, seeing 1-2 of them at a time through a
forward camera of 1.2 rad, its odometry (speed and turn rate) stamped irregularly and drifting
as a real robot's does (docs/robot.md). Every 5 Hz frame of the four ``wander-*`` routes is
scored; the scenario's ``long`` route (15 min) is left out, for calibrating a profile on.
"""

from __future__ import annotations

from azgym.bench.run.profiles import AS_SHIPPED, SimulatedNoise
from azgym.bench.suites.base import Case, keep_every, route_cases
from azgym.profile import Profile
from azgym.sensing.motion import DifferentialOdometryModel
from azgym.site import Scenario, load_scenario
from azgym.world.drive import motion_models, simulate

__all__ = ["ROUTES", "SCENARIO", "contender_defaults", "routes"]

SCENARIO = "robot-arena"
"""The scenario the suite drives."""
ROUTES = ("wander-1", "wander-2", "wander-3", "wander-4")
"""The routes it scores (about 2.6 min each)."""


def contender_defaults() -> Profile:
    """The contenders' defaults: robot-arena's vehicle and camera, and its odometry's errors.

    What a tracker on the forklift suites gets from its own defaults (they are the forklift
    simulator's models), a robot's tracker gets from these: the scenario's declared profile and
    the simulated odometry's :meth:`~azgym.sensing.motion.DifferentialOdometryModel.motion_profile`.
    """
    scenario = load_scenario(SCENARIO)
    motion = _odometry(scenario).motion_profile()
    return Profile(scenario.profile.vehicle, scenario.profile.sensor, motion)


def routes(seed: int, quick: bool, noise: SimulatedNoise = AS_SHIPPED) -> list[Case]:
    """robot-routes: every frame of each route (quick: the first route, every second frame).

    ``noise`` sets the bearing noise and the odometry's errors from a profile (``--profile``).
    """
    scenario = noise.scenario(load_scenario(SCENARIO))
    odometry = noise.differential_odometry(_odometry(scenario))
    chosen = [route for route in scenario.routes if route.name in ROUTES]
    cases: list[Case] = []
    for k, route in enumerate(chosen[:1] if quick else chosen):
        frames = simulate(scenario, route, seed=seed + k, odometry=odometry)
        cases += route_cases(SCENARIO, f"{SCENARIO}/{route.name}", frames, noise)
    return keep_every(cases, 2) if quick else cases


def _odometry(scenario: Scenario) -> DifferentialOdometryModel:
    """The robot's odometry model as its scenario simulates it (a differential drive's)."""
    odometry, _ = motion_models(scenario)
    assert isinstance(odometry, DifferentialOdometryModel), "robot-arena is a differential drive"
    return odometry

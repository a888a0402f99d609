"""The warehouse suites: random poses and driven routes, seen by the geometry sensor."""

from __future__ import annotations

import dataclasses

import numpy as np

from azgym.bench.run.profiles import AS_SHIPPED, SimulatedNoise
from azgym.bench.suites.base import Case, Suite, frame_cause, keep_every, route_cases
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.site import Scenario, load_scenario
from azgym.site.elements import Faults
from azgym.site.sampling import random_free_pose
from azgym.world.drive import simulate

__all__ = ["SCENARIOS", "fault_levels", "routes", "scenario_suite", "static", "static_cases",
           "stress"]

SCENARIOS = ("warehouse-small", "warehouse-paper")
"""The warehouses of the static and route suites."""
RANDOM_POSES = {True: 40, False: 400}
"""Random poses per scenario and fault level, quick and full: warehouse-static's, and a sweep's
scenario axis's."""


def fault_levels(scenario: Scenario) -> dict[str, Scenario]:
    """The scenario clean, as shipped, and with heavy faults (5 % misreads, mirrors ×2.5)."""
    def mirrors(factor: float) -> Scenario:
        return dataclasses.replace(
            scenario,
            racks=tuple(dataclasses.replace(r, reflectivity=min(1.0, r.reflectivity * factor))
                        for r in scenario.racks),
            walls=tuple(dataclasses.replace(w, reflectivity=min(1.0, w.reflectivity * factor))
                        for w in scenario.walls))

    clean = dataclasses.replace(mirrors(0.0), faults=Faults(0.0), physical_xyz=None)
    heavy = dataclasses.replace(mirrors(2.5), faults=Faults(0.05))
    return {"clean": clean, "as shipped": scenario, "heavy": heavy}


def static_cases(scenario: Scenario, count: int, rng: np.random.Generator,
                 group: str) -> list[Case]:
    """Frames at random free poses (:func:`~azgym.site.sampling.random_free_pose`)."""
    sensor = GeometrySensor(scenario)
    cases = []
    for _ in range(count):
        pose = random_free_pose(scenario, rng)
        observation = sensor.observe(pose, rng)
        cases.append(Case(scenario.name, observation.measurements, pose,
                          frame_cause(observation.truth.label), group))
    return cases


def static(seed: int, quick: bool, noise: SimulatedNoise = AS_SHIPPED) -> list[Case]:
    """warehouse-static: random poses in each warehouse at each fault level."""
    rng = np.random.default_rng(seed)
    cases = []
    for name in SCENARIOS:
        for level, scenario in fault_levels(noise.scenario(load_scenario(name))).items():
            cases += static_cases(scenario, RANDOM_POSES[quick], rng, f"{name}, {level}")
    return cases


def routes(seed: int, quick: bool, noise: SimulatedNoise = AS_SHIPPED) -> list[Case]:
    """warehouse-routes: every route driven, every 10 Hz frame (quick: one route, every 4th)."""
    cases = []
    for name in SCENARIOS:
        scenario = noise.scenario(load_scenario(name))
        chosen = scenario.routes[:1] if quick else scenario.routes
        for k, route in enumerate(chosen):
            frames = simulate(scenario, route, seed=seed + k, odometry=noise.odometry(),
                              imu=noise.imu())
            cases += route_cases(name, f"{name}/{route.name}", frames, noise)
    return keep_every(cases, 4) if quick else cases


def stress(seed: int, quick: bool, noise: SimulatedNoise = AS_SHIPPED) -> list[Case]:
    """stress: random poses in warehouse-large with heavy faults."""
    rng = np.random.default_rng(seed)
    heavy = fault_levels(noise.scenario(load_scenario("warehouse-large")))["heavy"]
    return static_cases(heavy, 60 if quick else 600, rng, "warehouse-large, heavy")


def scenario_suite(scenario: Scenario) -> Suite:
    """Random poses in one scenario, as shipped (:data:`RANDOM_POSES`): a sweep's scenario axis.

    Named ``static:<scenario>``; its default seed is 0. It is not registered among the suites
    (a leaderboard entry cannot name it): a sweep builds it from the file it was given.
    """
    def build(seed: int, quick: bool) -> list[Case]:
        return static_cases(scenario, RANDOM_POSES[quick], np.random.default_rng(seed),
                            f"{scenario.name}, as shipped")

    return Suite(f"static:{scenario.name}", 1, f"random poses in {scenario.name}, as shipped",
                 0, build)

"""The mapping suite: scenarios' routes driven with their maps unknown, stale or right.

A case is one route of a scenario (warehouse-small and warehouse-paper, the route suites'
warehouses, and robot-arena's wandering robot, whose narrow camera tests how a method
transfers), driven with the simulator's motion noise as shipped (as the route suites draw it),
under one perturbation of its map, drawn from the case's seed:

* ``unknown``: the prior is a map of two anchors only (two beacons the drive makes observable,
  drawn, at their true positions); everything else must be found;
* ``moved``: 1-3 of the beacons the drive makes observable moved in the world
  (:func:`~azgym.bench.mapping.perturb.move_beacons`); the prior is the map as it was;
* ``rack``: one rack slid along its axis, its beacons with it, hiding or uncovering others
  (:func:`~azgym.bench.mapping.perturb.move_rack`; sites with racks only); the prior is the map
  as it was;
* ``unchanged``: the prior is the true map, so any beacon said moved is a false move.

A mapper gets the :class:`~azgym.mapping.problem.Drive` (frames, motion, the true start camera
pose) and the :class:`~azgym.mapping.problem.Prior`; the truth (:class:`CaseTruth`: where each
beacon is, the camera's true poses, which detections are true) stays with the runner. The
routes are public, so their true poses are too: the suite has a ``dev`` split only, as the
route suites (:data:`~azgym.bench.suites.base.NO_TEST_SPLIT`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from azgym.bench.mapping.perturb import Perturbed, move_beacons, move_rack, true_map
from azgym.bench.mapping.scoring import observable_by_truth
from azgym.bench.run.profiles import AS_SHIPPED
from azgym.bench.suites import robot
from azgym.bench.suites.base import NO_TEST_SPLIT
from azgym.bench.suites.warehouse import SCENARIOS as WAREHOUSES
from azgym.core import BeaconMap, FloatArray, IntArray
from azgym.errors import InvalidInputError
from azgym.mapping.problem import Drive, Prior, simulated_drive
from azgym.profile import Profile
from azgym.registry import Registry
from azgym.sensing.labels import DIRECT, MOVED, PARTIAL
from azgym.sensing.motion import DifferentialOdometryModel
from azgym.site import Scenario, load_scenario
from azgym.site.elements import Route
from azgym.world.drive import Frame, motion_models, simulate

__all__ = ["MAPPING_SUITES", "MOVED_COUNT", "PERTURBATIONS", "RACK", "SCENARIOS", "UNCHANGED",
           "TRUE_LABELS", "UNKNOWN", "CaseTruth", "MappingCase", "MappingSuite", "build",
           "case_names", "get_mapping_suite", "perturbations", "true_detections"]

UNKNOWN, MOVED_BEACONS, RACK, UNCHANGED = "unknown", "moved", "rack", "unchanged"
PERTURBATIONS = (UNKNOWN, MOVED_BEACONS, RACK, UNCHANGED)
"""The perturbations of a case's map, in the order of a route's cases (module docstring)."""
SCENARIOS = (*WAREHOUSES, robot.SCENARIO)
"""The scenarios driven, the first one alone in the quick size."""
MOVED_COUNT = (1, 3)
"""How many beacons a ``moved`` case moves (drawn uniformly, both ends included)."""
TRUE_LABELS = (DIRECT, PARTIAL, MOVED)
"""The labels of a true detection: a beacon's own light, seen where it is (not a mirror image,
a misread id or a lamp)."""


@dataclass(frozen=True, eq=False)
class CaseTruth:
    """What a case's runner scores against; never sent to a mapper.

    Attributes:
        beacons: Where the world has each beacon.
        poses: The true camera pose (x, y, heading) of each frame (K, 3).
        frames: Each true detection's frame (D,) (:data:`TRUE_LABELS`).
        ids: Its beacon's id (D,).
        azimuths: Its noise-free azimuth in the camera frame (D,) [rad].
    """

    beacons: BeaconMap
    poses: FloatArray
    frames: IntArray
    ids: IntArray
    azimuths: FloatArray


@dataclass(frozen=True, eq=False)
class MappingCase:
    """One case: a route driven under one perturbation.

    Attributes:
        name: ``scenario/route/perturbation``.
        scenario: The scenario's name.
        route: The route's name.
        perturbation: One of :data:`PERTURBATIONS`.
        drive: What the mapper gets: the frames, their motion, the true start camera pose.
        prior: What it knew: the map (two anchors, stale, or right) and its anchors.
        profile: The profile the mapper takes its defaults from (robot-arena's vehicle, camera
            and odometry; None: the mapper's own, which fit the forklift's simulator).
        truth: What it is scored against, kept in the runner.
    """

    name: str
    scenario: str
    route: str
    perturbation: str
    drive: Drive
    prior: Prior
    profile: Profile | None
    truth: CaseTruth

    @property
    def times(self) -> FloatArray:
        """Each frame's time [s]."""
        return np.array([frame.time for frame in self.drive.frames])


@dataclass(frozen=True)
class MappingSuite:
    """A named, versioned way to draw mapping cases.

    Attributes:
        name: Identifier.
        version: Bumped whenever the cases it draws change.
        description: One line for listings and reports.
        dev_seed: The seed of its (only) split.
        build: ``build(seed, quick)`` draws the cases.
    """

    name: str
    version: int
    description: str
    dev_seed: int
    build: Callable[[int, bool], list[MappingCase]]

    def check_split(self, split: str) -> None:
        """Refuse a split other than ``dev`` (the routes are public: :data:`NO_TEST_SPLIT`)."""
        if split != "dev":
            raise InvalidInputError(NO_TEST_SPLIT.format(suite=self.name))


def build(seed: int, quick: bool) -> list[MappingCase]:
    """The mapping suite's cases: every scenario x route x perturbation (:func:`case_names`)."""
    cases = []
    for s, scenario, k, route in _routes(quick):
        cases += _route_cases(scenario, route, seed, [s, k])
    return cases


def case_names(quick: bool) -> list[str]:
    """The suite's cases by name, in the order it draws them, without driving them.

    A name is ``scenario/route/perturbation``.
    """
    return [_name(scenario, route, perturbation) for _, scenario, _, route in _routes(quick)
            for perturbation in perturbations(scenario)]


def perturbations(scenario: Scenario) -> tuple[str, ...]:
    """The perturbations a site allows, in order: ``rack`` only where it has racks."""
    return tuple(p for p in PERTURBATIONS if p != RACK or scenario.racks)


def _routes(quick: bool) -> Iterator[tuple[int, Scenario, int, Route]]:
    """Each scenario's routes driven (the robot's wandering ones), with their indices.

    Quick: the first scenario's first route alone.
    """
    for s, name in enumerate(SCENARIOS[:1] if quick else SCENARIOS):
        scenario = load_scenario(name)
        routes = [r for r in scenario.routes
                  if name != robot.SCENARIO or r.name in robot.ROUTES]
        for k, route in enumerate(routes[:1] if quick else routes):
            yield s, scenario, k, route


def _name(scenario: Scenario, route: Route, perturbation: str) -> str:
    """A case's name."""
    return f"{scenario.name}/{route.name}/{perturbation}"


def _route_cases(scenario: Scenario, route: Route, seed: int,
                 place: list[int]) -> list[MappingCase]:
    """A route's cases, one per perturbation the site allows, each drawn from its own stream."""
    as_shipped = _drive(scenario, route, seed + place[1])
    observable = sorted(observable_by_truth(*true_detections(scenario, as_shipped),
                                            _poses(as_shipped)))
    cases = []
    for perturbation in perturbations(scenario):
        rng = np.random.default_rng([seed, *place, PERTURBATIONS.index(perturbation)])
        world, frames, prior = scenario, as_shipped, Prior(true_map(scenario))
        if perturbation == UNKNOWN:
            anchors = sorted(int(b) for b in rng.choice(observable, 2, replace=False))
            known = true_map(scenario)
            rows = np.isin(known.ids, anchors)
            prior = Prior(BeaconMap(known.ids[rows], known.xyz[rows], known.width[rows]),
                          tuple(anchors))
        elif perturbation in (MOVED_BEACONS, RACK):
            changed: Perturbed = move_beacons(
                scenario, rng, int(rng.integers(MOVED_COUNT[0], MOVED_COUNT[1] + 1)),
                observable) if perturbation == MOVED_BEACONS else move_rack(scenario, rng, route)
            world = changed.world
            frames = _drive(world, route, seed + place[1])
            prior = Prior(scenario.beacons)
        cases.append(_case(world, route, perturbation, frames, prior))
    return cases


def _drive(scenario: Scenario, route: Route, seed: int) -> list[Frame]:
    """The route driven with the motion noise as shipped, as the route suites drive it."""
    if scenario.differential_drive:
        odometry, _ = motion_models(scenario)
        assert isinstance(odometry, DifferentialOdometryModel), "a differential drive's"
        return list(simulate(scenario, route, seed=seed,
                             odometry=AS_SHIPPED.differential_odometry(odometry)))
    return list(simulate(scenario, route, seed=seed, odometry=AS_SHIPPED.odometry(),
                         imu=AS_SHIPPED.imu()))


def _poses(frames: list[Frame]) -> FloatArray:
    """The true camera poses (K, 3)."""
    return np.array([frame.pose for frame in frames], dtype=np.float64).reshape(-1, 3)


def true_detections(scenario: Scenario, frames: list[Frame]
                    ) -> tuple[IntArray, IntArray, FloatArray]:
    """Each true detection (:data:`TRUE_LABELS`): its frame, beacon id and noise-free azimuth."""
    parts = []
    for k, frame in enumerate(frames):
        truth = frame.truth
        true = np.isin(truth.label, TRUE_LABELS) & (truth.beacon >= 0)
        parts.append((np.full(int(true.sum()), k), scenario.beacons.ids[truth.beacon[true]],
                      truth.azimuth[true]))
    return (np.concatenate([p[0] for p in parts]).astype(np.int64),
            np.concatenate([p[1] for p in parts]).astype(np.int64),
            np.concatenate([p[2] for p in parts]).astype(np.float64))


def _case(world: Scenario, route: Route, perturbation: str, frames: list[Frame],
          prior: Prior) -> MappingCase:
    """A case of a route driven through ``world``."""
    detected, ids, azimuths = true_detections(world, frames)
    drive = simulated_drive(frames, frames[0].pose)
    truth = CaseTruth(true_map(world), _poses(frames), detected, ids, azimuths)
    profile = robot.contender_defaults() if world.name == robot.SCENARIO else None
    return MappingCase(_name(world, route, perturbation), world.name, route.name,
                       perturbation, drive, prior, profile, truth)


MAPPING_SUITES: Registry[MappingSuite] = Registry("mapping suite", {
    "mapping": MappingSuite(
        "mapping", 1, "beacon maps from a drive: unknown but two anchors, beacons moved, a rack "
        "moved, unchanged; beacon error, moved beacons found and how soon, ransac on the map",
        2900, build)})
"""The mapping suites by name."""


def get_mapping_suite(name: str) -> MappingSuite:
    """The mapping suite of that name ("Did you mean ...?" otherwise)."""
    return MAPPING_SUITES[name]

"""The paper suite: the simulation protocol of Rátosi & Simon (2021), Sec. 3.1, as cases.

A 23 × 23 grid of integer points from −11 m to 11 m, 20 noise realisations per point, a uniformly
random heading per run, the errors of eq. 3 (Δα_d = 0.4°, W = 3 cm) and K outliers injected as
Sec. 3.1 says. All runs are drawn up front from one seed, so every localizer sees the very same
measurements (common random numbers) and the result does not depend on how work is split.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from azgym.bench.run.profiles import AS_SHIPPED, SimulatedNoise
from azgym.bench.suites.base import Case
from azgym.core import BeaconMap, BoolArray, FloatArray, Measurements, wrap_angle
from azgym.errors import InvalidInputError
from azgym.sensing.synthetic import ideal_azimuths, inject_outliers
from azgym.site import Scenario, load_scenario

__all__ = ["ProtocolConfig", "Runs", "build", "cases_of", "draw_runs", "grid_points", "near_beacon"]

PAPER_OUTLIER_COUNTS = (0, 1, 3, 5)
NEAR_BEACON_RADIUS = 0.5
"""Grid points closer than this to a beacon [m] are also reported separately (a grid point may
coincide with a beacon, where the paper's protocol leaves the azimuth undefined)."""


@dataclass(frozen=True)
class ProtocolConfig:
    """What to run.

    Attributes:
        grid_step: Spacing of the test grid [m] (the paper: 1 m, giving 23 × 23 points).
        realisations: Noise realisations per grid point (the paper: 20).
        outlier_counts: The values of K to run (the paper: 0, 1, 3, 5).
        seed: Seed of every random draw.
    """

    grid_step: int = 1
    realisations: int = 20
    outlier_counts: tuple[int, ...] = PAPER_OUTLIER_COUNTS
    seed: int = 2021

    def __post_init__(self) -> None:
        if not (isinstance(self.grid_step, int) and self.grid_step >= 1):
            raise InvalidInputError(f"grid_step must be an integer >= 1, got {self.grid_step!r}")
        if not (isinstance(self.realisations, int) and self.realisations >= 1):
            raise InvalidInputError(
                f"realisations must be an integer >= 1, got {self.realisations!r}"
            )

    @classmethod
    def quick(cls, seed: int = 2021) -> ProtocolConfig:
        """A small version for smoke tests and the README: every other grid point, 2 runs each."""
        return cls(grid_step=2, realisations=2, seed=seed)


@dataclass(frozen=True)
class Runs:
    """Every run of one outlier count K, as arrays over runs (R = points × realisations).

    Attributes:
        outliers: K.
        x, y, heading: True poses [m, m, rad], shape (R,).
        point: Index of the run's grid point, shape (R,).
        azimuth: Measured azimuths of all beacons, shape (R, N).
        outlier_mask: Which measurements were corrupted, shape (R, N).
        near_beacon: Whether the run's grid point is within NEAR_BEACON_RADIUS of a beacon.
    """

    outliers: int
    x: FloatArray
    y: FloatArray
    heading: FloatArray
    point: np.ndarray
    azimuth: FloatArray
    outlier_mask: BoolArray
    near_beacon: BoolArray

    def __len__(self) -> int:
        return int(self.x.size)


def grid_points(scenario: Scenario, step: int) -> FloatArray:
    """The test grid: integer points of the room every ``step`` metres, shape (P, 2)."""
    x_min, y_min, x_max, y_max = scenario.bounds
    xs = np.arange(math.ceil(x_min), math.floor(x_max) + 1, step, dtype=float)
    ys = np.arange(math.ceil(y_min), math.floor(y_max) + 1, step, dtype=float)
    gx, gy = np.meshgrid(xs, ys, indexing="xy")
    return np.c_[gx.ravel(), gy.ravel()]


def near_beacon(points: FloatArray, beacons: BeaconMap) -> BoolArray:
    """Whether each point lies within NEAR_BEACON_RADIUS of some beacon (horizontally)."""
    distance = np.hypot(points[:, None, 0] - beacons.xy[None, :, 0],
                        points[:, None, 1] - beacons.xy[None, :, 1])
    return np.any(distance < NEAR_BEACON_RADIUS, axis=1)


def draw_runs(scenario: Scenario, config: ProtocolConfig) -> list[Runs]:
    """Draw the measurements of every run, one :class:`Runs` per outlier count."""
    beacons = scenario.beacons
    points = grid_points(scenario, config.grid_step)
    near = near_beacon(points, beacons)
    streams = np.random.SeedSequence(config.seed).spawn(len(config.outlier_counts))
    result = []
    for k, stream in zip(config.outlier_counts, streams, strict=False):
        rng = np.random.default_rng(stream)
        point = np.repeat(np.arange(len(points)), config.realisations)
        count = point.size
        heading = rng.uniform(-math.pi, math.pi, size=count)
        azimuth = np.empty((count, len(beacons)))
        mask = np.zeros((count, len(beacons)), dtype=bool)
        for r in range(count):
            x, y = points[point[r]]
            ideal, distance = ideal_azimuths(x, y, heading[r], beacons)
            noisy = wrap_angle(ideal + scenario.error_model.sample(distance, beacons.width, rng))
            azimuth[r], mask[r] = inject_outliers(noisy, k, rng)
        result.append(Runs(outliers=k, x=points[point, 0], y=points[point, 1], heading=heading,
                           point=point, azimuth=azimuth, outlier_mask=mask,
                           near_beacon=near[point]))
    return result


def cases_of(scenario: Scenario, runs: list[Runs]) -> list[Case]:
    """The runs as cases, in order, grouped "K=k".

    Every beacon is measured; a case's cause is "outlier" when some measurement was corrupted.
    """
    cases = []
    for batch in runs:
        for r in range(len(batch)):
            cause = "outlier" if batch.outlier_mask[r].any() else "clean"
            cases.append(Case(scenario.name, Measurements(scenario.beacons.ids, batch.azimuth[r]),
                              (float(batch.x[r]), float(batch.y[r]), float(batch.heading[r])),
                              cause, f"K={batch.outliers}"))
    return cases


def build(seed: int, quick: bool, noise: SimulatedNoise = AS_SHIPPED) -> list[Case]:
    """The paper suite: the very runs of ``azgym reproduce paper`` (quick: of its quick version).

    ``noise`` sets the azimuth errors of eq. 3 (as shipped: the paper's).
    """
    scenario = noise.scenario(load_scenario("paper-room"))
    config = ProtocolConfig.quick(seed=seed) if quick else ProtocolConfig(seed=seed)
    return cases_of(scenario, draw_runs(scenario, config))

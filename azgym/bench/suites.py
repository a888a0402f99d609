"""Benchmark suites: fixed, versioned sets of frames that every localizer is scored on.

A suite draws its frames from a seed. The ``dev`` split uses the suite's fixed seed, so anyone can
reproduce and study it; the ``test`` split uses a seed drawn fresh at run time (and reported), so
nobody can tune to it. Every frame records its cause — the worst fault among its detections — so
results can be broken down by cause.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from azgym.core import Measurements
from azgym.errors import unknown_name
from azgym.layout import Faults
from azgym.reproduce.protocol import ProtocolConfig, draw_runs
from azgym.scenario import Scenario, load_scenario
from azgym.sensing import geometry as G
from azgym.sensing.image_sensor import ImageSensor
from azgym.sensing.sensor import Sensor
from azgym.simulate import image_drive, simulate

CAUSES = ("clean", "partial", "moved", "ghost", "misidentified", "outlier")
"""Frame causes, from harmless to harmful; a frame's cause is its worst detection's."""

# A distractor (a lamp's blob, with no id) is harmless to a localizer that ignores unknown ids.
_LABEL_CAUSE = {G.DIRECT: 0, G.PARTIAL: 1, G.MOVED: 2, G.GHOST: 3, G.MISIDENTIFIED: 4,
                G.DISTRACTOR: 0}


@dataclass(frozen=True, eq=False)
class Frame:
    """One case of a suite: what the localizer gets, and what it is scored against.

    Attributes:
        scenario: Name of the scenario (its beacon map is the localizer's map).
        measurements: The frame's detections.
        pose: The true camera pose (x, y, heading) [m, m, rad].
        cause: The worst fault among the detections (one of ``CAUSES``).
        group: A sub-set name for reports (e.g. "K=3", "as shipped").
    """

    scenario: str
    measurements: Measurements
    pose: tuple[float, float, float]
    cause: str
    group: str


@dataclass(frozen=True)
class Suite:
    """A named, versioned benchmark suite.

    Attributes:
        name: Identifier (``azgym bench --suite NAME``).
        version: Bumped whenever the frames it draws change.
        description: One line for listings and reports.
        dev_seed: The seed of the public ``dev`` split.
        build: ``build(seed, quick)`` draws the frames.
    """

    name: str
    version: int
    description: str
    dev_seed: int
    build: Callable[[int, bool], list[Frame]]


def frame_cause(labels: np.ndarray) -> str:
    """The worst cause among a frame's detection labels (``geometry`` label codes)."""
    worst = max((_LABEL_CAUSE[int(label)] for label in labels), default=0)
    return CAUSES[worst]


def _static_frames(scenario: Scenario, count: int, rng: np.random.Generator,
                   group: str) -> list[Frame]:
    """Frames at random poses in the room, off the racks, with a random heading."""
    sensor = Sensor(scenario)
    x_min, y_min, x_max, y_max = scenario.bounds
    frames = []
    while len(frames) < count:
        x, y = rng.uniform((x_min + 0.5, y_min + 0.5), (x_max - 0.5, y_max - 0.5))
        if any(rack.contains(x, y, margin=-0.8) for rack in scenario.racks):
            continue
        heading = float(rng.uniform(-math.pi, math.pi))
        measurements, truth = sensor.observe(x, y, heading, rng)
        frames.append(Frame(scenario.name, measurements, (float(x), float(y), heading),
                            frame_cause(truth.label), group))
    return frames


def _levels(scenario: Scenario) -> dict[str, Scenario]:
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


def _paper(seed: int, quick: bool) -> list[Frame]:
    scenario = load_scenario("paper-room")
    # The very runs of `azgym reproduce paper` (with --quick: of its quick version).
    config = ProtocolConfig.quick(seed=seed) if quick else ProtocolConfig(seed=seed)
    frames = []
    for runs in draw_runs(scenario, config):
        for r in range(len(runs)):
            cause = "outlier" if runs.outlier_mask[r].any() else "clean"
            frames.append(Frame(scenario.name, Measurements(scenario.beacons.ids, runs.azimuth[r]),
                                (float(runs.x[r]), float(runs.y[r]), float(runs.heading[r])),
                                cause, f"K={runs.outliers}"))
    return frames


def _warehouse_static(seed: int, quick: bool) -> list[Frame]:
    rng = np.random.default_rng(seed)
    frames = []
    for name in ("warehouse-small", "warehouse-paper"):
        for level, scenario in _levels(load_scenario(name)).items():
            frames += _static_frames(scenario, 40 if quick else 400, rng, f"{name}, {level}")
    return frames


def _warehouse_routes(seed: int, quick: bool) -> list[Frame]:
    frames = []
    for name in ("warehouse-small", "warehouse-paper"):
        scenario = load_scenario(name)
        routes = scenario.routes[:1] if quick else scenario.routes
        for k, route in enumerate(routes):
            for frame in simulate(scenario, route, seed=seed + k):
                frames.append(Frame(name, frame.measurements, frame.pose,
                                    frame_cause(frame.truth.label), f"{name}/{route.name}"))
    return frames[::4] if quick else frames


def _image_routes(seed: int, quick: bool) -> list[Frame]:
    """The routes through the image path: rendered, detected, ids decoded from blinking.

    The camera runs at 30 Hz (the blob tracker needs it, see ``azgym study ids``); every third
    frame is scored, as a 10 Hz localizer would use them.
    """
    frames = []
    for name in ("warehouse-small", "warehouse-paper"):
        scenario = load_scenario(name)
        routes = scenario.routes[:1] if quick else scenario.routes
        for k, route in enumerate(routes):
            sensor = ImageSensor(scenario, ids="blink", seed=seed + k)
            drive = image_drive(sensor, route, [seed, k], camera_rate_hz=30.0)
            for index, (pose, image) in enumerate(drive):
                if index % (12 if quick else 3) == 0:
                    frames.append(Frame(name, image.measurements, pose,
                                        frame_cause(image.labels), f"{name}/{route.name}"))
    return frames


def _stress(seed: int, quick: bool) -> list[Frame]:
    rng = np.random.default_rng(seed)
    heavy = _levels(load_scenario("warehouse-large"))["heavy"]
    return _static_frames(heavy, 60 if quick else 600, rng, "warehouse-large, heavy")


SUITES: dict[str, Suite] = {suite.name: suite for suite in (
    Suite("paper", 1, "Rátosi & Simon Sec. 3: the paper room's 23 x 23 grid, 20 runs a point, "
          "K = 0, 1, 3, 5 (the runs of azgym reproduce paper)", 2021, _paper),
    Suite("warehouse-static", 1, "random poses in warehouse-small and warehouse-paper; faults "
          "clean, as shipped and heavy", 7, _warehouse_static),
    Suite("warehouse-routes", 2, "every route of warehouse-small and warehouse-paper, frame by "
          "frame at 10 Hz", 11, _warehouse_routes),
    Suite("image-routes", 2, "every route of warehouse-small and warehouse-paper through the "
          "fisheye image path: blobs detected from pixels, ids decoded from blinking (30 Hz "
          "camera, every third frame scored)", 17, _image_routes),
    Suite("stress", 1, "warehouse-large (64 beacons) with heavy faults: 5 % misreads, bright "
          "mirrors", 13, _stress),
)}


def get_suite(name: str) -> Suite:
    """The suite of that name ("Did you mean ...?" otherwise)."""
    if name not in SUITES:
        raise unknown_name("suite", name, SUITES)
    return SUITES[name]

"""What the navigator localizes with: the truth, a per-frame localizer, or a tracker fed motion.

A tracker (:mod:`azgym.track`) is a localizer with memory: between frames it predicts its state
with the wheel odometry and IMU samples since the previous frame, then corrects it with the
frame's azimuths. In the navigation environment the forklift's motion sensors
(:class:`azgym.world.motion_sensors.MotionSensors`, the default ``OdometryModel`` and
``ImuModel``) are sampled after every physics step, as on a driven route; on each frame the
environment localizes, the tracker predicts with every sample up to that frame's time and
updates with its measurements. It starts each episode without the start pose
(``reset(seed, initial=None)``): like a localizer, it must find where it is from the frames.

The sensors' streams and the tracker's seed are drawn from the environment's generator at the
start of an episode, and only for a tracker, so a localizer's episodes are what they were
before trackers could drive. A localizer given as a tracker (``make_tracker("ransac")``, a
:class:`~azgym.track.base.FrameByFrame`) runs as the localizer itself, episode for episode.
"""

from __future__ import annotations

from typing import TypeGuard

import numpy as np

from azgym.core import BeaconMap, Estimate, Measurements
from azgym.errors import InvalidInputError
from azgym.localize.registry import SupportsLocalize, build, has_tracker_methods
from azgym.sensing.motion import ImuModel, OdometryModel
from azgym.track.base import FrameByFrame, SupportsTrack
from azgym.world.motion_sensors import MotionSensors
from azgym.world.world import World

__all__ = ["LocalizerFeed", "TrackerFeed", "feed_for", "is_tracker", "resolve_estimator"]

SEED_BOUND = 2**63
"""The seeds of an episode's motion sensors and tracker are drawn below this."""


def is_tracker(estimator: object) -> TypeGuard[SupportsTrack]:
    """Whether ``estimator`` runs as a tracker: no ``localize``, but reset, predict and update."""
    return not isinstance(estimator, (type, SupportsLocalize)) and has_tracker_methods(estimator)


def resolve_estimator(localizer: str | SupportsLocalize | SupportsTrack
                      ) -> SupportsLocalize | SupportsTrack | None:
    """None for ``"truth"``, else the localizer or tracker a name, spec or object stands for.

    Raises:
        UnknownNameError: No such name.
        InvalidInputError: A bad spec, or an object that is neither a localizer nor a tracker (a
            class is neither: an instance is).
    """
    if isinstance(localizer, str):
        if localizer == "truth":
            return None
        built = build(localizer)
    else:
        built = localizer
    if isinstance(built, FrameByFrame):
        built = built.localizer
    if isinstance(built, type) or not (isinstance(built, SupportsLocalize) or is_tracker(built)):
        raise InvalidInputError(
            f"localizer must be a name, \"truth\" or an object: a localizer (with "
            f"localize(measurements, beacons)) or a tracker (with reset, predict and update), "
            f"got {localizer!r}")
    return built


class LocalizerFeed:
    """A localizer in an episode: nothing to sample, each frame localized on its own.

    Args:
        localizer: The localizer.
    """

    def __init__(self, localizer: SupportsLocalize) -> None:
        self.localizer = localizer

    def reset(self, world: World, rng: np.random.Generator) -> None:
        """Start an episode: nothing to start (no draw from ``rng``)."""

    def step(self, world: World) -> None:
        """A physics step: nothing to sample."""

    def estimate(self, time: float, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """The localizer's estimate of the frame at ``time`` [s]."""
        return self.localizer.localize(measurements, beacons)


class TrackerFeed:
    """A tracker in an episode: the motion sensors sampled every physics step, fed per frame.

    Args:
        tracker: The tracker (reset, predict, update).
        dt: The world's physics step [s].
    """

    def __init__(self, tracker: SupportsTrack, dt: float) -> None:
        self.tracker = tracker
        self._dt = dt
        self._sensors: MotionSensors | None = None

    def reset(self, world: World, rng: np.random.Generator) -> None:
        """Start an episode in ``world``: fresh sensors and tracker, seeded from ``rng``."""
        odometry_seed, imu_seed, tracker_seed = (int(seed) for seed in
                                                 rng.integers(SEED_BOUND, size=3))
        self._sensors = MotionSensors(OdometryModel(), ImuModel(),
                                      np.random.default_rng(odometry_seed),
                                      np.random.default_rng(imu_seed), self._dt)
        self._sensors.step(world)
        self.tracker.reset(tracker_seed, None)

    def step(self, world: World) -> None:
        """Sample the physics step just taken."""
        self._started().step(world)

    def estimate(self, time: float, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """The tracker's estimate of the frame at ``time`` [s].

        It predicts with the samples up to that time (later ones wait for the next frame), then
        updates with the frame's measurements.
        """
        self.tracker.predict(self._started().motion(time))
        return self.tracker.update(measurements, beacons)

    def _started(self) -> MotionSensors:
        """The episode's motion sensors; refuses a call before :meth:`reset`."""
        if self._sensors is None:
            raise InvalidInputError("TrackerFeed: call reset() before step() or estimate()")
        return self._sensors


def feed_for(estimator: SupportsLocalize | SupportsTrack | None, dt: float
             ) -> LocalizerFeed | TrackerFeed | None:
    """What feeds and asks an estimator in an episode; None for the truth (nothing to ask).

    Args:
        estimator: What :func:`resolve_estimator` gave.
        dt: The world's physics step [s].
    """
    if estimator is None:
        return None
    if isinstance(estimator, SupportsLocalize):
        return LocalizerFeed(estimator)
    return TrackerFeed(estimator, dt)

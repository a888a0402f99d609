"""The tracker interface: ``reset``, then per frame ``predict`` (motion) and ``update`` (azimuths).

A tracker is a localizer with memory. Per camera frame the runner calls ``predict(motion)`` with
the odometry and IMU samples since the previous frame, then ``update(measurements, beacons)``,
which returns the frame's :class:`~azgym.core.Estimate`, with a covariance where the tracker
has one. ``reset(seed, initial)`` starts a new sequence (a route), optionally from a known pose
(a forklift leaving its dock).

The public methods validate and keep the bookkeeping; subclasses implement ``_reset``,
``_predict`` and ``_update``, with keyword-only hyperparameters as localizers have them
(:mod:`azgym.hyperparameters`). A per-frame localizer is a tracker without memory
(:class:`FrameByFrame`), so every suite scores both kinds side by side.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from azgym.core import BeaconMap, Estimate, Measurements, Pose
from azgym.errors import InvalidInputError
from azgym.hyperparameters import Hyperparameters
from azgym.localize.base import MAX_MEASUREMENTS
from azgym.localize.registry import SupportsLocalize, build, has_tracker_methods
from azgym.sensing.motion import Motion
from azgym.track._motion_check import NOT_FINITE, OUT_OF_ORDER, PARTLY_GIVEN, motion_fault

__all__ = ["COLUMNS", "FrameByFrame", "SupportsTrack", "Tracker", "check_choice", "check_motion",
           "make_tracker"]

STREAMS = ("odometry", "imu")
"""The motion streams, in the order :func:`check_motion` checks them."""
COLUMNS = {"odometry": ("speed", "steer", "yaw_rate"), "imu": ("yaw_rate", "ax", "ay")}
"""The value columns of each motion stream that :func:`check_motion` checks."""
OPTIONAL = {"odometry": np.array([False, True, True]), "imu": np.array([False, True, True])}
"""Which of them a stream may leave out (NaN throughout): a steered vehicle's odometry reports
no yaw rate, a differential drive's no steering angle, a log's IMU may give no accelerations."""


@runtime_checkable
class SupportsTrack(Protocol):
    """What azgym needs of a tracker: three methods. :class:`Tracker` adds validation on top.

    A plug-in tracker need not derive from :class:`Tracker`: any object with these methods runs
    in the benchmark and the environments.
    """

    def reset(self, seed: int | None = None, initial: Pose | None = None) -> None:
        """Start a new sequence, from the pose ``initial`` (x, y, heading) if it is known."""
        ...

    def predict(self, motion: Motion) -> None:
        """Move the state with the motion samples since the previous frame."""
        ...

    def update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """The frame's estimate, after correcting the state with its measurements."""
        ...


class Tracker(Hyperparameters, ABC):
    """Base class of every tracker (module docstring); subclasses set ``name``."""

    name: ClassVar[str] = ""

    def reset(self, seed: int | None = None, initial: Pose | None = None) -> None:
        """Start a new sequence: forget the past, seed any randomness, start at ``initial``.

        Args:
            seed: Seed of the tracker's own random draws (particles, sampled triplets).
            initial: A known start pose (x, y, heading) [m, m, rad], or None: unknown.

        Raises:
            InvalidInputError: ``initial`` is not three finite numbers.
        """
        self._validate_once()
        if initial is not None:
            try:
                pose = np.asarray(initial, dtype=np.float64)
            except (TypeError, ValueError):
                pose = np.full(0, np.nan)
            if pose.shape != (3,) or not np.isfinite(pose).all():
                raise InvalidInputError(
                    f"{type(self).__name__}.reset: initial must be a finite pose (x, y, "
                    f"heading), got {initial!r}")
            initial = (float(pose[0]), float(pose[1]), float(pose[2]))
        object.__setattr__(self, "_clock", -math.inf)
        object.__setattr__(self, "_given", (0, 0))
        self._reset(np.random.default_rng(seed), initial)

    def predict(self, motion: Motion) -> None:
        """Move the state to ``motion.time`` with the motion samples since the previous frame.

        A frame may repeat the previous frame's time (it then carries no samples), and samples
        may repeat a time stamp.

        Raises:
            InvalidInputError: Before ``reset``; a time before the previous one; samples out of
                order, outside (previous time, time], or not finite, except a column a stream
                leaves out (NaN in every sample of every frame: :data:`OPTIONAL`; an IMU
                heading may be NaN in any sample: no orientation sensor).
        """
        clock = self._started("predict")
        self._validate_once()
        given = check_motion(motion, clock)
        self._check_columns(given)
        object.__setattr__(self, "_clock", float(motion.time))
        self._predict(motion)

    def update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """The frame's estimate, after correcting the state with its measurements.

        Raises:
            InvalidInputError: Before ``reset``, or arguments of the wrong type or size.
        """
        self._started("update")
        if not isinstance(measurements, Measurements):
            raise InvalidInputError(
                f"measurements must be an azgym.Measurements, got {type(measurements).__name__}")
        if not isinstance(beacons, BeaconMap):
            raise InvalidInputError(
                f"beacons must be an azgym.BeaconMap, got {type(beacons).__name__}")
        if measurements.ids.size > MAX_MEASUREMENTS:
            raise InvalidInputError(
                f"measurements has {len(measurements)} detections, more than the "
                f"{MAX_MEASUREMENTS} a tracker accepts in one frame")
        self._validate_once()
        return self._update(measurements, beacons)

    def _check_columns(self, given: tuple[int, int]) -> None:
        """Refuse a stream that gives a column it left out before, or leaves out one it gave."""
        seen = self.__dict__["_given"]
        if given == seen:
            return
        for stream, columns, before in zip(STREAMS, given, seen, strict=True):
            if not (columns and before) or before == columns:  # a stream without samples gives 0
                continue
            c = next(c for c in range(len(COLUMNS[stream])) if (before ^ columns) >> c & 1)
            now, earlier = ("given", "NaN") if columns >> c & 1 else ("NaN", "given")
            raise InvalidInputError(
                f"motion.{stream}.{COLUMNS[stream][c]} is {now} in this frame's samples but was "
                f"{earlier} in earlier frames: a column is given throughout a stream or left out "
                "(NaN) throughout")
        # A stream's first samples say which columns it gives from now on.
        merged = tuple(before or columns for columns, before in zip(given, seen, strict=True))
        object.__setattr__(self, "_given", merged)

    def _columns(self, stream: str) -> int:
        """Which of the stream's :data:`COLUMNS` the sequence's samples give (bit c: column c).

        As :func:`check_motion` found them in the frames with samples so far; any frame's samples
        give the same (a change is refused).
        """
        return int(self.__dict__["_given"][STREAMS.index(stream)])

    def _started(self, method: str) -> float:
        """The time of the last prediction; refuses a call before ``reset``."""
        clock = self.__dict__.get("_clock")
        if clock is None:
            raise InvalidInputError(
                f"{type(self).__name__}.{method} called before reset(): a tracker starts each "
                "sequence with reset(seed, initial)")
        return clock

    @abstractmethod
    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        """Start a sequence (validated arguments)."""

    @abstractmethod
    def _predict(self, motion: Motion) -> None:
        """Move the state with validated motion samples."""

    @abstractmethod
    def _update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """Correct the state with one frame; return its estimate."""


def check_motion(motion: Any, after: float) -> tuple[int, int]:
    """Refuse motion data a tracker cannot use: out of order, in the past, or not finite.

    Returns:
        Per stream of :data:`STREAMS`, which of its :data:`COLUMNS` it gives (bit c for column
        c; 0: no samples).
    """
    if not isinstance(motion, Motion):
        raise InvalidInputError(f"motion must be an azgym Motion, got {type(motion).__name__}")
    if not math.isfinite(motion.time) or motion.time < after:
        raise InvalidInputError(
            f"motion.time must be finite and not before the previous frame's ({after!r}), got "
            f"{motion.time!r}")
    odometry, imu = motion.odometry, motion.imu
    at_fault, fault, column, odometry_given, imu_given = motion_fault(
        after, float(motion.time), odometry.time, odometry.speed, odometry.steer,
        odometry.yaw_rate, imu.time, imu.yaw_rate, imu.accel, OPTIONAL["odometry"],
        OPTIONAL["imu"])
    if fault:
        stream = STREAMS[at_fault]
        time = (odometry, imu)[at_fault].time
        where = f"motion.{stream}" + (f".{COLUMNS[stream][column]}" if column >= 0 else ".time")
        if fault == OUT_OF_ORDER:
            raise InvalidInputError(
                f"{where} must not decrease and lie within ({after!r}, {motion.time!r}], got "
                f"{time.tolist()[:6]}")
        if fault == NOT_FINITE:
            raise InvalidInputError(f"{where} holds a NaN or infinite value")
        if fault == PARTLY_GIVEN:
            raise InvalidInputError(
                f"{where} is NaN in some samples only: a column is given throughout a stream or "
                "left out (NaN) throughout")
    return odometry_given, imu_given


def check_choice(owner: str, name: str, value: Any, choices: tuple[str, ...]) -> None:
    """Raise :class:`InvalidInputError` unless ``value`` is one of ``choices``."""
    if value not in choices:
        raise InvalidInputError(
            f"{owner}.{name} must be one of {', '.join(map(repr, choices))}, got {value!r}")


class FrameByFrame(Tracker):
    """A localizer as a tracker without memory: ``predict`` ignores motion, ``update`` localizes.

    Args:
        localizer: Anything with ``localize(measurements, beacons)``.
    """

    name = "frame-by-frame"

    def __init__(self, *, localizer: SupportsLocalize) -> None:
        self.localizer = localizer
        self._validate_once()

    def _check_params(self) -> None:
        if not isinstance(self.localizer, SupportsLocalize):
            raise InvalidInputError(
                f"FrameByFrame.localizer must have a localize(measurements, beacons) method, "
                f"got {type(self.localizer).__name__}")

    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        """Nothing to remember."""

    def _predict(self, motion: Motion) -> None:
        """Motion does not matter to a per-frame localizer."""

    def _update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        return self.localizer.localize(measurements, beacons)


def make_tracker(name: str, **params: Any) -> SupportsTrack:
    """Build a tracker from a name or spec; a localizer's comes wrapped in :class:`FrameByFrame`.

    Example:
        >>> import azgym
        >>> tracker = azgym.make_tracker("ransac")
        >>> type(tracker).__name__, type(tracker.localizer).__name__
        ('FrameByFrame', 'Ransac')

    Raises:
        UnknownNameError: No such name.
        InvalidInputError: A bad spec or hyperparameter, or an object that is neither.
    """
    built = build(name, **params)
    if isinstance(built, SupportsLocalize):
        return FrameByFrame(localizer=built)
    if not has_tracker_methods(built):
        raise InvalidInputError(
            f"{name!r} built a {type(built).__name__}, which is neither a localizer nor a "
            "tracker")
    return built

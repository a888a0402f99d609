"""The sensor interface: what every camera model does, and the one type of frame it returns.

A :class:`Sensor` looks from a camera pose and returns an :class:`Observation`: the
:class:`~azgym.core.Measurements` a localizer gets, the ground truth of every detection beside
them (never inside), and the image when the sensor makes one. The geometry sensor
(:class:`~azgym.sensing.geometry.sensor.GeometrySensor`) and the fisheye image sensor
(:class:`~azgym.sensing.image.sensor.ImageSensor`) implement it, so environments, the drive and
the suites never ask which one they hold.

Random draws: ``reset(seed)`` seeds what a sensor keeps for a whole sequence of frames (the
image sensor's bank of noise frames and the beacons' blinking phases) and forgets any state
(tracks); ``observe(..., rng)`` takes each frame's draws (noise, misreads) from the caller's
generator, so an environment's ``reset(seed=...)`` decides both.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from azgym.core import BoolArray, FloatArray, IntArray, Measurements, Pose
from azgym.sensing.labels import LABEL_NAMES

if TYPE_CHECKING:
    from azgym.sensing.image.detect import Blob
    from azgym.site import Scenario

Tilt = tuple[float, float]
"""(pitch, roll) of the camera's axis from the vertical [rad]."""
LEVEL: Tilt = (0.0, 0.0)
"""A camera looking straight up."""
CAMERA_RATE_HZ = 10.0
"""The camera's frame rate unless a sensor needs another (blinking ids need 30 Hz) [Hz]."""
Seed = int | Sequence[int] | np.random.SeedSequence | np.random.Generator | None
"""Anything ``numpy.random.default_rng`` takes."""


@dataclass(frozen=True, eq=False)
class DetectionTruth:
    """What really produced each detection of a frame, index for index with its measurements.

    Attributes:
        label: Cause of each detection (:mod:`azgym.sensing.labels`), shape (M,).
        beacon: Map row of the beacon whose light it is, −1 for none (a lamp, noise), shape (M,).
        azimuth: Its light's noise-free azimuth in the camera frame [rad]: the visible centroid
            for a partly covered beacon, the mirror direction for a ghost; NaN for none.
        visible: Visible share of its light's width (1 for a ghost, 0 for none), shape (M,).
        mirrored: Whether it is a mirror image (of a beacon or a lamp), shape (M,).
    """

    label: IntArray
    beacon: IntArray
    azimuth: FloatArray
    visible: FloatArray
    mirrored: BoolArray

    def label_names(self) -> list[str]:
        """The labels as words."""
        return [LABEL_NAMES[k] for k in self.label]


@dataclass(frozen=True, eq=False)
class Observation:
    """One camera frame: the measurements, their ground truth, and the image if there is one.

    Attributes:
        measurements: What a localizer gets, listed by azimuth (as a detector scanning the
            image around its centre lists them).
        truth: The ground truth of each measurement.
        in_view: Map rows of the beacons in direct view (whether or not detected: a blinking
            beacon may be dark), shape (V,).
        image: The 8-bit frame (image sensors only).
        blobs: The detected blobs, index for index with the measurements (image sensors only).
    """

    measurements: Measurements
    truth: DetectionTruth
    in_view: IntArray
    image: np.ndarray | None = None
    blobs: tuple[Blob, ...] = ()


@runtime_checkable
class Sensor(Protocol):
    """A camera model: ``reset`` before a sequence of frames, ``observe`` each one.

    Attributes:
        scenario: The site it sees.
        quality_names: What each column of ``Measurements.quality`` holds, e.g.
            ``("log_brightness",)`` or ``("area_px", "peak", "elongation")``.
        quality_high: The largest value of each quality column (the lowest is 0).
        frame_rate_hz: The frame rate it is made for [Hz].
    """

    scenario: Scenario
    quality_names: tuple[str, ...]
    quality_high: tuple[float, ...]
    frame_rate_hz: float

    def reset(self, seed: Seed = None) -> None:
        """Start a new sequence of frames; seed what the sensor keeps across frames."""
        ...

    def observe(self, pose: Pose, rng: np.random.Generator, tilt: Tilt = LEVEL) -> Observation:
        """The frame seen from the camera pose (x, y, heading), every draw taken from ``rng``."""
        ...

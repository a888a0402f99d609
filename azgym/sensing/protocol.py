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

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from azgym.core import BoolArray, FloatArray, IntArray, Measurements, Pose
from azgym.errors import InvalidInputError
from azgym.sensing.labels import LABEL_NAMES
from azgym.site.elements import CAMERA_RATE_HZ as CAMERA_RATE_HZ  # the sensors' default rate

if TYPE_CHECKING:
    from azgym.sensing.image.detect import Blob
    from azgym.site import Scenario

__all__ = ["AZIMUTH", "BEACON", "CAMERA_RATE_HZ", "ID", "LABEL", "LEVEL", "MIRRORED",
           "TRUE_AZIMUTH", "VISIBLE", "DetectionTruth", "Observation", "Seed", "Sensor", "Tilt",
           "check_pose"]

Tilt = tuple[float, float]
"""(pitch, roll) of the camera's axis from the vertical [rad]."""
LEVEL: Tilt = (0.0, 0.0)
"""A camera looking straight up."""
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


ID, BEACON, LABEL, MIRRORED = range(4)
"""Rows of ``Observation.ints``: decoded id, true beacon's map row (−1: none), label, mirrored."""
AZIMUTH = 0
"""Row of ``Observation.measured`` holding the azimuths; the quality columns follow it."""
TRUE_AZIMUTH, VISIBLE = range(2)
"""Rows of ``Observation.true``: the light's noise-free azimuth (NaN: none), visible share."""


class Observation:
    """One camera frame: the measurements, their ground truth, and the image if there is one.

    The frame is kept as three packed arrays, M columns each, listed by azimuth (as a detector
    scanning the image around its centre lists them); ``measurements`` and ``truth`` are read-only
    views of them, built when first read. One copy per array makes a frame, and an environment
    pads all rows of an array in one call, which keeps a step cheap.

    Attributes:
        measured: Rows azimuth [rad], then each quality column, shape (1 + Q, M), float64.
        true: Rows ``TRUE_AZIMUTH`` and ``VISIBLE``, shape (2, M), float64.
        ints: Rows ``ID``, ``BEACON``, ``LABEL``, ``MIRRORED`` (0 or 1), shape (4, M), int64.
        image: The 8-bit frame (image sensors only).
        blobs: The detected blobs, index for index with the measurements (image sensors only).
    """

    __slots__ = ("measured", "true", "ints", "image", "blobs", "_in_view", "_measurements",
                 "_truth")

    def __init__(self, measured: FloatArray, true: FloatArray, ints: IntArray, *,
                 in_view: IntArray | None = None, image: np.ndarray | None = None,
                 blobs: tuple[Blob, ...] = ()) -> None:
        for array in (measured, true, ints):
            array.setflags(write=False)
        self.measured, self.true, self.ints = measured, true, ints
        self.image, self.blobs = image, blobs
        self._in_view = in_view
        self._measurements: Measurements | None = None
        self._truth: DetectionTruth | None = None

    @classmethod
    def from_columns(cls, *, ids: ArrayLike, azimuth: ArrayLike, quality: ArrayLike | None,
                     label: ArrayLike, beacon: ArrayLike, true_azimuth: ArrayLike,
                     visible: ArrayLike, mirrored: ArrayLike, in_view: ArrayLike | None = None,
                     image: np.ndarray | None = None, blobs: Sequence[Blob] = ()
                     ) -> Observation:
        """A frame from one column per field, M entries each, listed here by azimuth.

        Every column is checked, and a bad one is named: ids, label and beacon are integers;
        azimuth, quality ((M,) or (M, Q)) and visible are finite; true_azimuth is finite or NaN
        (a blob no light explains); blobs are none or one per detection.

        Raises:
            InvalidInputError: A column of the wrong type, length or value.
        """
        measurements = Measurements(ids, azimuth, quality)
        count = len(measurements)
        beacon, label, mirrored = (_column(name, values, count, integer=True) for name, values in
                                   (("beacon", beacon), ("label", label), ("mirrored", mirrored)))
        if blobs and len(blobs) != count:
            raise InvalidInputError(f"Observation.blobs must be empty or hold {count} blobs, "
                                    f"got {len(blobs)}")
        quality = measurements.quality
        return cls._from_valid_columns(
            ids=measurements.ids, azimuth=measurements.azimuth,
            quality=(np.empty((count, 0)) if quality is None
                     else quality[:, None] if quality.ndim == 1 else quality),
            label=label, beacon=beacon,
            true_azimuth=_column("true_azimuth", true_azimuth, count, allow_nan=True),
            visible=_column("visible", visible, count), mirrored=mirrored,
            in_view=None if in_view is None else np.asarray(in_view, dtype=np.int64),
            image=image, blobs=blobs)

    @classmethod
    def _from_valid_columns(cls, *, ids: IntArray, azimuth: FloatArray, quality: FloatArray,
                            label: IntArray, beacon: IntArray, true_azimuth: FloatArray,
                            visible: FloatArray, mirrored: np.ndarray,
                            in_view: IntArray | None, image: np.ndarray | None,
                            blobs: Sequence[Blob]) -> Observation:
        """:meth:`from_columns` without the checks, for columns azgym's own sensors computed.

        Only for equal-length arrays: integer ids, label, beacon and mirrored; finite azimuths
        and quality (M, Q); true azimuths finite or NaN.
        """
        count, columns = quality.shape
        order = np.argsort(azimuth, kind="stable")
        measured = np.empty((1 + columns, count))
        measured[AZIMUTH] = azimuth[order]
        measured[AZIMUTH + 1:] = quality[order].T
        true = np.empty((2, count))
        true[TRUE_AZIMUTH], true[VISIBLE] = true_azimuth[order], visible[order]
        ints = np.empty((4, count), dtype=np.int64)
        ints[ID], ints[BEACON], ints[LABEL], ints[MIRRORED] = (
            ids[order], beacon[order], label[order], mirrored[order])
        return cls(measured, true, ints, in_view=in_view, image=image,
                   blobs=tuple(blobs[k] for k in order) if blobs else ())

    def __len__(self) -> int:
        return int(self.ints.shape[1])

    @property
    def measurements(self) -> Measurements:
        """What a localizer gets: ids, azimuths and quality ((M,) for one column, else (M, Q))."""
        if self._measurements is None:
            quality = self.measured[AZIMUTH + 1:]
            self._measurements = Measurements._from_frozen(
                self.ints[ID], self.measured[AZIMUTH], quality[0] if len(quality) == 1
                else quality.T)
        return self._measurements

    @property
    def truth(self) -> DetectionTruth:
        """The ground truth of each measurement."""
        if self._truth is None:
            mirrored = self.ints[MIRRORED] == 1
            mirrored.setflags(write=False)
            self._truth = DetectionTruth(label=self.ints[LABEL], beacon=self.ints[BEACON],
                                         azimuth=self.true[TRUE_AZIMUTH],
                                         visible=self.true[VISIBLE], mirrored=mirrored)
        return self._truth

    @property
    def in_view(self) -> IntArray:
        """Map rows of the beacons in direct view, detected or not (a blinking one may be dark).

        By default, the beacons of the non-mirrored detections.
        """
        if self._in_view is None:
            self._in_view = self.ints[BEACON][self.ints[MIRRORED] == 0]
        return self._in_view


@runtime_checkable
class Sensor(Protocol):
    """A camera model: ``reset`` before a sequence of frames, ``observe`` each one.

    Attributes:
        scenario: The site it sees.
        frame_rate_hz: The frame rate it is made for [Hz].
    """

    scenario: Scenario
    frame_rate_hz: float

    @property
    def quality_names(self) -> tuple[str, ...]:
        """What each column of ``Measurements.quality`` holds.

        For example ``("log_brightness",)`` or ``("area_px", "peak", "elongation")``.
        """
        ...

    @property
    def quality_high(self) -> tuple[float, ...]:
        """The largest value of each quality column (the lowest is 0)."""
        ...

    def reset(self, seed: Seed = None) -> None:
        """Start a new sequence of frames; seed what the sensor keeps across frames."""
        ...

    def observe(self, pose: Pose, rng: np.random.Generator, tilt: Tilt = LEVEL) -> Observation:
        """The frame seen from the camera pose (x, y, heading), every draw taken from ``rng``."""
        ...


def check_pose(pose: Pose) -> Pose:
    """The camera pose (x, y, heading) as given; refuses one of another length or not finite.

    Cheap on purpose (every frame goes through it): three ``math.isfinite`` calls.
    """
    try:
        x, y, heading = pose
        if math.isfinite(x) and math.isfinite(y) and math.isfinite(heading):
            return pose
    except (TypeError, ValueError):
        raise InvalidInputError(f"pose must be (x, y, heading) numbers, got {pose!r}") from None
    raise InvalidInputError(f"pose must be finite, got {tuple(pose)}")


def _column(name: str, values: ArrayLike, count: int, *, integer: bool = False,
            allow_nan: bool = False) -> np.ndarray:
    """One column of an observation: ``count`` integers, or finite floats (NaN if allowed)."""
    array = np.asarray(values)
    if array.shape != (count,):
        raise InvalidInputError(f"Observation.{name} must have shape ({count},), got "
                                f"{array.shape}")
    if integer:
        if count and array.dtype.kind not in "iub":  # signed, unsigned, bool
            raise InvalidInputError(f"Observation.{name} must hold integers, got dtype "
                                    f"{array.dtype}")
        return array
    if array.dtype.kind not in "iuf":
        raise InvalidInputError(f"Observation.{name} must be numeric, got {array.dtype}")
    bad = np.isinf(array) if allow_nan else ~np.isfinite(array)
    if bad.any():
        raise InvalidInputError(f"Observation.{name} must be finite, got {array[bad][0]} at "
                                f"index {int(np.flatnonzero(bad)[0])}")
    return array

"""A survey's inputs: the drives (frames with their motion), what is known beforehand, the settings.

A drive is what a tracker gets along one sequence: per camera frame its time, its detections
(ids and azimuths) and the motion samples since the previous frame, and possibly the pose it
started from. A simulated route gives one (:func:`simulated_drive`); a log gives one per
sequence (:func:`log_drives`). What is known beforehand (:class:`Prior`) is an optional map and
which of its beacons are surveyed anchors; the settings (:class:`Settings`) are the vehicle's,
the camera's and the motion sensors' (a profile's fields, :func:`settings_from_profile`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from azgym.core import BeaconMap, FloatArray, Measurements, Pose
from azgym.errors import InvalidInputError
from azgym.logs.frames import frame_measurements, frame_motions
from azgym.logs.read import Log
from azgym.profile import FORKLIFT, VEHICLE_KINDS, Profile
from azgym.sensing.motion import DifferentialOdometryModel, ImuModel, Motion
from azgym.site.error_model import check_azimuth_noise
from azgym.track.kinematics import WHEELBASE
from azgym.track.unicycle import VEHICLE_DEFAULTS, YAW_SOURCES, MotionNoise
from azgym.world.drive import Frame

__all__ = ["LOSSES", "MIN_MAP_SIGMA", "Drive", "Prior", "Settings", "SurveyFrame", "drive_list",
           "log_drives", "settings_from_profile", "simulated_drive"]

LOSSES = ("cauchy", "huber")
"""The robust losses of the azimuth factors (docs/mapping.md: why Cauchy is the default)."""
MIN_MAP_SIGMA = 0.001
"""Least :attr:`Settings.map_sigma` [m]: no map is surveyed finer than a millimetre, and a
prior much stiffer than its beacon's azimuths leaves the beacon's position without its prior
(:func:`~azgym.mapping.graph.left_out`: its information less the prior's) to rounding."""


@dataclass(frozen=True, eq=False)
class SurveyFrame:
    """One camera frame of a drive.

    Attributes:
        time: The frame's time [s].
        measurements: Its detections (ids, azimuths in the camera frame).
        motion: The odometry and IMU samples since the previous frame, up to ``time``.
    """

    time: float
    measurements: Measurements
    motion: Motion


@dataclass(frozen=True, eq=False)
class Drive:
    """One sequence of frames driven in a row, and the camera pose it started from if known.

    Attributes:
        frames: The frames, in time order.
        start: The camera pose (x, y, heading) at the first frame [m, m, rad], or None.
        name: What the messages call it (``sequence 2``).
    """

    frames: tuple[SurveyFrame, ...]
    start: Pose | None = None
    name: str = "the drive"


@dataclass(frozen=True, eq=False)
class Prior:
    """What is known before the survey.

    Attributes:
        beacons: A map (positions possibly stale), or None. Its widths are the beacons' widths;
            with ``check_moved`` its positions are tested against the survey's. When it holds
            beacons beyond the anchors it is the site's map, and an id it lacks is a misread
            one (:attr:`ids`).
        anchors: Ids of beacons whose map positions are surveyed (held fixed); each must be in
            ``beacons``.
    """

    beacons: BeaconMap | None = None
    anchors: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.anchors and self.beacons is None:
            raise InvalidInputError(
                f"anchors {list(self.anchors)} were given without a map holding their positions")
        if self.beacons is not None:
            known = set(self.beacons.ids.tolist())
            unknown = [a for a in self.anchors if a not in known]
            if unknown:
                raise InvalidInputError(
                    f"anchor id{'s' if len(unknown) > 1 else ''} {unknown} not in the map "
                    f"(its ids: {sorted(known)[:20]}{' ...' if len(known) > 20 else ''})")
        if len(set(self.anchors)) != len(self.anchors):
            raise InvalidInputError(f"anchors repeat an id: {list(self.anchors)}")

    @property
    def ids(self) -> frozenset[int] | None:
        """The ids a survey may answer, or None for any.

        The map's, when it holds beacons beyond the anchors (the site's map: an id it lacks is
        a misread one, not a beacon); None without a map or with one of the anchors alone (the
        map unknown but for them, every other beacon to be found).
        """
        if self.beacons is None or len(self.beacons.ids) <= len(self.anchors):
            return None
        return frozenset(self.beacons.ids.tolist())

    @property
    def mapped(self) -> dict[int, FloatArray]:
        """The map position (x, y) of each beacon a survey holds by the map, not as an anchor.

        A site's map (:attr:`ids` not None) is mostly right even when stale: its beacons beyond
        the anchors are priors of the survey (:attr:`Settings.map_sigma`). Empty without a map,
        or with one of the anchors alone.
        """
        if self.ids is None or self.beacons is None:
            return {}
        held = set(self.anchors)
        return {int(i): self.beacons.xyz[k, :2].copy()
                for k, i in enumerate(self.beacons.ids.tolist()) if i not in held}


@dataclass(frozen=True)
class Settings:
    """The vehicle, camera and motion sensors a survey assumes (a profile's fields).

    Attributes:
        vehicle: ``"forklift"`` or ``"differential-drive"``.
        yaw_source: ``"gyro"`` or ``"odometry"``; None: the vehicle's.
        camera_ahead: The camera's offset ahead of the turning axis [m]; None: the vehicle's.
        wheelbase: A forklift's wheelbase [m].
        speed_factor: True over read distance of the odometry [1].
        noise: The motion sensors' errors (the trackers' :class:`MotionNoise`).
        delta_alpha_d: Δα_d, half-width of the centre-detection error [rad] (eq. 1).
        coverage: Whether eq. 2's coverage error applies.
        extra_sigma: Azimuth noise beyond the error model (sway, rendering) [rad].
        loss: The azimuth factors' robust loss, one of :data:`LOSSES`.
        loss_scale: Where the loss turns robust, in standard deviations of the azimuth.
        start_bias: Spread of the turn rate's bias at a drive's start [rad/s]; None: the turn
            rate source's (a gyro's, :class:`~azgym.sensing.motion.ImuModel`; a differential
            drive's odometry's, :class:`~azgym.sensing.motion.DifferentialOdometryModel`).
        map_sigma: Standard deviation of each position of a site's map given as the prior
            (:attr:`Prior.mapped`) [m]: how well it was surveyed (a total station's centimetre).
            Each such beacon is held there by that much, behind the robust loss, until the
            drive shows it moved (docs/mapping.md, "The model" and "Moved beacons").
    """

    vehicle: str = FORKLIFT
    yaw_source: str | None = None
    camera_ahead: float | None = None
    wheelbase: float = WHEELBASE
    speed_factor: float = 1.0
    noise: MotionNoise = field(default_factory=MotionNoise)
    delta_alpha_d: float = math.radians(0.4)
    coverage: bool = True
    extra_sigma: float = math.radians(0.1)
    loss: str = "cauchy"
    loss_scale: float = 3.0
    start_bias: float | None = None
    map_sigma: float = 0.01

    def __post_init__(self) -> None:
        if self.vehicle not in VEHICLE_KINDS:
            raise InvalidInputError(f"vehicle must be one of {VEHICLE_KINDS}, got "
                                    f"{self.vehicle!r}")
        if self.yaw_source is not None and self.yaw_source not in YAW_SOURCES:
            raise InvalidInputError(f"yaw_source must be one of {YAW_SOURCES}, got "
                                    f"{self.yaw_source!r}")
        if self.loss not in LOSSES:
            raise InvalidInputError(f"loss must be one of {LOSSES}, got {self.loss!r}")
        for name in ("loss_scale", "wheelbase", "speed_factor"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"{name} must be a positive number, got {value!r}")
        if not (math.isfinite(self.map_sigma) and self.map_sigma >= MIN_MAP_SIGMA):
            raise InvalidInputError(f"map_sigma must be a number of at least {MIN_MAP_SIGMA} m, "
                                    f"got {self.map_sigma!r}")
        if self.start_bias is not None and not (math.isfinite(self.start_bias)
                                                and self.start_bias >= 0.0):
            raise InvalidInputError(f"start_bias must be a number >= 0 [rad/s] or None, got "
                                    f"{self.start_bias!r}")
        check_azimuth_noise("survey settings", self.delta_alpha_d, self.extra_sigma)

    @property
    def turn_source(self) -> str:
        """Where the turn rate comes from."""
        return VEHICLE_DEFAULTS[self.vehicle][0] if self.yaw_source is None else self.yaw_source

    @property
    def turn_rate_bias(self) -> float:
        """Spread of the turn rate's bias at a drive's start [rad/s] (``start_bias``)."""
        if self.start_bias is not None:
            return self.start_bias
        return (ImuModel().gyro_bias if self.turn_source == "gyro"
                else DifferentialOdometryModel().turn_rate_bias)

    @property
    def lever(self) -> float:
        """The camera's offset ahead of the turning axis [m]."""
        return float(VEHICLE_DEFAULTS[self.vehicle][1] if self.camera_ahead is None
                     else self.camera_ahead)


def settings_from_profile(profile: Profile, **overrides: object) -> Settings:
    """The settings a profile gives (its ``[vehicle]``, ``[sensor]``, ``[motion]`` fields).

    Raises:
        InvalidInputError: A field of the wrong kind or out of range.
    """
    given = profile.hyperparameters() | overrides
    noise_fields = set(MotionNoise.__dataclass_fields__)
    noise = MotionNoise(**{k: v for k, v in given.items() if k in noise_fields})
    own = set(Settings.__dataclass_fields__) - {"noise"}
    return Settings(noise=noise, **{k: v for k, v in given.items() if k in own})


def simulated_drive(frames: Iterable[Frame], start: Pose | None = None) -> Drive:
    """A simulated route's frames (:func:`azgym.world.drive.simulate`) as a drive."""
    return Drive(tuple(SurveyFrame(f.time, f.measurements, f.motion) for f in frames), start,
                 "the route")


def log_drives(log: Log) -> list[Drive]:
    """A log's sequences as drives, each starting from its true pose where the log has one.

    A sequence's known start is its first frame's true pose, with a heading (a forklift leaving
    its dock); a log without heading truth gives none.

    Raises:
        InvalidInputError: The log has no odometry or IMU (a survey drives between frames).
    """
    if not log.driven:
        raise InvalidInputError(
            f"{log.folder}: the log has no odometry.csv or imu.csv; a survey needs the motion "
            "between frames to place the camera")
    frames = log.frames
    times = frames["time"]
    motions = frame_motions(log)
    sequences = frames["sequence"]
    drives: list[Drive] = []
    measurements = frame_measurements(log)
    edges = [0, *(np.flatnonzero(sequences[1:] != sequences[:-1]) + 1).tolist()]
    for first, stop in zip(edges, [*edges[1:], len(times)], strict=True):
        pose = log.pose(first)
        start = None if pose is None or math.isnan(pose[2]) else pose
        drives.append(Drive(tuple(SurveyFrame(float(times[k]), measurements[k], motions[k])
                                  for k in range(first, stop)), start,
                            f"sequence {sequences[first]}"))
    return drives


def drive_list(drives: Drive | Sequence[Drive]) -> list[Drive]:
    """One drive or several, as a list."""
    return [drives] if isinstance(drives, Drive) else list(drives)

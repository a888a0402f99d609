"""Wheel odometry and an IMU, sampled at their own rates, for the trackers to fuse.

Samples are taken at physics steps, so a rate above the physics rate is capped there.
Wheel odometry reports the drive speed and the steering angle: the speed with a slowly varying
scale error (tyre slip, wheel wear: a random walk) and white noise, the steering angle with white
noise. The IMU reports the yaw rate (a gyro with a bias that random-walks, and white noise), the
linear acceleration in the body frame (white noise) and, optionally, an absolute heading from an
orientation sensor (white noise). ``ImuModel.plotter()`` is the smartphone of Dang et al. (2015):
26 Hz, accelerometer variance 0.011 (m/s²)² and orientation variance 0.235 deg².
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from azgym.core import FloatArray


@dataclass(frozen=True)
class OdometryModel:
    """Wheel odometry errors.

    Attributes:
        rate_hz: Samples per second.
        speed_noise: White noise on the speed [m/s].
        scale_walk: Random walk of the speed's scale error [1/√s].
        steer_noise: White noise on the steering angle [rad].
    """

    rate_hz: float = 50.0
    speed_noise: float = 0.02
    scale_walk: float = 0.002
    steer_noise: float = math.radians(0.5)


@dataclass(frozen=True)
class ImuModel:
    """IMU errors.

    Attributes:
        rate_hz: Samples per second.
        gyro_noise: White noise on the yaw rate [rad/s].
        gyro_bias: Standard deviation of the gyro's initial bias [rad/s].
        gyro_bias_walk: Random walk of the bias [rad/s/√s].
        accel_noise: White noise on each acceleration axis [m/s²].
        orientation_noise: White noise of an absolute heading sensor [rad]; None: no such sensor.
    """

    rate_hz: float = 50.0
    gyro_noise: float = 0.005
    gyro_bias: float = 0.005
    gyro_bias_walk: float = 1e-4
    accel_noise: float = 0.05
    orientation_noise: float | None = None

    @classmethod
    def plotter(cls) -> ImuModel:
        """The smartphone sensors of Dang et al. (2015), Sec. V-A, at their 26 Hz."""
        return cls(rate_hz=26.0, accel_noise=math.sqrt(0.011),
                   orientation_noise=math.radians(math.sqrt(0.235)))


@dataclass(frozen=True, eq=False)
class OdometrySamples:
    """Odometry samples, K of them, each array of shape (K,).

    A steered vehicle's odometry reports the steering angle, a differential drive's (or any
    odometry that reports how fast it turns) the turn rate; the one not reported is NaN
    throughout (left out, it is filled so).

    Attributes:
        time: Sample times [s].
        speed: Forward speed [m/s].
        steer: Steering angle [rad] (NaN: not reported).
        yaw_rate: Turn rate, counter-clockwise [rad/s] (NaN: not reported).
    """

    time: FloatArray
    speed: FloatArray
    steer: FloatArray
    yaw_rate: FloatArray = None  # type: ignore[assignment]  # NaN-filled in __post_init__

    def __post_init__(self) -> None:
        if self.yaw_rate is None:
            object.__setattr__(self, "yaw_rate", np.full(np.shape(self.time), math.nan))

    @classmethod
    def turning(cls, time: FloatArray, speed: FloatArray, yaw_rate: FloatArray
                ) -> OdometrySamples:
        """Samples of an odometry that reports the turn rate (no steering angle)."""
        return cls(time, speed, np.full(np.shape(time), math.nan), yaw_rate)

    @property
    def reports_yaw_rate(self) -> bool:
        """Whether these samples give the turn rate rather than the steering angle."""
        return bool(np.size(self.time)) and not np.isnan(self.yaw_rate).all()


@dataclass(frozen=True, eq=False)
class ImuSamples:
    """IMU samples, K of them.

    Attributes are ``time`` [s], ``yaw_rate`` [rad/s], ``accel`` (K, 2) in the body frame
    (forward, left) [m/s²] and ``heading`` [rad] (NaN without an orientation sensor).
    """

    time: FloatArray
    yaw_rate: FloatArray
    accel: FloatArray
    heading: FloatArray


@dataclass(frozen=True, eq=False)
class Motion:
    """What the motion sensors reported between two camera frames: a tracker's ``predict``.

    Attributes:
        time: The new frame's time [s]; a tracker predicts its state up to it.
        odometry: Wheel odometry samples since the previous frame, in time order.
        imu: IMU samples since the previous frame, in time order.
    """

    time: float
    odometry: OdometrySamples
    imu: ImuSamples


def joined(motions: list[Motion]) -> Motion:
    """The motion over several frames in a row, as one: every sample, up to the last one's time.

    For a suite that scores every n-th frame: the tracker of a scored frame gets what the motion
    sensors reported since the previous scored frame.
    """
    if len(motions) == 1:
        return motions[0]
    odometry = OdometrySamples(*(np.concatenate([getattr(m.odometry, key) for m in motions])
                                 for key in ("time", "speed", "steer", "yaw_rate")))
    imu = ImuSamples(*(np.concatenate([getattr(m.imu, key) for m in motions])
                       for key in ("time", "yaw_rate", "accel", "heading")))
    return Motion(motions[-1].time, odometry, imu)


class Odometer:
    """Produces odometry samples from the true speed and steering, at the model's rate."""

    def __init__(self, model: OdometryModel, rng: np.random.Generator) -> None:
        self.model = model
        self._rng = rng
        self._scale = 0.0
        self._next = 0.0
        self._rows: list[tuple[float, float, float]] = []

    def update(self, time: float, speed: float, steer: float) -> None:
        """Sample if a sample is due at ``time`` (called every physics step)."""
        model = self.model
        if time + 1e-12 < self._next:
            return
        period = 1.0 / model.rate_hz
        self._scale += model.scale_walk * math.sqrt(period) * self._rng.standard_normal()
        noise = self._rng.standard_normal(2)
        self._rows.append((time, speed * (1.0 + self._scale) + model.speed_noise * noise[0],
                           steer + model.steer_noise * noise[1]))
        self._next += period

    def take(self, until: float = math.inf) -> OdometrySamples:
        """The samples since the last call, up to time ``until`` [s] (later ones wait)."""
        time, speed, steer = np.array(_taken(self._rows, until), dtype=np.float64).reshape(-1, 3).T
        return OdometrySamples(time=time.copy(), speed=speed.copy(), steer=steer.copy())


class Imu:
    """Produces IMU samples from the true yaw rate, acceleration and heading, at its rate."""

    def __init__(self, model: ImuModel, rng: np.random.Generator) -> None:
        self.model = model
        self._rng = rng
        self._bias = model.gyro_bias * rng.standard_normal()
        self._next = 0.0
        self._rows: list[tuple[float, float, float, float, float]] = []

    def update(self, time: float, yaw_rate: float, accel: tuple[float, float],
               heading: float) -> None:
        """Sample if a sample is due at ``time`` (called every physics step)."""
        model = self.model
        if time + 1e-12 < self._next:
            return
        period = 1.0 / model.rate_hz
        noise = self._rng.standard_normal(5)
        self._bias += model.gyro_bias_walk * math.sqrt(period) * noise[0]
        measured_heading = math.nan
        if model.orientation_noise is not None:
            measured_heading = heading + model.orientation_noise * noise[4]
        self._rows.append((time, yaw_rate + self._bias + model.gyro_noise * noise[1],
                           accel[0] + model.accel_noise * noise[2],
                           accel[1] + model.accel_noise * noise[3], measured_heading))
        self._next += period

    def take(self, until: float = math.inf) -> ImuSamples:
        """The samples since the last call, up to time ``until`` [s] (later ones wait)."""
        rows = _taken(self._rows, until)
        time, yaw_rate, ax, ay, heading = np.array(rows, dtype=np.float64).reshape(-1, 5).T
        return ImuSamples(time=time.copy(), yaw_rate=yaw_rate.copy(),
                          accel=np.column_stack([ax, ay]), heading=heading.copy())


def _taken(rows: list[tuple[float, ...]], until: float) -> list[tuple[float, ...]]:
    """Remove and return the rows (in time order, time first) taken at or before ``until``.

    A camera frame may fall between two physics steps (a 30 Hz camera, a 50 Hz physics): the
    samples after it belong to the next frame.
    """
    count = bisect.bisect_right(rows, until, key=lambda row: row[0])
    taken = rows[:count]
    del rows[:count]
    return taken

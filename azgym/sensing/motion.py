"""Wheel odometry and an IMU, sampled at their own rates, for the trackers to fuse.

Samples are taken at physics steps, so a rate above the physics rate is capped there.
Wheel odometry reports the drive speed and the steering angle: the speed with a slowly varying
scale error (tyre slip, wheel wear: a random walk) and white noise, the steering angle with white
noise. The IMU reports the yaw rate (a gyro with a bias that random-walks, and white noise), the
linear acceleration in the body frame (white noise) and, optionally, an absolute heading from an
orientation sensor (white noise). ``ImuModel.plotter()`` is the smartphone of Dang et al. (2015):
26 Hz, accelerometer variance 0.011 (m/s²)² and orientation variance 0.235 deg².

A differential-drive robot's odometry (:class:`DifferentialOdometryModel`) reports the forward
speed and the turn rate, stamped as a real logger stamps them: 10 ms apart mostly, 20-50 ms when
the logger is busy, an occasional gap over 0.1 s, repeated stamps at millisecond resolution. Its
distance reads short by a scale (a wheel's radius off by 10 %) and its turn rate carries a bias
that wanders, so that its heading drifts by degrees a second.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.profile import MotionProfile

__all__ = ["DifferentialOdometer", "DifferentialOdometryModel", "Imu", "ImuModel", "ImuSamples",
           "Motion", "Odometer", "OdometryModel", "OdometrySamples", "joined"]


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


@dataclass(frozen=True)
class DifferentialOdometryModel:
    """A differential drive's odometry: forward speed and turn rate, stamped by a busy logger.

    Each interval between stamps is drawn: a repeated stamp (0) at ``repeat_share``, a gap of
    ``gap`` at ``gap_share``, a busy interval of ``busy`` at ``busy_share``, else the nominal
    ``period`` with ``period_jitter`` (each range uniform); stamps are rounded to
    ``stamp_resolution``. A sample reads the true speed times the run's scale,
    (1 + ``speed_scale`` · N(0, 1)) / ``speed_factor``, plus ``speed_noise``; and the true turn
    rate plus the run's bias (N(0, ``turn_rate_bias``), walking by ``bias_walk``) plus
    ``turn_rate_noise``. The defaults follow a real recording of a wheeled robot (docs/robot.md).

    Attributes:
        period: Nominal interval between samples [s].
        period_jitter: Half-width of the nominal interval's jitter [s].
        busy: Range of a busy logger's intervals [s].
        busy_share: Share of busy intervals.
        gap: Range of a gap's length [s].
        gap_share: Share of gaps.
        repeat_share: Share of samples stamped like the one before.
        stamp_resolution: The logger's clock tick [s].
        speed_factor: True distance over read distance, the run's mean [1].
        speed_scale: Standard deviation of a run's scale error around it [1].
        speed_noise: White noise of a speed sample [m/s].
        turn_rate_noise: White noise of a turn-rate sample [rad/s].
        turn_rate_bias: Standard deviation of a run's turn-rate bias at the start [rad/s].
        bias_walk: Random walk of the turn-rate bias [rad/s/√s].
    """

    period: float = 0.0098
    period_jitter: float = 0.0015
    busy: tuple[float, float] = (0.020, 0.050)
    busy_share: float = 0.25
    gap: tuple[float, float] = (0.10, 0.30)
    gap_share: float = 0.002
    repeat_share: float = 0.03
    stamp_resolution: float = 0.001
    speed_factor: float = 1.1
    speed_scale: float = 0.02
    speed_noise: float = 0.01
    turn_rate_noise: float = 0.2
    turn_rate_bias: float = 0.015
    bias_walk: float = 0.001

    def __post_init__(self) -> None:
        for name in ("period", "stamp_resolution", "speed_factor"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise InvalidInputError(f"DifferentialOdometryModel.{name} must be > 0, got "
                                        f"{getattr(self, name)!r}")
        for name in ("period_jitter", "speed_scale", "speed_noise", "turn_rate_noise",
                     "turn_rate_bias", "bias_walk"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise InvalidInputError(f"DifferentialOdometryModel.{name} must be >= 0, got "
                                        f"{getattr(self, name)!r}")
        if not self.period_jitter < self.period:
            raise InvalidInputError("DifferentialOdometryModel.period_jitter must be less than "
                                    f"its period {self.period}, got {self.period_jitter!r}")
        shares = (self.busy_share, self.gap_share, self.repeat_share)
        if not (all(0 <= share <= 1 for share in shares) and sum(shares) < 1):
            raise InvalidInputError("DifferentialOdometryModel's busy_share, gap_share and "
                                    f"repeat_share must be >= 0 and sum to < 1, got {shares}")
        for name in ("busy", "gap"):
            low, high = getattr(self, name)
            if not 0 < low <= high < math.inf:
                raise InvalidInputError(f"DifferentialOdometryModel.{name} must be a range "
                                        f"(low, high) with 0 < low <= high, got "
                                        f"{getattr(self, name)!r}")

    def motion_profile(self) -> MotionProfile:
        """Its errors as a profile's ``[motion]`` section: what ``azgym calibrate`` should find.

        The start bias (``turn_rate_bias``) has no profile field and is left out.
        """
        return MotionProfile(speed_factor=self.speed_factor, speed_scale=self.speed_scale,
                             speed_noise=self.speed_noise, turn_rate_noise=self.turn_rate_noise,
                             bias_walk=self.bias_walk)


@dataclass(frozen=True, eq=False, init=False)
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
    yaw_rate: FloatArray

    def __init__(self, time: FloatArray, speed: FloatArray, steer: FloatArray,
                 yaw_rate: FloatArray | None = None) -> None:
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "speed", speed)
        object.__setattr__(self, "steer", steer)
        object.__setattr__(self, "yaw_rate", np.full(np.shape(time), math.nan)
                           if yaw_rate is None else yaw_rate)

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

    @classmethod
    def none(cls) -> ImuSamples:
        """No samples: a vehicle without an IMU."""
        return cls(np.empty(0), np.empty(0), np.empty((0, 2)), np.empty(0))


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


class DifferentialOdometer:
    """Produces a differential drive's odometry samples at its logger's stamps.

    Each physics step reports the velocity it held over its span (:meth:`update`); every stamp
    in that span gets a sample of it. The run's scale and bias are drawn at construction.
    """

    def __init__(self, model: DifferentialOdometryModel, rng: np.random.Generator) -> None:
        self.model = model
        self._rng = rng
        self._scale = (1.0 + model.speed_scale * rng.standard_normal()) / model.speed_factor
        self._bias = model.turn_rate_bias * rng.standard_normal()
        self._next = max(1, round(model.period / model.stamp_resolution))  # the next stamp [ticks]
        self._previous = 0
        self._rows: list[tuple[float, float, float]] = []

    def _interval(self) -> float:
        """The next interval between stamps [s] (the class docstring's mixture)."""
        model = self.model
        u, v = self._rng.random(2)
        if u < model.repeat_share:
            return 0.0
        u -= model.repeat_share
        if u < model.gap_share:
            return model.gap[0] + v * (model.gap[1] - model.gap[0])
        u -= model.gap_share
        if u < model.busy_share:
            return model.busy[0] + v * (model.busy[1] - model.busy[0])
        return model.period + (2.0 * v - 1.0) * model.period_jitter

    def update(self, time: float, speed: float, yaw_rate: float) -> None:
        """Sample every stamp up to ``time`` [s]: the velocity held since the previous call."""
        model = self.model
        tick = model.stamp_resolution
        while self._next * tick <= time + 1e-12:
            stamp = self._next * tick
            walk = math.sqrt((self._next - self._previous) * tick)
            noise = self._rng.standard_normal(3)
            self._bias += model.bias_walk * walk * noise[0]
            self._rows.append((stamp, speed * self._scale + model.speed_noise * noise[1],
                               yaw_rate + self._bias + model.turn_rate_noise * noise[2]))
            self._previous = self._next
            self._next += round(self._interval() / tick)

    def take(self, until: float = math.inf) -> OdometrySamples:
        """The samples since the last call, up to time ``until`` [s] (later ones wait)."""
        rows = _taken(self._rows, until)
        time, speed, yaw_rate = np.array(rows, dtype=np.float64).reshape(-1, 3).T
        return OdometrySamples.turning(time.copy(), speed.copy(), yaw_rate.copy())


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


_Row = TypeVar("_Row", bound=tuple[float, ...])


def _taken(rows: list[_Row], until: float) -> list[_Row]:
    """Remove and return the rows (in time order, time first) taken at or before ``until``.

    A camera frame may fall between two physics steps (a 30 Hz camera, a 50 Hz physics): the
    samples after it belong to the next frame.
    """
    count = bisect.bisect_right(rows, until, key=lambda row: row[0])
    taken = rows[:count]
    del rows[:count]
    return taken

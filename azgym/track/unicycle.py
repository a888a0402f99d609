"""The trackers' motion model: the camera carried by a unicycle driven by odometry and a turn rate.

The state is the camera pose, the turn rate's bias b and the odometry's scale correction k,
``[x, y, φ, b, k]`` (``STATE_SIZE`` = 5): both sensor errors wander slowly (``OdometryModel``,
``ImuModel``), and estimating them keeps dead reckoning straight through an outage. Between two
frames the vehicle's turning axis (a forklift's reference axle, the one that does not steer; a
differential drive's wheel axle) moves at the odometry's speed v f (1 + k) along the heading,
f the odometry's known ``speed_factor``, and turns at the measured rate ω − b: the gyro's, or the
odometry's (a differential drive's reported yaw rate, or a forklift's v tan δ / L;
:func:`~azgym.track.kinematics.odometry_yaw_rates`). The camera sits ``lever`` metres ahead of
that axis (negative: behind it), so it also slides sideways at ω · lever: a forklift's camera,
behind its steering-free front axle, swings out in turns (:mod:`azgym.world.forklift`).

Each frame is one step with the mean speed and yaw rate of its samples and the heading at the
step's midpoint; a frame longer than ``MAX_STEP_S`` (the first after an outage) is cut into
steps of its own. Time the motion sensors did not cover (a stream that stopped, or a forklift
carried with its sensors off) moves nothing and adds the variance of any motion within the
vehicle's limits: a teleport shows up as a covariance the azimuths then overrule.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from azgym.core import FloatArray
from azgym.profile import DIFFERENTIAL_DRIVE, FORKLIFT
from azgym.sensing.motion import ImuModel, Motion, OdometryModel
from azgym.track.kinematics import CAMERA_AHEAD, odometry_yaw_rates
from azgym.track.unicycle_steps import (
    HOLD_FLOOR_S,
    HOLD_PERIODS,
    IBIAS,
    IPHI,
    ISCALE,
    IX,
    IY,
    MAX_FRAME_STEPS,
    MAX_STEP_S,
    PERIOD_HISTORY,
    STATE_SIZE,
    UNSEEN_HORIZON_S,
    advance,
    frame_steps,
    hold_streams,
    new_streams,
    predict_step,
)
from azgym.world.forklift import ForkliftSpec

__all__ = ["HOLD_FLOOR_S", "HOLD_PERIODS", "IBIAS", "IPHI", "ISCALE", "IX", "IY",
           "MAX_FRAME_STEPS", "MAX_STEP_S", "PERIOD_HISTORY", "STATE_SIZE", "UNSEEN_HORIZON_S",
           "VEHICLE_DEFAULTS", "YAW_SOURCES", "MotionNoise",
           "MotionSteps", "Step", "predict"]


@dataclass(frozen=True)
class MotionNoise:
    """What a frame's prediction is unsure of, from the sensors' models and the model's own error.

    Attributes:
        speed_noise: White noise of one odometry speed sample [m/s].
        speed_scale: Standard deviation of the odometry's scale error at the start [1].
        scale_walk: Random walk of that scale error [1/√s] (tyre wear, slip).
        turn_rate_noise: White noise of one turn-rate sample (gyro or odometry) [rad/s].
        bias_walk: Random walk of the turn rate's bias [rad/s/√s].
        position_walk: Model error of the position (the body lagging the command) [m/√s].
        heading_walk: Model error of the heading [rad/√s].
        max_speed: Fastest the forklift moves when no sensor watches [m/s].
        max_turn_rate: Fastest it turns then [rad/s].
    """

    speed_noise: float = OdometryModel().speed_noise
    speed_scale: float = 0.02
    scale_walk: float = OdometryModel().scale_walk
    turn_rate_noise: float = ImuModel().gyro_noise
    bias_walk: float = ImuModel().gyro_bias_walk
    position_walk: float = 0.02
    heading_walk: float = 0.002
    max_speed: float = ForkliftSpec().max_speed
    max_turn_rate: float = 2.0

    @cached_property
    def vector(self) -> FloatArray:
        """The fields as an array, in their order: what the compiled prediction takes."""
        return np.array([getattr(self, name) for name in self.__dataclass_fields__],
                        dtype=np.float64)


class Step(NamedTuple):
    """One prediction step: what the motion sensors say happened over ``seconds``.

    Attributes:
        speed: Mean odometry speed over the observed time [m/s].
        yaw_rate: Mean measured yaw rate over the observed time [rad/s].
        observed: Seconds both streams covered.
        seconds: The step's length [s].
        unseen: Seconds no sensor watched, charged to this step (see :meth:`MotionSteps.steps`).
        speed_spread: The speed samples' Σ hold² (each sample's hold time squared, summed) times
            ``speed_factor``² [s²]: the step's distance has variance ``speed_noise``² times it.
        turn_spread: The turn-rate samples' Σ hold² [s²], likewise for the heading.
    """

    speed: float
    yaw_rate: float
    observed: float
    seconds: float
    unseen: float
    speed_spread: float = 0.0
    turn_spread: float = 0.0


YAW_SOURCES = ("gyro", "odometry")
"""Where a tracker's turn rate comes from: the IMU's gyro, or the odometry
(:func:`~azgym.track.kinematics.odometry_yaw_rates`)."""
VEHICLE_DEFAULTS = {FORKLIFT: ("gyro", CAMERA_AHEAD), DIFFERENTIAL_DRIVE: ("odometry", 0.0)}
"""Per vehicle kind, the ``yaw_source`` and ``camera_ahead`` [m] a tracker assumes when they are
not given: a forklift turns by its gyro and carries the camera 0.5 m behind its front axle; a
differential drive's odometry reports its turn rate, and its camera is taken over the axle."""


class MotionSteps:
    """Turns each frame's :class:`Motion` into unicycle steps: mean speed, mean yaw rate, time.

    Each stream (the odometry's speed, the turn rate) is held (zero-order) from sample to sample:
    a sample taken at t_k describes the motion of the step that follows it (the simulator, like
    most drive controllers, applies a commanded rate until the next command), so a frame's
    motion over (t_prev, t] is the previous frame's last sample up to the first new one, then
    each new sample in turn. A sample holds for at most max(``HOLD_PERIODS`` typical periods,
    ``HOLD_FLOOR_S``), the typical period being the median of the stream's latest
    ``PERIOD_HISTORY`` intervals (repeated time stamps left out): jitter is held over, a stopped
    stream is not. The arithmetic is compiled (:mod:`azgym.track.unicycle_steps`).

    Args:
        period: The sample period assumed until a stream's spacing shows its own [s].
        yaw_source: One of :data:`YAW_SOURCES`.
        vehicle: The vehicle kind (``azgym.profile.VEHICLE_KINDS``), for the odometry's turn rate.
        wheelbase: A forklift's wheelbase [m], likewise.
        speed_factor: True over read distance of the odometry [1].
    """

    def __init__(self, period: float, yaw_source: str = "gyro", vehicle: str = FORKLIFT,
                 wheelbase: float = ForkliftSpec().wheelbase, speed_factor: float = 1.0) -> None:
        self.period = float(period)
        self.streams = new_streams()
        self.yaw_source, self.vehicle = yaw_source, vehicle
        self.wheelbase, self.speed_factor = wheelbase, float(speed_factor)
        self.time: float | None = None

    def steps(self, motion: Motion) -> list[Step]:
        """The frame's steps: one, unless it spans more than ``MAX_STEP_S``.

        Time no sensor watched is charged whole to the last step: an unobserved stretch is one
        unknown motion, whose spread grows with its whole length, not a sum of independent ones.
        The first frame of a sequence has no start: it only starts the clock and the holds (the
        start pose is the pose at its time), and has no steps.
        """
        frame = self._frame(motion)
        if frame is None:
            return []
        rows = frame_steps(self.streams, *frame, self.speed_factor, self.period)
        return [Step(*row) for row in rows.tolist()]

    def advance(self, motion: Motion, state: FloatArray, cov: FloatArray, lever: float,
                noise: MotionNoise, move: bool) -> None:
        """:meth:`steps`, and when ``move``, :func:`predict` through them: one compiled call."""
        frame = self._frame(motion)
        if frame is not None:
            advance(self.streams, *frame, self.speed_factor, self.period, state, cov,
                    float(lever), noise.vector, move)

    def _frame(self, motion: Motion) -> tuple[FloatArray, int, float, float] | None:
        """The frame's samples and their odometry count (:meth:`_samples`), its start and end.

        None for a sequence's first frame, whose samples only start the holds.
        """
        samples, speed_count = self._samples(motion)
        if self.time is None:
            self.time = motion.time
            hold_streams(self.streams, samples, speed_count)
            return None
        start, self.time = self.time, float(motion.time)
        return samples, speed_count, start, self.time

    def _samples(self, motion: Motion) -> tuple[FloatArray, int]:
        """The odometry's times and speeds, then the turn rate's times and rates, in one array.

        One new array, whatever the samples' own are (read-only from a run's wire, strided from
        a log's table): the kernels then have one specialization each, compiled once. Also the
        number of odometry samples.
        """
        odometry = motion.odometry
        if self.yaw_source == "gyro":
            turn_time, turn_rate = motion.imu.time, motion.imu.yaw_rate
        else:
            turn_time = odometry.time
            turn_rate = odometry_yaw_rates(odometry, self.vehicle, self.wheelbase)
        samples = np.concatenate((odometry.time, odometry.speed, turn_time, turn_rate),
                                 dtype=np.float64)
        return samples, int(odometry.time.size)


def predict(state: FloatArray, cov: FloatArray, step: Step, lever: float,
            noise: MotionNoise) -> None:
    """Move ``state`` and ``cov`` (in place) by one :class:`Step`.

    Entries past the first :data:`STATE_SIZE` (beacons a tracker keeps in its state) stand
    still; their cross-covariances with the pose move with it.
    """
    predict_step(state, cov, np.array(step, dtype=np.float64), float(lever), noise.vector)

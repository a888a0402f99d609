"""The trackers' motion model: the camera carried by a unicycle driven by odometry and the gyro.

The state is the camera pose, the gyro's bias b and the odometry's scale correction k,
``[x, y, φ, b, k]`` (``STATE_SIZE`` = 5): both sensor errors wander slowly (``OdometryModel``,
``ImuModel``), and estimating them keeps dead reckoning straight through an outage. Between two
frames the forklift's reference axle (the one that does not steer) moves at the odometry's speed
v (1 + k) along the heading and turns at the gyro's rate ω − b. The camera sits ``lever`` metres
ahead of that axle (negative: behind it), so it also slides sideways at ω · lever: a forklift's
camera, behind its steering-free front axle, swings out in turns (:mod:`azgym.world.forklift`).

Each frame is one step with the mean speed and yaw rate of its samples and the heading at the
step's midpoint; a frame longer than ``MAX_STEP_S`` (the first after an outage) is cut into
steps of its own. Time the motion sensors did not cover (a frame whose samples stop early, or a
forklift carried with its sensors off) moves nothing and adds the variance of any motion within
the forklift's limits: a teleport shows up as a covariance the azimuths then overrule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from azgym.core import FloatArray
from azgym.sensing.motion import ImuModel, Motion, OdometryModel
from azgym.world.forklift import ForkliftSpec

STATE_SIZE = 5
"""Length of the state ``[x, y, φ, b, k]``: camera position [m], heading [rad], gyro bias
[rad/s] and the odometry's scale correction k [1] (the true speed is (1 + k) times the read)."""
IX, IY, IPHI, IBIAS, ISCALE = range(STATE_SIZE)
"""Positions of x, y, heading, gyro bias and odometry scale correction in the state."""


def camera_lever(spec: ForkliftSpec) -> float:
    """How far the camera sits ahead of the reference (non-steering) axle [m]: the swing arm."""
    centre = -0.5 * spec.wheelbase if spec.rear_steer else 0.5 * spec.wheelbase
    return spec.camera_offset[0] + centre


@dataclass(frozen=True)
class MotionNoise:
    """What a frame's prediction is unsure of, from the sensors' models and the model's own error.

    Attributes:
        speed_noise: White noise of one odometry speed sample [m/s].
        speed_scale: Standard deviation of the odometry's scale error at the start [1].
        scale_walk: Random walk of that scale error [1/√s] (tyre wear, slip).
        gyro_noise: White noise of one gyro sample [rad/s].
        bias_walk: Random walk of the gyro bias [rad/s/√s].
        position_walk: Model error of the position (the body lagging the command) [m/√s].
        heading_walk: Model error of the heading [rad/√s].
        max_speed: Fastest the forklift moves when no sensor watches [m/s].
        max_turn_rate: Fastest it turns then [rad/s].
        rate_hz: Samples per second of each stream, for the noise of their means.
    """

    speed_noise: float = OdometryModel().speed_noise
    speed_scale: float = 0.02
    scale_walk: float = OdometryModel().scale_walk
    gyro_noise: float = ImuModel().gyro_noise
    bias_walk: float = ImuModel().gyro_bias_walk
    position_walk: float = 0.02
    heading_walk: float = 0.002
    max_speed: float = ForkliftSpec().max_speed
    max_turn_rate: float = 2.0
    rate_hz: float = OdometryModel().rate_hz


MAX_HOLD = 1.5
"""A sample holds for at most this many sample periods: after a longer silence the stream has
stopped (a forklift carried with its sensors off), and the time is unobserved."""


class HeldStream:
    """One motion stream under a zero-order hold: each sample holds until the next one.

    A sample taken at t_k describes the motion of the step that follows it (the simulator, like
    most drive controllers, applies a commanded rate until the next command), so a frame's motion
    over (t_prev, t] is the previous frame's last sample up to the first new one, then each new
    sample in turn. ``period`` is the stream's sample period [s], learnt from its spacing.
    """

    def __init__(self, period: float) -> None:
        self.period = period
        self.held: float | None = None
        self.held_since = -math.inf

    def integrate(self, times: FloatArray, values: FloatArray, start: float,
                  end: float) -> tuple[float, float]:
        """(integral of the rate, observed seconds) over (``start``, ``end``]; then hold on."""
        if times.size >= 2:
            self.period = float(times[-1] - times[0]) / (times.size - 1)
        limit = MAX_HOLD * self.period
        total = observed = 0.0
        if self.held is not None:
            until = min(float(times[0]) if times.size else end, self.held_since + limit)
            if until > start:
                total, observed = self.held * (until - start), until - start
        if times.size:
            ends = np.minimum(np.append(times[1:], end), times + limit)
            spans = np.maximum(ends - times, 0.0)
            total += float(values @ spans)
            observed += float(spans.sum())
            self.held, self.held_since = float(values[-1]), float(times[-1])
        return total, observed


class Step(NamedTuple):
    """One prediction step: what the motion sensors say happened over ``seconds``.

    Attributes:
        speed: Mean odometry speed over the observed time [m/s].
        yaw_rate: Mean measured yaw rate over the observed time [rad/s].
        observed: Seconds both streams covered.
        seconds: The step's length [s].
        unseen: Seconds no sensor watched, charged to this step (see :meth:`MotionSteps.steps`).
    """

    speed: float
    yaw_rate: float
    observed: float
    seconds: float
    unseen: float


MAX_STEP_S = 0.25
"""Longest prediction step [s]: a longer frame (the first after an outage, whose motion spans
seconds) is cut into equal steps no longer than this, each with its own samples' means. One
step with the mean speed and turn rate of a 3 s gap that held a straight and a turn put the
track metres off."""


class MotionSteps:
    """Turns each frame's :class:`Motion` into unicycle steps: mean speed, mean yaw rate, time.

    Args:
        period: The sample period assumed until a stream's spacing shows its own [s].
    """

    def __init__(self, period: float) -> None:
        self.odometry = HeldStream(period)
        self.imu = HeldStream(period)
        self.time: float | None = None

    def steps(self, motion: Motion) -> list[Step]:
        """The frame's steps: one, unless it spans more than ``MAX_STEP_S``.

        Time no sensor watched is charged whole to the last step: an unobserved stretch is one
        unknown motion, whose spread grows with its whole length, not a sum of independent ones.
        The first frame of a sequence has no start: it only starts the clock and the holds.
        """
        start = motion.time if self.time is None else self.time
        self.time = motion.time
        count = math.ceil((motion.time - start) / MAX_STEP_S)
        if count <= 1:  # the usual frame: one step, every sample
            step = self._step(motion, start, motion.time, slice(None), slice(None))
            return [step._replace(unseen=step.seconds - step.observed)]
        bounds = np.linspace(start, motion.time, count + 1)
        odometry = _cuts(motion.odometry.time, bounds)
        imu = _cuts(motion.imu.time, bounds)
        steps = [self._step(motion, float(bounds[k]), float(bounds[k + 1]), odometry[k], imu[k])
                 for k in range(count)]
        unseen = sum(step.seconds - step.observed for step in steps)
        steps[-1] = steps[-1]._replace(unseen=unseen)
        return steps

    def _step(self, motion: Motion, start: float, end: float, odometry: slice,
              imu: slice) -> Step:
        """One step over (``start``, ``end``], from the samples the slices pick."""
        distance, seen_odometry = self.odometry.integrate(
            motion.odometry.time[odometry], motion.odometry.speed[odometry], start, end)
        angle, seen_imu = self.imu.integrate(motion.imu.time[imu], motion.imu.yaw_rate[imu],
                                             start, end)
        tau = min(seen_odometry, seen_imu)
        speed = distance / seen_odometry if seen_odometry > 0 else 0.0
        rate = angle / seen_imu if seen_imu > 0 else 0.0
        return Step(speed, rate, tau, end - start, 0.0)


def _cuts(times: FloatArray, bounds: FloatArray) -> list[slice]:
    """Each step's samples: those up to its end, after the previous step's.

    The frame's samples all fall in its (start, end] (the tracker's motion check), so the first
    step takes every one up to its end.
    """
    edges = [0, *np.searchsorted(times, bounds[1:-1], side="right").tolist(), times.size]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def predict(state: FloatArray, cov: FloatArray, step: Step, lever: float,
            noise: MotionNoise) -> None:
    """Move ``state`` and ``cov`` (in place) by one :class:`Step`."""
    read, measured_rate, tau, dt, unseen = step
    v = read * (1.0 + state[ISCALE])
    omega = measured_rate - state[IBIAS]
    half = state[IPHI] + 0.5 * omega * tau
    c, s = math.cos(half), math.sin(half)
    dx = v * tau * c - lever * omega * tau * s
    dy = v * tau * s + lever * omega * tau * c
    jacobian = np.eye(STATE_SIZE)
    jacobian[IX, IPHI] = -dy
    jacobian[IY, IPHI] = dx
    jacobian[IX, IBIAS] = 0.5 * tau * dy + lever * tau * s
    jacobian[IY, IBIAS] = -0.5 * tau * dx - lever * tau * c
    jacobian[IPHI, IBIAS] = -tau
    jacobian[IX, ISCALE] = read * tau * c
    jacobian[IY, ISCALE] = read * tau * s
    state[IX] += dx
    state[IY] += dy
    state[IPHI] = math.remainder(state[IPHI] + omega * tau, 2.0 * math.pi)
    cov[:] = jacobian @ cov @ jacobian.T
    _add_noise(cov, v, tau, dt, unseen, c, s, noise)


def _add_noise(cov: FloatArray, v: float, tau: float, dt: float, unseen: float, c: float,
               s: float, noise: MotionNoise) -> None:
    """The step's process noise: along and across the track, heading, bias, unobserved time."""
    samples = max(tau * noise.rate_hz, 1.0)
    along = noise.speed_noise**2 / samples * tau**2 \
        + noise.position_walk**2 * tau
    across = noise.position_walk**2 * tau
    cov[IX, IX] += along * c * c + across * s * s
    cov[IY, IY] += along * s * s + across * c * c
    cov[IX, IY] += (along - across) * c * s
    cov[IY, IX] += (along - across) * c * s
    cov[IPHI, IPHI] += noise.gyro_noise**2 / samples * tau**2 + noise.heading_walk**2 * tau
    cov[IBIAS, IBIAS] += noise.bias_walk**2 * dt
    cov[ISCALE, ISCALE] += noise.scale_walk**2 * dt
    if unseen > 0.0:
        cov[IX, IX] += (noise.max_speed * unseen) ** 2
        cov[IY, IY] += (noise.max_speed * unseen) ** 2
        cov[IPHI, IPHI] += min((noise.max_turn_rate * unseen) ** 2, math.pi**2)

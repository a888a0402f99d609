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

import math
from collections import deque
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from azgym.core import FloatArray
from azgym.profile import DIFFERENTIAL_DRIVE, FORKLIFT
from azgym.sensing.motion import ImuModel, Motion, OdometryModel
from azgym.track.kinematics import CAMERA_AHEAD, odometry_yaw_rates
from azgym.world.forklift import ForkliftSpec

__all__ = ["HOLD_FLOOR_S", "HOLD_PERIODS", "IBIAS", "IPHI", "ISCALE", "IX", "IY", "MAX_STEP_S",
           "STATE_SIZE", "VEHICLE_DEFAULTS", "YAW_SOURCES", "HeldStream", "MotionNoise",
           "MotionSteps", "Step", "predict"]

STATE_SIZE = 5
"""Length of the state ``[x, y, φ, b, k]``: camera position [m], heading [rad], gyro bias
[rad/s] and the odometry's scale correction k [1] (the true speed is (1 + k) times the read)."""
IX, IY, IPHI, IBIAS, ISCALE = range(STATE_SIZE)
"""Positions of x, y, heading, gyro bias and odometry scale correction in the state."""


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


HOLD_PERIODS = 5.0
"""A sample holds for up to this many of its stream's typical (median) sample periods, ..."""
HOLD_FLOOR_S = 0.25
"""... and for at least this long [s]: a logger's jitter (a 100 Hz stream's 20-50 ms intervals,
its occasional 0.1-0.2 s gaps) is not a stream that stopped. After a longer silence the stream
has stopped (a forklift carried with its sensors off), and the time is unobserved."""
PERIOD_HISTORY = 64
"""How many of a stream's latest sample intervals its typical period is the median of."""


class HeldStream:
    """One motion stream under a zero-order hold: each sample holds until the next one.

    A sample taken at t_k describes the motion of the step that follows it (the simulator, like
    most drive controllers, applies a commanded rate until the next command), so a frame's motion
    over (t_prev, t] is the previous frame's last sample up to the first new one, then each new
    sample in turn. A sample holds for at most :meth:`limit`: max(``HOLD_PERIODS`` typical
    periods, ``HOLD_FLOOR_S``), the typical period being the median of the stream's latest
    intervals (repeated time stamps left out), so that jitter is held over and a stopped stream
    is not.

    Args:
        period: The sample period assumed until the stream shows its own [s].
    """

    def __init__(self, period: float) -> None:
        self.period = period
        self.recent: deque[FloatArray] = deque(maxlen=PERIOD_HISTORY + 1)
        self.held: float | None = None
        self.held_since = -math.inf

    def limit(self) -> float:
        """The longest a sample holds [s] (class docstring)."""
        recent = np.concatenate(self.recent)[-PERIOD_HISTORY - 1:] if self.recent else ()
        intervals = np.diff(recent)
        intervals = intervals[intervals > 0.0]
        typical = float(np.median(intervals)) if intervals.size else self.period
        return max(HOLD_PERIODS * typical, HOLD_FLOOR_S)

    def hold(self, times: FloatArray, values: FloatArray) -> None:
        """Take samples without integrating them (those before a sequence's first frame)."""
        self._remember(times)
        if times.size:
            self.held, self.held_since = float(values[-1]), float(times[-1])

    def _remember(self, times: FloatArray) -> None:
        """Keep (at least) the latest ``PERIOD_HISTORY`` + 1 sample times, for the period."""
        if times.size:
            self.recent.append(times)

    def integrate(self, times: FloatArray, values: FloatArray, start: float,
                  end: float) -> tuple[float, float, float]:
        """(integral of the rate, observed seconds, Σ hold²) over (``start``, ``end``].

        The last sample then holds on into the next call. Σ hold² is the sum of the squared
        times each sample held [s²]: a sample's white noise σ adds σ² times it to the
        integral's variance (σ² T / rate for a regular stream; a single noisy sample held over a
        logger's gap weighs as much as its hold). The hold's limit is only worked out when a
        gap is longer than ``HOLD_FLOOR_S`` (below it, no sample is cut short).
        """
        self._remember(times)
        first = float(times[0]) if times.size else end
        spans = np.append(times[1:], end) - times
        longest = first - self.held_since if self.held is not None else 0.0
        if times.size:
            longest = max(longest, float(spans.max()))
        limit = self.limit() if longest > HOLD_FLOOR_S else math.inf
        total = observed = spread = 0.0
        if self.held is not None:
            until = min(first, self.held_since + limit)
            if until > start:
                total, observed = self.held * (until - start), until - start
                spread = observed * observed
        if times.size:
            if limit < math.inf:
                spans = np.minimum(spans, limit)
            total += float(values @ spans)
            observed += float(spans.sum())
            spread += float(spans @ spans)
            self.held, self.held_since = float(values[-1]), float(times[-1])
        return total, observed, spread


class Step(NamedTuple):
    """One prediction step: what the motion sensors say happened over ``seconds``.

    Attributes:
        speed: Mean odometry speed over the observed time [m/s].
        yaw_rate: Mean measured yaw rate over the observed time [rad/s].
        observed: Seconds both streams covered.
        seconds: The step's length [s].
        unseen: Seconds no sensor watched, charged to this step (see :meth:`MotionSteps.steps`).
        speed_spread: The speed samples' Σ hold² (:meth:`HeldStream.integrate`) times
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


MAX_STEP_S = 0.25
"""Longest prediction step [s]: a longer frame (the first after an outage, whose motion spans
seconds) is cut into equal steps no longer than this, each with its own samples' means. One
step with the mean speed and turn rate of a 3 s gap that held a straight and a turn put the
track metres off."""


YAW_SOURCES = ("gyro", "odometry")
"""Where a tracker's turn rate comes from: the IMU's gyro, or the odometry
(:func:`~azgym.track.kinematics.odometry_yaw_rates`)."""
VEHICLE_DEFAULTS = {FORKLIFT: ("gyro", CAMERA_AHEAD), DIFFERENTIAL_DRIVE: ("odometry", 0.0)}
"""Per vehicle kind, the ``yaw_source`` and ``camera_ahead`` [m] a tracker assumes when they are
not given: a forklift turns by its gyro and carries the camera 0.5 m behind its front axle; a
differential drive's odometry reports its turn rate, and its camera is taken over the axle."""


class MotionSteps:
    """Turns each frame's :class:`Motion` into unicycle steps: mean speed, mean yaw rate, time.

    Args:
        period: The sample period assumed until a stream's spacing shows its own [s].
        yaw_source: One of :data:`YAW_SOURCES`.
        vehicle: The vehicle kind (``azgym.profile.VEHICLE_KINDS``), for the odometry's turn rate.
        wheelbase: A forklift's wheelbase [m], likewise.
        speed_factor: True over read distance of the odometry [1].
    """

    def __init__(self, period: float, yaw_source: str = "gyro", vehicle: str = FORKLIFT,
                 wheelbase: float = ForkliftSpec().wheelbase, speed_factor: float = 1.0) -> None:
        self.odometry = HeldStream(period)
        self.turn = HeldStream(period)
        self.yaw_source, self.vehicle = yaw_source, vehicle
        self.wheelbase, self.speed_factor = wheelbase, speed_factor
        self.time: float | None = None

    def steps(self, motion: Motion) -> list[Step]:
        """The frame's steps: one, unless it spans more than ``MAX_STEP_S``.

        Time no sensor watched is charged whole to the last step: an unobserved stretch is one
        unknown motion, whose spread grows with its whole length, not a sum of independent ones.
        The first frame of a sequence has no start: it only starts the clock and the holds (the
        start pose is the pose at its time), and has no steps.
        """
        odometry = motion.odometry
        if self.yaw_source == "gyro":
            turn_time, turn_rate = motion.imu.time, motion.imu.yaw_rate
        else:
            turn_time = odometry.time
            turn_rate = odometry_yaw_rates(odometry, self.vehicle, self.wheelbase)
        streams = (odometry.time, odometry.speed, turn_time, turn_rate)
        if self.time is None:
            self.time = motion.time
            self.odometry.hold(odometry.time, odometry.speed)
            self.turn.hold(turn_time, turn_rate)
            return []
        start, self.time = self.time, motion.time
        count = math.ceil((motion.time - start) / MAX_STEP_S)
        if count <= 1:  # the usual frame: one step, every sample
            step = self._step(streams, start, motion.time, slice(None), slice(None))
            return [step._replace(unseen=step.seconds - step.observed)]
        bounds = np.linspace(start, motion.time, count + 1)
        speed_cuts, turn_cuts = _cuts(odometry.time, bounds), _cuts(turn_time, bounds)
        steps = [self._step(streams, float(bounds[k]), float(bounds[k + 1]), speed_cuts[k],
                            turn_cuts[k]) for k in range(count)]
        unseen = sum(step.seconds - step.observed for step in steps)
        steps[-1] = steps[-1]._replace(unseen=unseen)
        return steps

    def _step(self, streams: tuple[FloatArray, ...], start: float, end: float, speed: slice,
              turn: slice) -> Step:
        """One step over (``start``, ``end``], from the samples the slices pick."""
        speed_time, speed_value, turn_time, turn_rate = streams
        distance, seen_odometry, speed_spread = self.odometry.integrate(
            speed_time[speed], speed_value[speed], start, end)
        angle, seen_turn, turn_spread = self.turn.integrate(turn_time[turn], turn_rate[turn],
                                                            start, end)
        tau = min(seen_odometry, seen_turn)
        mean_speed = self.speed_factor * distance / seen_odometry if seen_odometry > 0 else 0.0
        rate = angle / seen_turn if seen_turn > 0 else 0.0
        return Step(mean_speed, rate, tau, end - start, 0.0,
                    self.speed_factor**2 * speed_spread, turn_spread)


def _cuts(times: FloatArray, bounds: FloatArray) -> list[slice]:
    """Each step's samples: those up to its end, after the previous step's.

    The frame's samples all fall in its (start, end] (the tracker's motion check), so the first
    step takes every one up to its end.
    """
    edges = [0, *np.searchsorted(times, bounds[1:-1], side="right").tolist(), times.size]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def predict(state: FloatArray, cov: FloatArray, step: Step, lever: float,
            noise: MotionNoise) -> None:
    """Move ``state`` and ``cov`` (in place) by one :class:`Step`.

    Entries past the first :data:`STATE_SIZE` (beacons a tracker keeps in its state) stand
    still; their cross-covariances with the pose move with it.
    """
    read, measured_rate, tau = step.speed, step.yaw_rate, step.observed
    v = read * (1.0 + state[ISCALE])
    omega = measured_rate - state[IBIAS]
    half = state[IPHI] + 0.5 * omega * tau
    c, s = math.cos(half), math.sin(half)
    dx = v * tau * c - lever * omega * tau * s
    dy = v * tau * s + lever * omega * tau * c
    jacobian = np.eye(state.size)
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
    _add_noise(cov, step, c, s, noise)


def _add_noise(cov: FloatArray, step: Step, c: float, s: float, noise: MotionNoise) -> None:
    """The step's process noise: along and across the track, heading, bias, unobserved time."""
    tau, dt, unseen = step.observed, step.seconds, step.unseen
    along = noise.speed_noise**2 * step.speed_spread + noise.position_walk**2 * tau
    across = noise.position_walk**2 * tau
    cov[IX, IX] += along * c * c + across * s * s
    cov[IY, IY] += along * s * s + across * c * c
    cov[IX, IY] += (along - across) * c * s
    cov[IY, IX] += (along - across) * c * s
    cov[IPHI, IPHI] += noise.turn_rate_noise**2 * step.turn_spread + noise.heading_walk**2 * tau
    cov[IBIAS, IBIAS] += noise.bias_walk**2 * dt
    cov[ISCALE, ISCALE] += noise.scale_walk**2 * dt
    if unseen > 0.0:
        cov[IX, IX] += (noise.max_speed * unseen) ** 2
        cov[IY, IY] += (noise.max_speed * unseen) ** 2
        cov[IPHI, IPHI] += min((noise.max_turn_rate * unseen) ** 2, math.pi**2)

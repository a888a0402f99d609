"""The unicycle motion model's compiled kernels: held streams, a frame's steps, a step's prediction.

:mod:`azgym.track.unicycle` states the model and keeps its Python interface; the arithmetic is
here, in four entry points: :func:`frame_steps` (a frame's motion samples into steps),
:func:`predict_step` (one step moves a state and its covariance), :func:`advance` (both, for a
tracker's frame, in one call) and :func:`hold_streams` (a sequence's first frame, which only
starts the holds).

A stream's hold (:class:`~azgym.track.unicycle.MotionSteps` states the rule) lives in a row of
``streams`` (odometry speed, then turn rate): whether a sample holds, its value and time, and a
ring of the stream's latest :data:`RING` sample times, whose positive intervals' median is the
stream's typical period.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit

__all__ = ["HOLD_FLOOR_S", "HOLD_PERIODS", "IBIAS", "IPHI", "ISCALE", "IX", "IY",
           "MAX_FRAME_STEPS", "MAX_STEP_S", "PERIOD_HISTORY", "STATE_SIZE", "UNSEEN_HORIZON_S",
           "advance", "frame_steps", "hold_streams", "new_streams", "predict_step"]

PERIOD_HISTORY = 64
"""How many of a stream's latest sample intervals its typical period is the median of."""
RING = PERIOD_HISTORY + 1
"""Sample times a stream remembers: ``PERIOD_HISTORY`` intervals' worth."""
HOLD_PERIODS = 5.0
"""A sample holds for up to this many of its stream's typical (median) sample periods, ..."""
HOLD_FLOOR_S = 0.25
"""... and for at least this long [s]: a logger's jitter (a 100 Hz stream's 20-50 ms intervals,
its occasional 0.1-0.2 s gaps) is not a stream that stopped. After a longer silence the stream
has stopped (a forklift carried with its sensors off), and the time is unobserved."""
MAX_STEP_S = 0.25
"""Longest prediction step [s]: a longer frame (the first after an outage, whose motion spans
seconds) is cut into equal steps no longer than this (up to ``MAX_FRAME_STEPS`` of them), each
with its own samples' means. One step with the mean speed and turn rate of a 3 s gap that held a
straight and a turn put the track metres off."""
MAX_FRAME_STEPS = 4096
"""Most steps a frame is cut into: a frame longer than ``MAX_FRAME_STEPS`` × ``MAX_STEP_S``
(17 minutes) has longer steps, so that a time stamp's jump (a log whose clock leaps by years)
costs bounded memory and time instead of billions of steps."""
UNSEEN_HORIZON_S = 3600.0
"""Longest unobserved stretch whose motion a step's covariance charges [s]: after an hour
unwatched the vehicle may be anywhere an hour's drive reaches, farther than any site spans, so
the position's variance stops growing (as the heading's stops at π²). A time stamp's leap of
years otherwise makes a covariance of 10¹⁸ m² that no azimuth update can invert."""

STATE_SIZE = 5
"""Length of the state ``[x, y, φ, b, k]``: camera position [m], heading [rad], gyro bias
[rad/s] and the odometry's scale correction k [1] (the true speed is (1 + k) times the read)."""
IX, IY, IPHI, IBIAS, ISCALE = range(STATE_SIZE)
"""Positions of x, y, heading, gyro bias and odometry scale correction in the state."""
HAS_HELD, HELD, SINCE, COUNT, NEXT, TIMES = range(6)
"""A stream's row: whether a sample holds (1) or none yet (0), its value, its time [s], how many
sample times the ring holds, where the next goes, then the ring."""
STREAM_SIZE = TIMES + RING
STEP_FIELDS = 7
"""A step's row: :class:`~azgym.track.unicycle.Step`'s fields, in its order."""
SPEED, RATE, OBSERVED, SECONDS, UNSEEN, SPEED_SPREAD, TURN_SPREAD = range(STEP_FIELDS)
(SPEED_NOISE, SPEED_SCALE, SCALE_WALK, TURN_RATE_NOISE, BIAS_WALK, POSITION_WALK, HEADING_WALK,
 MAX_SPEED, MAX_TURN_RATE) = range(9)
"""Positions of :class:`~azgym.track.unicycle.MotionNoise`'s fields in its ``vector``."""


def new_streams() -> np.ndarray:
    """Two streams (odometry speed, turn rate) with nothing held and no sample times."""
    streams = np.zeros((2, STREAM_SIZE))
    streams[:, SINCE] = -math.inf
    return streams


@jit
def frame_steps(streams, samples, speed_count, start, end, speed_factor, period):
    """A frame's steps over (``start``, ``end``]: one, unless it spans more than ``MAX_STEP_S``.

    A longer frame is cut into equal steps no longer than ``MAX_STEP_S``, or into
    ``MAX_FRAME_STEPS`` equal (longer) steps when that would take more.

    The frame's samples all lie in (``start``, ``end``] (the tracker's motion check). Time no
    sensor watched is charged whole to the last step: an unobserved stretch is one unknown
    motion, whose spread grows with its whole length, not a sum of independent ones.

    Args:
        streams: The two streams' rows (:func:`new_streams`), updated in place.
        samples: The odometry samples' times [s] (in order) and speeds [m/s], then the
            turn-rate samples' times [s] (in order) and rates [rad/s], one after the other.
        speed_count: How many odometry samples there are.
        start: The previous frame's time [s].
        end: This frame's time [s].
        speed_factor: True over read distance of the odometry [1].
        period: The sample period a stream is taken to have until it shows its own [s].

    Returns:
        (S, :data:`STEP_FIELDS`) the steps, in time order.
    """
    speed_time, speed_value, turn_time, turn_rate = _split(samples, speed_count)
    # in floats until the cap: a jump of 10³⁰⁰ s overflows no integer
    count = int(max(min(np.ceil((end - start) / MAX_STEP_S), float(MAX_FRAME_STEPS)), 1.0))
    steps = np.zeros((count, STEP_FIELDS))
    if count == 1:  # the usual frame: one step, every sample
        _step(streams, speed_time, speed_value, 0, speed_time.size, turn_time, turn_rate, 0,
              turn_time.size, start, end, speed_factor, period, steps[0])
        steps[0, UNSEEN] = steps[0, SECONDS] - steps[0, OBSERVED]
        return steps
    # bounds as numpy's linspace draws them, bit for bit: k · ((end − start) / count) + start,
    # the last one ``end``
    width = (end - start) / count
    speed_from = turn_from = 0
    unseen = 0.0
    for k in range(count):
        low = k * width + start
        high = end if k == count - 1 else (k + 1) * width + start
        speed_to = speed_time.size if k == count - 1 else _after(speed_time, speed_from, high)
        turn_to = turn_time.size if k == count - 1 else _after(turn_time, turn_from, high)
        _step(streams, speed_time, speed_value, speed_from, speed_to, turn_time, turn_rate,
              turn_from, turn_to, low, high, speed_factor, period, steps[k])
        unseen += steps[k, SECONDS] - steps[k, OBSERVED]
        speed_from, turn_from = speed_to, turn_to
    steps[count - 1, UNSEEN] = unseen
    return steps


@jit
def hold_streams(streams, samples, speed_count):
    """Hold a sequence's first frame's samples (as :func:`frame_steps` takes them), unintegrated."""
    speed_time, speed_value, turn_time, turn_rate = _split(samples, speed_count)
    _hold(streams[0], speed_time, speed_value)
    _hold(streams[1], turn_time, turn_rate)


@jit
def advance(streams, samples, speed_count, start, end, speed_factor, period, state, cov, lever,
            noise, move):
    """A tracker's frame: :func:`frame_steps`, then each step's :func:`predict_step` if ``move``."""
    steps = frame_steps(streams, samples, speed_count, start, end, speed_factor, period)
    if move:
        for k in range(steps.shape[0]):
            predict_step(state, cov, steps[k], lever, noise)


@jit
def predict_step(state, cov, step, lever, noise):
    """Move ``state`` and ``cov`` (in place) by one step (:func:`azgym.track.unicycle.predict`).

    Entries past the first five (beacons a tracker keeps in its state) stand still; their
    cross-covariances with the pose move with it. The covariance moves as J P Jᵀ, J the step's
    Jacobian: the identity but for the position's and heading's rows, so only those rows and
    columns change.
    """
    read, measured_rate, tau = step[SPEED], step[RATE], step[OBSERVED]
    v = read * (1.0 + state[ISCALE])
    omega = measured_rate - state[IBIAS]
    half = state[IPHI] + 0.5 * omega * tau
    c, s = math.cos(half), math.sin(half)
    dx = v * tau * c - lever * omega * tau * s
    dy = v * tau * s + lever * omega * tau * c
    x_row = (-dy, 0.5 * tau * dy + lever * tau * s, read * tau * c)  # ∂x/∂(φ, b, k)
    y_row = (dx, -0.5 * tau * dx - lever * tau * c, read * tau * s)  # ∂y/∂(φ, b, k)
    state[IX] += dx
    state[IY] += dy
    state[IPHI] = _remainder(state[IPHI] + omega * tau)
    _jacobian_rows(cov, x_row, y_row, -tau)  # J P
    _jacobian_rows(cov.T, x_row, y_row, -tau)  # (J P) Jᵀ: the same on its columns
    _add_noise(cov, step, c, s, noise)


@jit(inline="always")
def _jacobian_rows(matrix, x_row, y_row, phi_bias):
    """``matrix`` ← J ``matrix``, in place.

    J is the step's Jacobian: the identity but for the rows of x and y (``x_row``, ``y_row``:
    their entries for φ, b and k) and of φ (``phi_bias``, its entry for b).
    """
    for j in range(matrix.shape[1]):
        new_x = matrix[IX, j] + x_row[0] * matrix[IPHI, j] + x_row[1] * matrix[IBIAS, j] \
            + x_row[2] * matrix[ISCALE, j]
        new_y = matrix[IY, j] + y_row[0] * matrix[IPHI, j] + y_row[1] * matrix[IBIAS, j] \
            + y_row[2] * matrix[ISCALE, j]
        matrix[IPHI, j] += phi_bias * matrix[IBIAS, j]
        matrix[IX, j], matrix[IY, j] = new_x, new_y


@jit(inline="always")
def _add_noise(cov, step, c, s, noise):
    """The step's process noise: along and across the track, heading, bias, unobserved time."""
    tau, dt, unseen = step[OBSERVED], step[SECONDS], min(step[UNSEEN], UNSEEN_HORIZON_S)
    along = noise[SPEED_NOISE] ** 2 * step[SPEED_SPREAD] + noise[POSITION_WALK] ** 2 * tau
    across = noise[POSITION_WALK] ** 2 * tau
    cov[IX, IX] += along * c * c + across * s * s
    cov[IY, IY] += along * s * s + across * c * c
    cov[IX, IY] += (along - across) * c * s
    cov[IY, IX] += (along - across) * c * s
    cov[IPHI, IPHI] += noise[TURN_RATE_NOISE] ** 2 * step[TURN_SPREAD] \
        + noise[HEADING_WALK] ** 2 * tau
    cov[IBIAS, IBIAS] += noise[BIAS_WALK] ** 2 * dt
    cov[ISCALE, ISCALE] += noise[SCALE_WALK] ** 2 * dt
    if unseen > 0.0:
        cov[IX, IX] += (noise[MAX_SPEED] * unseen) ** 2
        cov[IY, IY] += (noise[MAX_SPEED] * unseen) ** 2
        cov[IPHI, IPHI] += min((noise[MAX_TURN_RATE] * unseen) ** 2, math.pi ** 2)


@jit(inline="always")
def _remainder(angle):
    """``math.remainder(angle, 2π)``: the angle wrapped to [−π, π], halves to the even side."""
    turns = 2.0 * math.pi
    quotient = np.round(angle / turns)
    wrapped = angle - quotient * turns
    if abs(wrapped) <= math.pi:
        return wrapped
    return wrapped - math.copysign(turns, wrapped)


@jit(inline="always")
def _step(streams, speed_time, speed_value, speed_from, speed_to, turn_time, turn_rate,
          turn_from, turn_to, start, end, speed_factor, period, out):
    """One step over (``start``, ``end``] from each stream's samples [from, to), into ``out``."""
    distance, seen_speed, speed_spread = _integrate(streams[0], speed_time, speed_value,
                                                    speed_from, speed_to, start, end, period)
    angle, seen_turn, turn_spread = _integrate(streams[1], turn_time, turn_rate, turn_from,
                                               turn_to, start, end, period)
    out[SPEED] = speed_factor * distance / seen_speed if seen_speed > 0 else 0.0
    out[RATE] = angle / seen_turn if seen_turn > 0 else 0.0
    out[OBSERVED] = min(seen_speed, seen_turn)
    out[SECONDS] = end - start
    out[UNSEEN] = 0.0
    out[SPEED_SPREAD] = speed_factor ** 2 * speed_spread
    out[TURN_SPREAD] = turn_spread


@jit(inline="always")
def _integrate(stream, times, values, first_sample, stop, start, end, period):
    """(integral of the rate, observed seconds, Σ hold²) over (``start``, ``end``].

    The hold rule (:class:`~azgym.track.unicycle.MotionSteps`) on the samples [``first_sample``,
    ``stop``); the last of them then holds on into the next call. Σ hold² is the sum of the
    squared times each sample held [s²]: a sample's white noise σ adds σ² times it to the
    integral's variance. The hold's limit is only worked out when a gap is longer than
    ``HOLD_FLOOR_S`` (below it, no sample is cut short).
    """
    _remember(stream, times, first_sample, stop)
    size = stop - first_sample
    first = times[first_sample] if size else end
    held = stream[HAS_HELD] != 0.0
    longest = first - stream[SINCE] if held else 0.0
    for k in range(first_sample, stop):
        longest = max(longest, (times[k + 1] if k + 1 < stop else end) - times[k])
    limit = _limit(stream, period) if longest > HOLD_FLOOR_S else math.inf
    total = observed = spread = 0.0
    if held:
        until = min(first, stream[SINCE] + limit)
        if until > start:
            total, observed = stream[HELD] * (until - start), until - start
            spread = observed * observed
    if size:
        dot = seen = squares = 0.0
        for k in range(first_sample, stop):
            span = min((times[k + 1] if k + 1 < stop else end) - times[k], limit)
            dot += values[k] * span
            seen += span
            squares += span * span
        total += dot
        observed += seen
        spread += squares
        stream[HAS_HELD], stream[HELD], stream[SINCE] = 1.0, values[stop - 1], times[stop - 1]
    return total, observed, spread


@jit(inline="always")
def _hold(stream, times, values):
    """Remember the samples and hold the last one, without integrating."""
    _remember(stream, times, 0, times.size)
    if times.size:
        stream[HAS_HELD], stream[HELD], stream[SINCE] = 1.0, values[-1], times[-1]


@jit(inline="always")
def _remember(stream, times, first_sample, stop):
    """Put the sample times [``first_sample``, ``stop``) into the stream's ring."""
    for k in range(first_sample, stop):
        at = int(stream[NEXT])
        stream[TIMES + at] = times[k]
        stream[NEXT] = (at + 1) % RING
        stream[COUNT] = min(stream[COUNT] + 1.0, RING)


@jit(inline="always")
def _limit(stream, period):
    """The longest a sample holds [s]: max(``HOLD_PERIODS`` typical periods, ``HOLD_FLOOR_S``).

    The typical period is the median of the positive intervals between the ring's sample times
    (repeated time stamps left out), or ``period`` while there are none.
    """
    count = int(stream[COUNT])
    oldest = 0 if count < RING else int(stream[NEXT])
    intervals = np.empty(RING)
    found = 0
    for k in range(1, count):
        interval = stream[TIMES + (oldest + k) % RING] - stream[TIMES + (oldest + k - 1) % RING]
        if interval > 0.0:
            at = found  # insertion sort: at most 64 intervals
            while at > 0 and intervals[at - 1] > interval:
                intervals[at] = intervals[at - 1]
                at -= 1
            intervals[at] = interval
            found += 1
    if found == 0:
        typical = period
    elif found % 2:
        typical = intervals[found // 2]
    else:
        typical = (intervals[found // 2 - 1] + intervals[found // 2]) / 2.0
    return max(HOLD_PERIODS * typical, HOLD_FLOOR_S)


@jit(inline="always")
def _split(samples, speed_count):
    """The odometry's times and speeds, the turn rate's times and rates (views of ``samples``)."""
    turn_count = (samples.size - 2 * speed_count) // 2
    turn_from = 2 * speed_count
    return (samples[:speed_count], samples[speed_count:turn_from],
            samples[turn_from:turn_from + turn_count], samples[turn_from + turn_count:])


@jit(inline="always")
def _after(times, first, bound):
    """How many of ``times`` (in order) are at or before ``bound`` (numpy's side="right").

    The count starts at ``first``: the first ``first`` times are known to be, so a frame's cuts
    cost one pass over its samples, however many steps it has.
    """
    found = first
    while found < times.size and times[found] <= bound:
        found += 1
    return found

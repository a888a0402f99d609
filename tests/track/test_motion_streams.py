"""Motion streams as real loggers write them: jitter, repeated stamps, columns left out."""

from __future__ import annotations

import math

import numpy as np
import pytest

import azgym
from azgym import InvalidInputError, Measurements
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples
from azgym.track.unicycle import HOLD_FLOOR_S, MotionSteps

NOTHING = Measurements(np.zeros(0, int), np.zeros(0))
BEACONS = azgym.BeaconMap([1], [[0.0, 0.0, 3.0]])


def logger_stamps(seconds: float, seed: int) -> np.ndarray:
    """A busy 100 Hz logger's stamps: 10 ms mostly, 20-50 ms often, 0.1-0.2 s now and then."""
    rng = np.random.default_rng(seed)
    kind = rng.random(int(seconds * 100))
    intervals = np.where(kind < 0.25, rng.uniform(0.02, 0.05, kind.size), 0.01)
    intervals = np.where(kind > 0.99, rng.uniform(0.1, 0.2, kind.size), intervals)
    intervals = np.where((kind > 0.25) & (kind < 0.28), 0.0, intervals)  # repeated stamps
    stamps = np.round(np.cumsum(intervals), 3)
    return stamps[stamps <= seconds]


def frames(stamps: np.ndarray, frame_times: np.ndarray, speed=1.0, yaw_rate=0.1):
    """The stream cut into each frame's (previous frame, frame] samples, as Motion."""
    previous = -math.inf
    for time in frame_times:
        chosen = stamps[(stamps > previous) & (stamps <= time)]
        n = chosen.size
        yield Motion(float(time), OdometrySamples(chosen, np.full(n, speed), np.zeros(n)),
                     ImuSamples(chosen, np.full(n, yaw_rate), np.zeros((n, 2)),
                                np.full(n, math.nan)))
        previous = time


def test_logging_jitter_is_not_charged_as_unobserved_time():
    # The 100 Hz odometry: with a hold of 1.5 learnt periods, 28 % of its intervals
    # were charged as time no sensor watched, at the forklift's top speed.
    stamps = logger_stamps(20.0, seed=1)
    assert np.diff(stamps).max() > 0.1 and (np.diff(stamps) == 0).any()
    steps = MotionSteps(0.01)
    unseen = [step.unseen for motion in frames(stamps, np.arange(0.2, 20.0, 0.2))
              for step in steps.steps(motion)]
    assert sum(unseen) == 0.0


def test_a_stream_that_stops_for_seconds_is_still_unobserved():
    stamps = logger_stamps(5.0, seed=2)
    steps = MotionSteps(0.01)
    for motion in frames(stamps, np.arange(0.2, 5.01, 0.2)):
        steps.steps(motion)
    silent = steps.steps(next(frames(np.zeros(0), np.array([8.0]))))  # 3 s without a sample
    assert sum(step.unseen for step in silent) == pytest.approx(3.0 - HOLD_FLOOR_S, abs=0.05)


@pytest.mark.parametrize("name", ["gated-ekf", "robust", "dead-reckoning", "tkf", "lpkf"])
def test_repeated_stamps_and_a_repeated_frame_time_are_taken(name):
    tracker = azgym.make_tracker(name)
    tracker.reset(0, (0.0, 0.0, 0.0))
    times = np.array([0.1, 0.1, 0.1, 0.12, 0.2, 0.2])
    for motion in (*frames(times, np.array([0.0, 0.2])), next(frames(times[:0], [0.2]))):
        tracker.predict(motion)  # the last frame repeats the time 0.2 and carries no sample
        estimate = tracker.update(NOTHING, BEACONS)
        assert estimate.ok and np.isfinite(estimate.pose).all()


def odometry(time, steer=None, yaw_rate=None):
    n = len(time)
    steer = np.zeros(n) if steer is None else np.asarray(steer, dtype=float)
    yaw_rate = np.full(n, math.nan) if yaw_rate is None else np.asarray(yaw_rate, dtype=float)
    return OdometrySamples(np.asarray(time, dtype=float), np.ones(n), steer, yaw_rate)


def imu(time, accel=0.0):
    n = len(time)
    return ImuSamples(np.asarray(time, dtype=float), np.zeros(n),
                      np.full((n, 2), accel, dtype=float), np.full(n, math.nan))


@pytest.mark.parametrize(("first", "second", "message"), [
    (Motion(0.2, odometry([0.1, 0.2], steer=[0.0, math.nan]), imu([])), None,
     r"motion.odometry.steer is NaN in some samples only"),
    (Motion(0.2, odometry([0.1, 0.2], [math.nan] * 2, [0.1, math.nan]), imu([])), None,
     r"motion.odometry.yaw_rate is NaN in some samples only"),
    (Motion(0.2, odometry([]), ImuSamples(np.array([0.1, 0.2]), np.zeros(2),
                                          np.array([[0.0, 0.0], [math.nan, math.nan]]),
                                          np.full(2, math.nan))), None,
     r"motion.imu.ax is NaN in some samples only"),
    (Motion(0.2, odometry([]), imu([0.1], accel=math.inf)), None,
     r"motion.imu.ax holds a NaN or infinite value"),
    (Motion(0.2, odometry([0.1], [math.nan], yaw_rate=[0.3]), imu([])),
     Motion(0.4, odometry([0.3], steer=[math.nan], yaw_rate=[math.nan]), imu([])),
     r"motion.odometry.yaw_rate is NaN in this frame's samples but was given in earlier"),
    (Motion(0.2, odometry([]), imu([0.1], accel=math.nan)),
     Motion(0.4, odometry([]), imu([0.3])),
     r"motion.imu.ax is given in this frame's samples but was NaN in earlier frames"),
])
def test_a_column_given_in_part_is_refused(first, second, message):
    tracker = azgym.make_tracker("gated-ekf")
    tracker.reset(0, (0.0, 0.0, 0.0))
    with pytest.raises(InvalidInputError, match=message):
        tracker.predict(first)
        tracker.predict(second)


def test_a_stream_that_starts_late_keeps_the_columns_its_first_samples_give():
    tracker = azgym.make_tracker("gated-ekf")
    tracker.reset(0, (0.0, 0.0, 0.0))
    tracker.predict(Motion(0.2, odometry([]), imu([0.1])))  # no odometry yet
    tracker.predict(Motion(0.4, odometry([0.3], [math.nan], yaw_rate=[0.3]), imu([0.35])))
    with pytest.raises(InvalidInputError, match=r"motion.odometry.yaw_rate is NaN in this "
                                                r"frame's samples but was given in earlier"):
        tracker.predict(Motion(0.6, odometry([0.5], [math.nan], yaw_rate=[math.nan]),
                               imu([0.55])))


def test_a_column_left_out_throughout_is_accepted():
    tracker = azgym.make_tracker("tkf")  # reads the IMU's accelerations
    tracker.reset(0, (0.0, 0.0, 0.0))
    for k in range(1, 4):
        times = [0.1 * k - 0.05, 0.1 * k]
        tracker.predict(Motion(0.1 * k, odometry(times, [math.nan] * 2, [0.0, 0.0]),
                               imu(times, accel=math.nan)))
    assert tracker.update(NOTHING, BEACONS).ok


def test_tkf_without_accelerations_takes_the_velocity_from_the_odometry():
    # 1 m/s east for 1.5 s, the IMU giving the (zero) yaw rate and no accelerations.
    tracker = azgym.make_tracker("tkf")
    tracker.reset(0, (0.0, 0.0, 0.0))
    for k in range(16):
        times = np.round(0.1 * k - np.array([0.08, 0.06, 0.04, 0.02, 0.0]), 9)
        times = times[times > 0.1 * (k - 1) + 1e-9] if k else times[times <= 0.0][-1:]
        tracker.predict(Motion(0.1 * k, odometry(times), imu(times, accel=math.nan)))
    estimate = tracker.update(NOTHING, BEACONS)
    assert estimate.ok and (estimate.x, estimate.y) == pytest.approx((1.5, 0.0), abs=0.01)
    assert estimate.diagnostics["speed"] == pytest.approx(1.0, abs=0.01)

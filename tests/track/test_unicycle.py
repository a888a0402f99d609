"""The unicycle prediction across a long frame: cut into steps, it follows a straight and a turn."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples
from azgym.track.unicycle import MAX_STEP_S, MotionNoise, MotionSteps, predict

SILENT = MotionNoise(speed_noise=0.0, speed_scale=0.0, scale_walk=0.0, turn_rate_noise=0.0,
                     bias_walk=0.0, position_walk=0.0, heading_walk=0.0)
RATE = 50.0


def samples(times, speed, yaw_rate):
    n = times.size
    return (OdometrySamples(times, speed, np.zeros(n)),
            ImuSamples(times, yaw_rate, np.zeros((n, 2)), np.full(n, math.nan)))


def test_a_three_second_gap_with_a_straight_then_a_quarter_turn_is_followed():
    # 1.5 s straight at 2 m/s, then 1.5 s turning at π/3 rad/s: a quarter circle of radius
    # 6/π m. All of it arrives with one frame (the first after an outage).
    times = np.arange(1, 151) / RATE
    yaw_rate = np.where(times > 1.5 + 1e-9, math.pi / 3, 0.0)
    odometry, imu = samples(times - 1.0 / RATE, np.full(150, 2.0), yaw_rate)
    steps = MotionSteps(1.0 / RATE)
    steps.steps(Motion(0.0, *samples(np.zeros(0), np.zeros(0), np.zeros(0))))
    state, cov = np.zeros(5), np.diag([1e-4, 1e-4, 1e-6, 1e-8, 1e-6])
    frame = steps.steps(Motion(3.0, odometry, imu))
    assert len(frame) == math.ceil(3.0 / MAX_STEP_S)
    for step in frame:
        predict(state, cov, step, 0.0, SILENT)
    radius = 2.0 / (math.pi / 3)
    assert state[:3] == pytest.approx([3.0 + radius, radius, math.pi / 2], abs=0.02)
    # One step with the gap's mean speed and turn rate would land at 6 m along 45°, 2.4 m off.
    assert math.hypot(6 * math.cos(math.pi / 4) - 3.0 - radius,
                      6 * math.sin(math.pi / 4) - radius) > 2.0

"""The motion model's compiled kernels against the model written out in numpy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.jit import jit
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples
from azgym.track import unicycle_steps as kernels
from azgym.track.unicycle import (
    HOLD_FLOOR_S,
    HOLD_PERIODS,
    MAX_FRAME_STEPS,
    MAX_STEP_S,
    UNSEEN_HORIZON_S,
    MotionNoise,
    MotionSteps,
    Step,
    predict,
)

NOISE = MotionNoise(speed_noise=0.03, speed_scale=0.02, scale_walk=1e-3, turn_rate_noise=0.01,
                    bias_walk=1e-4, position_walk=0.02, heading_walk=0.002, max_speed=2.5,
                    max_turn_rate=2.0)


@jit
def _wrapped(angles):
    out = np.empty(angles.size)
    for k in range(angles.size):
        out[k] = kernels._remainder(angles[k])
    return out


def test_the_heading_wraps_as_math_remainder_does_to_the_last_bit():
    rng = np.random.default_rng(3)
    near = [math.pi, -math.pi, 3 * math.pi, -3 * math.pi]
    angles = np.concatenate([
        rng.uniform(-20.0, 20.0, 20_000),
        *[edge + rng.normal(0.0, 1e-14, 500) for edge in near],
        [0.0, -0.0, math.pi, -math.pi, 2 * math.pi, np.nextafter(math.pi, 4.0),
         np.nextafter(-math.pi, -4.0), 1e-300]])
    expected = np.array([math.remainder(angle, 2 * math.pi) for angle in angles])
    assert np.array_equal(_wrapped(angles), expected)


def reference_predict(state, cov, step: Step, lever: float, noise: MotionNoise):
    """The step written out with a dense Jacobian, J P Jᵀ + Q (the module's equations)."""
    state, cov = state.copy(), cov.copy()
    v = step.speed * (1.0 + state[4])
    omega = step.yaw_rate - state[3]
    tau = step.observed
    half = state[2] + 0.5 * omega * tau
    c, s = math.cos(half), math.sin(half)
    dx = v * tau * c - lever * omega * tau * s
    dy = v * tau * s + lever * omega * tau * c
    jacobian = np.eye(state.size)
    jacobian[0, 2], jacobian[1, 2] = -dy, dx
    jacobian[0, 3] = 0.5 * tau * dy + lever * tau * s
    jacobian[1, 3] = -0.5 * tau * dx - lever * tau * c
    jacobian[2, 3] = -tau
    jacobian[0, 4], jacobian[1, 4] = step.speed * tau * c, step.speed * tau * s
    state[:3] += (dx, dy, omega * tau)
    state[2] = math.remainder(state[2], 2 * math.pi)
    cov = jacobian @ cov @ jacobian.T
    along = noise.speed_noise**2 * step.speed_spread + noise.position_walk**2 * tau
    across = noise.position_walk**2 * tau
    rotation = np.array([[c, -s], [s, c]])
    cov[:2, :2] += rotation @ np.diag([along, across]) @ rotation.T
    cov[2, 2] += noise.turn_rate_noise**2 * step.turn_spread + noise.heading_walk**2 * tau
    cov[3, 3] += noise.bias_walk**2 * step.seconds
    cov[4, 4] += noise.scale_walk**2 * step.seconds
    if step.unseen > 0:
        unseen = min(step.unseen, UNSEEN_HORIZON_S)
        cov[0, 0] += (noise.max_speed * unseen) ** 2
        cov[1, 1] += (noise.max_speed * unseen) ** 2
        cov[2, 2] += min((noise.max_turn_rate * unseen) ** 2, math.pi**2)
    return state, cov


@pytest.mark.parametrize("size", [5, 9])  # 9: two beacons kept in the state
@pytest.mark.parametrize("unseen", [0.0, 0.3, 1e9])  # 1e9: past UNSEEN_HORIZON_S
def test_a_step_moves_the_state_and_covariance_as_the_dense_jacobian_does(size, unseen):
    rng = np.random.default_rng(size)
    state = np.concatenate([[3.0, -2.0, 3.1, 0.004, -0.01], rng.normal(0.0, 5.0, size - 5)])
    root = rng.normal(0.0, 0.1, (size, size))
    cov = root @ root.T + np.eye(size) * 1e-4
    step = Step(speed=1.7, yaw_rate=0.9, observed=0.1, seconds=0.1 + unseen, unseen=unseen,
                speed_spread=0.002, turn_spread=0.002)
    expected_state, expected_cov = reference_predict(state, cov, step, -0.5, NOISE)
    predict(state, cov, step, -0.5, NOISE)
    assert state == pytest.approx(expected_state, rel=1e-14, abs=1e-14)
    assert np.allclose(cov, expected_cov, rtol=1e-12, atol=1e-15)
    assert state[2] == pytest.approx(math.remainder(3.1 + (0.9 - 0.004) * 0.1, 2 * math.pi))


def jittery_motion(times: np.ndarray, end: float) -> Motion:
    n = times.size
    odometry = OdometrySamples(times, 1.0 + 0.1 * np.sin(times), np.zeros(n))
    imu = ImuSamples(times, 0.2 * np.cos(times), np.zeros((n, 2)), np.full(n, math.nan))
    return Motion(end, odometry, imu)


def test_one_compiled_call_a_frame_predicts_as_the_steps_one_by_one():
    rng = np.random.default_rng(5)
    stamps = np.round(np.cumsum(rng.choice([0.01, 0.02, 0.0, 0.04], 3000)), 3)
    frame_ends = [0.0, *np.arange(0.1, 10.0, 0.1), 13.0, 13.1]  # a 2.9 s outage, then on
    by_steps, in_one = MotionSteps(0.01), MotionSteps(0.01)
    state_a, state_b = np.zeros(5), np.zeros(5)
    cov_a, cov_b = np.eye(5) * 1e-4, np.eye(5) * 1e-4
    previous = -1.0
    for end in frame_ends:
        times = stamps[(stamps > previous) & (stamps <= end) & ((stamps < 10.0) | (stamps > 13.0))]
        motion = jittery_motion(times, end)
        for step in by_steps.steps(motion):
            predict(state_a, cov_a, step, 0.3, NOISE)
        in_one.advance(motion, state_b, cov_b, 0.3, NOISE, True)
        previous = end
    assert np.array_equal(state_a, state_b) and np.array_equal(cov_a, cov_b)
    assert np.array_equal(by_steps.streams, in_one.streams)


def test_a_sample_holds_for_five_median_periods_of_the_latest_intervals_only():
    # 200 samples 0.01 s apart, then 70 at 0.1 s: the median of the latest 64 intervals is
    # 0.1 s, so the last sample holds 0.5 s (not 0.05 s) into a silent frame.
    times = np.concatenate([np.arange(1, 201) * 0.01, 2.0 + np.arange(1, 71) * 0.1])
    steps = MotionSteps(0.01)
    steps.steps(jittery_motion(np.zeros(0), 0.0))
    steps.steps(jittery_motion(times, float(times[-1])))
    silent = steps.steps(jittery_motion(np.zeros(0), float(times[-1]) + 0.2))
    assert [step.observed for step in silent] == pytest.approx([0.2])
    step = steps.steps(jittery_motion(np.zeros(0), float(times[-1]) + 1.0))
    held = HOLD_PERIODS * 0.1 - 0.2
    assert sum(s.observed for s in step) == pytest.approx(held)
    assert sum(s.unseen for s in step) == pytest.approx(0.8 - held)
    assert HOLD_PERIODS * 0.01 < HOLD_FLOOR_S < HOLD_PERIODS * 0.1


def test_a_frame_is_cut_into_steps_of_a_quarter_second_but_never_more_than_the_cap():
    steps = MotionSteps(0.01)
    steps.steps(jittery_motion(np.zeros(0), 0.0))
    steps.steps(jittery_motion(np.arange(1, 101) * 0.01, 1.0))
    long = steps.steps(jittery_motion(np.zeros(0), 1000.0))  # 999 s: 3 996 steps of 0.25 s
    assert len(long) == 3996 < MAX_FRAME_STEPS
    assert [step.seconds for step in long] == pytest.approx([MAX_STEP_S] * 3996)
    # a clock that leaps by 10⁹ s: as many steps as the cap allows, the leap unobserved
    leap = steps.steps(jittery_motion(np.zeros(0), 1000.0 + 1e9))
    assert len(leap) == MAX_FRAME_STEPS
    assert sum(step.seconds for step in leap) == pytest.approx(1e9)
    assert sum(step.observed for step in leap) == 0.0
    assert leap[-1].unseen == pytest.approx(1e9)

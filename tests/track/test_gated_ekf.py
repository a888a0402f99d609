"""gated-ekf: the motion model and the gated azimuth update by hand, gating, following a route."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame

import azgym
from azgym import InvalidInputError, Measurements
from azgym.core import pose_error
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples
from azgym.track.unicycle import MotionNoise, MotionSteps, Step, predict
from azgym.world.drive import simulate

SILENT = MotionNoise(speed_noise=0.0, speed_scale=0.0, scale_walk=0.0, turn_rate_noise=0.0,
                     bias_walk=0.0, position_walk=0.0, heading_walk=0.0)
BEACONS = beacon_map([(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (5.0, 12.0)])


def steady(time, speed, yaw_rate, start=0.0, rate=50.0):
    """Motion samples at ``rate`` over (start, time], constant speed and yaw rate."""
    times = np.arange(start + 1.0 / rate, time + 1e-9, 1.0 / rate)
    n = times.size
    return Motion(time, OdometrySamples(times, np.full(n, speed), np.zeros(n)),
                  ImuSamples(times, np.full(n, yaw_rate), np.zeros((n, 2)), np.full(n, math.nan)))


def test_a_prediction_by_hand():
    # 1 m/s for 0.1 s at heading 0, no turn, camera 0.5 m behind the steering-free axle.
    state = np.zeros(5)
    cov = np.diag([1e-4, 1e-4, 1e-4, 1e-6, 1e-4])
    predict(state, cov, Step(1.0, 0.0, 0.1, 0.1, 0.0), -0.5, SILENT)
    np.testing.assert_allclose(state, [0.1, 0.0, 0.0, 0.0, 0.0], atol=1e-15)
    # F: ∂y/∂φ = 0.1, ∂x/∂k = 0.1, ∂φ/∂b = −0.1, ∂y/∂b = −½·0.1·0.1 − (−0.5)·0.1 = 0.045.
    assert cov[0, 0] == pytest.approx(1e-4 + 0.1**2 * 1e-4)
    assert cov[1, 1] == pytest.approx(1e-4 + 0.1**2 * 1e-4 + 0.045**2 * 1e-6)
    assert cov[2, 2] == pytest.approx(1e-4 + 0.1**2 * 1e-6)
    assert cov[1, 2] == pytest.approx(0.1 * 1e-4 + 0.045 * -0.1 * 1e-6)


def test_the_samples_hold_until_the_next_and_a_silent_gap_is_unobserved():
    steps = MotionSteps(0.02)
    steps.steps(steady(0.1, 2.0, 0.0))
    [(speed, rate, observed, dt, unseen, speed_spread, turn_spread)] = steps.steps(
        steady(0.2, 1.0, 0.5, start=0.1))
    # (0.1, 0.12] still runs on the last sample of the previous frame (2 m/s, no turn).
    assert (speed, rate) == (pytest.approx(0.02 * 2.0 / 0.1 + 0.08 * 1.0 / 0.1),
                             pytest.approx(0.08 * 0.5 / 0.1))
    assert (observed, dt, unseen) == (pytest.approx(0.1), pytest.approx(0.1),
                                      pytest.approx(0.0, abs=1e-12))
    # Each sample's white noise weighs by its hold: 0.02 s of the old one, four of 0.02 s.
    assert speed_spread == turn_spread == pytest.approx(5 * 0.02**2)
    gap = steps.steps(steady(10.0, 1.0, 0.0, start=9.9))  # 9.7 s without samples
    # Observed: the old sample's hold (HOLD_FLOOR_S, 0.25 s: a stopped stream is told from
    # jitter only after it), then 9.92 … 10.0 up to the frame (0.08 s), in 40 steps of 0.245 s;
    # the 9.47 s unseen are charged to the last step.
    assert len(gap) == 40 and sum(step.seconds for step in gap) == pytest.approx(9.8)
    assert sum(step.observed for step in gap) == pytest.approx(0.33)
    assert [step.unseen for step in gap[:-1]] == [0.0] * 39
    assert gap[-1].unseen == pytest.approx(9.8 - 0.33)


@pytest.mark.parametrize("name", ["gated-ekf", "robust"])
def test_the_gate_rejects_a_ghost_and_a_misread_id(name):
    pose = (4.0, 3.0, 0.3)
    clean = ideal_frame(*pose, BEACONS)
    # A mirror ghost of beacon 2 (its azimuth reflected in a wall) and beacon 4's azimuth read
    # as id 5.
    ids = np.r_[clean.ids, 2, 5]
    azimuth = np.r_[clean.azimuth, azgym.wrap_angle(clean.azimuth[1] + 0.4), clean.azimuth[3]]
    tracker = azgym.make_tracker(name)
    tracker.reset(initial=pose)
    estimate = tracker.update(Measurements(ids, azimuth), BEACONS)
    assert estimate.ok and estimate.inliers.tolist() == [True] * 5 + [False, False]
    assert pose_error(estimate.pose, pose)[0] < 1e-3


def test_uninitialized_it_answers_no_pose_with_a_reason_then_starts_from_a_fix():
    tracker = azgym.make_tracker("gated-ekf")
    tracker.reset(seed=0)
    few = tracker.update(Measurements([1, 2], [0.1, 0.2]), BEACONS)
    assert not few.ok and few.reason.startswith("not initialized: ransac: fewer than 3")
    estimate = tracker.update(ideal_frame(4.0, 3.0, 0.3, BEACONS), BEACONS)
    assert estimate.ok and pose_error(estimate.pose, (4.0, 3.0, 0.3))[0] < 1e-3
    assert estimate.covariance.shape == (3, 3) and estimate.diagnostics["initialized"]
    after = tracker.update(Measurements([], []), BEACONS)  # no measurement: the prediction
    assert after.ok and after.pose == pytest.approx(estimate.pose)


def test_reset_forgets_the_track_and_starts_from_the_initial_pose():
    tracker = azgym.make_tracker("gated-ekf")
    tracker.reset(initial=(1.0, 2.0, 0.5))
    assert tracker.update(Measurements([], []), BEACONS).pose == pytest.approx((1.0, 2.0, 0.5))
    tracker.reset()
    assert not tracker.update(Measurements([], []), BEACONS).ok


@pytest.mark.parametrize(("params", "message"), [
    ({"gate_probability": 1.0}, r"GatedEkf.gate_probability must be in \(0, 1\)"),
    ({"delta_alpha_d": -0.1}, r"GatedEkf.delta_alpha_d must be in"),
    ({"extra_sigma": "wide"}, r"GatedEkf.extra_sigma must be a finite number"),
    ({"position_walk": math.nan}, r"GatedEkf.position_walk must be a finite number"),
    ({"initializer": "mex"}, r"GatedEkf.initializer must be one of 'ransac', 'loo', got 'mex'"),
    ({"vehicle": "tank"}, r"GatedEkf.vehicle must be one of 'forklift', 'differential-drive'"),
    ({"yaw_source": "compass"}, r"GatedEkf.yaw_source must be one of 'gyro', 'odometry'"),
    ({"camera_ahead": math.inf}, r"GatedEkf.camera_ahead must be a finite number, got inf"),
    ({"wheelbase": 0.0}, r"GatedEkf.wheelbase must be > 0"),
    ({"coverage": "yes"}, r"GatedEkf.coverage must be True or False"),
    ({"speed_factor": 0.0}, r"GatedEkf.speed_factor must be > 0"),
    ({"speed_noise": -0.1}, r"GatedEkf.speed_noise must be >= 0"),
    ({"speed_scale": math.nan}, r"GatedEkf.speed_scale must be a finite number"),
    ({"scale_walk": -1e-3}, r"GatedEkf.scale_walk must be >= 0"),
    ({"turn_rate_noise": -1.0}, r"GatedEkf.turn_rate_noise must be >= 0"),
    ({"bias_walk": "1e-4"}, r"GatedEkf.bias_walk must be a finite number"),
    ({"heading_walk": -0.1}, r"GatedEkf.heading_walk must be >= 0"),
    ({"min_init_inliers": 2}, r"GatedEkf.min_init_inliers must be an integer >= 3"),
    ({"delta_alpha_d": 0.0, "extra_sigma": 0.0}, "gives the azimuths no noise"),
])
def test_bad_hyperparameters_are_refused(params, message):
    with pytest.raises(InvalidInputError, match=message):
        azgym.make_tracker("gated-ekf", **params)


def test_a_hyperparameter_set_later_is_checked_before_the_next_frame():
    tracker = azgym.make_tracker("gated-ekf:initializer=loo")
    tracker.gate_probability = 0.0
    with pytest.raises(InvalidInputError, match="gate_probability"):
        tracker.reset()


def follow(tracker, scenario, frames):
    """Errors [m] of every answered frame after the first answer, and the unanswered count."""
    errors, missed = [], 0
    for frame in frames:
        tracker.predict(frame.motion)
        estimate = tracker.update(frame.measurements, scenario.beacons)
        if estimate.ok:
            errors.append(pose_error(estimate.pose, frame.pose)[0])
        elif errors:
            missed += 1
    return np.array(errors), missed


@pytest.fixture(scope="module")
def cross_aisle():
    scenario = azgym.load_scenario("warehouse-small")
    return scenario, list(simulate(scenario, "cross-aisle", seed=5))


@pytest.mark.parametrize("name", ["gated-ekf", "robust"])
def test_it_follows_a_route_within_a_few_centimetres(name, cross_aisle):
    scenario, frames = cross_aisle
    tracker = azgym.make_tracker(name)
    tracker.reset(seed=0)
    errors, missed = follow(tracker, scenario, frames)
    assert missed == 0 and errors.size >= len(frames) - 2
    assert np.percentile(errors, 95) < 0.05 and errors.max() < 0.15

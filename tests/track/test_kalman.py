"""Plotter's Kalman filter: its compiled steps by hand, the trackers on a simulated route."""

from __future__ import annotations

import math

import numpy as np
import pytest

import azgym
from azgym import InvalidInputError
from azgym.core import Measurements, pose_error
from azgym.track.inertial_steps import (
    HEADING,
    HEADING_VAR,
    NOISE_SIZE,
    SIZE,
    SPEED_FACTOR,
    SPEED_VAR,
    VX,
    VY,
    X,
    Y,
    camera_estimate,
    fix_update,
    inertial_step,
    low_pass,
    new_held,
    predict_samples,
)
from azgym.world.drive import simulate


def _fix_update(z, heading=0.0, ahead=0.0, gate=math.inf):
    """A fix with covariance I on x = (0, 0, 0, 0, heading, 0), P = I; the state after, and d²."""
    x, P = np.zeros(SIZE), np.eye(SIZE)
    x[HEADING] = heading
    distance = fix_update(x, P, *map(float, z), np.eye(3), ahead, gate)
    return x, P, distance


def test_a_fix_as_uncertain_as_the_state_pulls_it_halfway_by_hand():
    # S = P + R = 2 I, K = I / 2 on (x, y, φ): the state moves half the innovation, P halves.
    x, P, distance = _fix_update([1.0, -2.0, 0.5])
    np.testing.assert_allclose(x[[X, Y, HEADING]], [0.5, -1.0, 0.25])
    np.testing.assert_allclose(np.diag(P)[[X, Y, HEADING]], [0.5, 0.5, 0.5])
    assert x[VX] == x[VY] == 0.0 and P[VX, VX] == 1.0  # uncorrelated: untouched
    assert distance == pytest.approx((1.0 + 4.0 + 0.25) / 2)


def test_the_fix_sees_the_camera_ahead_of_the_imu():
    # Facing north with the camera 1 m ahead: a fix at (0, 1, π/2) is what the state predicts.
    x, P, distance = _fix_update([0.0, 1.0, math.pi / 2], heading=math.pi / 2, ahead=1.0)
    assert distance == pytest.approx(0.0, abs=1e-24)
    np.testing.assert_allclose(x[[X, Y]], [0.0, 0.0], atol=1e-15)


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_fix_whose_covariance_is_not_finite_changes_nothing(bad):
    x, P = np.zeros(SIZE), np.eye(SIZE)
    R = np.eye(3)
    R[1, 2] = bad
    assert fix_update(x, P, 1.0, 2.0, 0.3, R, 0.5, math.inf) == -1.0
    assert not x.any() and np.array_equal(P, np.eye(SIZE))


class _NotFiniteFix:
    """ransac's fix with a covariance that is NaN from the given frame on."""

    def __init__(self, from_frame):
        self.ransac, self.frame, self.from_frame = azgym.make_localizer("ransac"), 0, from_frame

    def localize(self, measurements, beacons):
        fix = self.ransac.localize(measurements, beacons)
        self.frame += 1
        if self.frame >= self.from_frame and fix.covariance is not None:
            fix.covariance[0, 0] = math.nan
        return fix


@pytest.mark.parametrize("from_frame", [1, 5])  # before the filter starts, and once it runs
def test_tkf_refuses_a_fix_whose_covariance_is_not_finite(from_frame):
    scenario = azgym.load_scenario("warehouse-small")
    frames = list(simulate(scenario, scenario.routes[0].name, seed=1))[:12]
    tracker = azgym.make_tracker("tkf")
    tracker._fix = _NotFiniteFix(from_frame).localize
    tracker.reset(seed=0)
    states = []
    for frame in frames[1:]:
        tracker.predict(frame.motion)
        states.append(tracker.update(frame.observation.measurements, scenario.beacons))
    assert all(state.diagnostics["fix"] != "used" for state in states[from_frame - 1:])
    assert all(np.isfinite(tracker._x)) and np.isfinite(tracker._P).all()


def test_the_gate_leaves_the_state_alone_for_an_outlier():
    x, P, distance = _fix_update([10.0, 0.0, 0.0], gate=16.0)
    assert distance == pytest.approx(50.0)
    assert not x.any() and (P == np.eye(SIZE)).all()


def test_a_heading_innovation_is_wrapped():
    x, _, _ = _fix_update([0.0, 0.0, -math.pi + 0.01], heading=math.pi - 0.01)
    assert abs(x[HEADING]) == pytest.approx(math.pi, abs=1e-9)  # halfway across ±π, not 0


def test_the_camera_s_covariance_carries_the_heading_s_through_the_lever():
    # Facing east, camera 2 m ahead: its y moves 2 m per radian of heading, so var(y) = 1 + 4.
    x, P = np.zeros(SIZE), np.eye(SIZE)
    covariance = np.full((3, 3), np.nan)
    pose = camera_estimate(x, P, 2.0, covariance)
    np.testing.assert_allclose(pose, [2.0, 0.0, 0.0])
    np.testing.assert_allclose(covariance, [[1.0, 0.0, 0.0], [0.0, 5.0, 2.0], [0.0, 2.0, 1.0]])


def test_the_inertial_step_turns_body_acceleration_into_the_world():
    x, P = np.zeros(SIZE), np.zeros((SIZE, SIZE))
    x[4] = math.pi / 2  # facing north: forward acceleration is northward
    for _ in range(100):
        inertial_step(x, P, 1.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0)
    np.testing.assert_allclose(x[:4], [0.0, 0.5, 0.0, 1.0], atol=1e-12)  # a t² / 2, a t
    inertial_step(x, P, 0.0, 0.0, 0.0, 1.0, 0.01, 0.0, 0.0)
    assert P[1, 1] == pytest.approx(0.01 / 4) and P[3, 3] == pytest.approx(0.01)


def test_the_low_pass_reaches_63_percent_after_one_time_constant():
    held, rc, steps = new_held(), 1 / (2 * math.pi), 1000
    assert low_pass(held, 0.5, -0.5, 0.0, rc) == (0.5, -0.5)  # the first sample passes as it is
    assert low_pass(held, 0.0, 0.0, 1e9, rc) == pytest.approx((0.0, 0.0), abs=1e-9)  # long after
    for _ in range(steps):
        value = low_pass(held, 1.0, -2.0, rc / steps, rc)
    assert value == pytest.approx((1 - math.exp(-1), -2 * (1 - math.exp(-1))), abs=1e-3)


def _one_frame(imu_heading=math.nan, imu_yaw_rate=0.0, speed=None, rate=None, gyro_yaw=True):
    """Predict x = 0, P = I from t = 0 to t = 1 through one IMU sample (and one odometry one)."""
    x, P, held = np.zeros(SIZE), np.eye(SIZE), new_held()
    noise = np.zeros(NOISE_SIZE)
    noise[HEADING_VAR] = noise[SPEED_VAR] = noise[SPEED_FACTOR] = 1.0
    odometry = np.array([0.0]) if speed is not None else np.zeros(0)
    predict_samples(x, P, np.array([0.0]), np.zeros((1, 2)), np.array([imu_yaw_rate]),
                    np.array([imu_heading]), odometry, np.array([speed or 0.0])[:odometry.size],
                    np.array([rate or 0.0]), odometry.size, 0.0, 1.0 if rate is not None else 0.0,
                    held, noise, True, speed is not None, gyro_yaw)
    return x, P


def test_a_heading_reading_as_uncertain_as_the_state_pulls_it_halfway():
    x, P = _one_frame(imu_heading=0.2)
    assert x[HEADING] == pytest.approx(0.1) and P[HEADING, HEADING] == pytest.approx(0.5)


def test_a_speed_reading_as_uncertain_as_the_velocity_pulls_it_halfway():
    # Facing east with vₓ = 0 ± 1: a speed of 2 ± 1 along the heading gives vₓ = 1, v_y alone.
    x, P = _one_frame(speed=2.0)
    assert x[VX] == pytest.approx(1.0) and x[VY] == 0.0 and P[VX, VX] == pytest.approx(0.5)


def test_the_turn_rate_is_the_odometry_s_when_told_and_the_gyro_s_otherwise():
    # The gyro reads 1 rad/s, the odometry 0.5, both at t = 0, held until t = 1 (bias 0).
    assert _one_frame(imu_yaw_rate=1.0, speed=0.0, rate=0.5, gyro_yaw=False)[0][HEADING] == \
        pytest.approx(0.5)
    assert _one_frame(imu_yaw_rate=1.0, speed=0.0, rate=0.5)[0][HEADING] == pytest.approx(1.0)


@pytest.fixture(scope="module")
def route():
    scenario = azgym.load_scenario("warehouse-small")
    return scenario, list(simulate(scenario, "aisle-loop", seed=1))[:250]


def _run(tracker, scenario, frames, initial=True, blind=()):
    tracker.reset(initial=frames[0].pose if initial else None)
    estimates = []
    for frame in frames:
        tracker.predict(frame.motion)
        measurements = frame.measurements
        if blind and blind[0] <= frame.time < blind[1]:
            measurements = Measurements(np.zeros(0, int), np.zeros(0))
        estimates.append(tracker.update(measurements, scenario.beacons))
    return estimates


def test_tkf_tracks_a_warehouse_route_better_than_each_frame_alone(route):
    scenario, frames = route
    ransac = [e.ok and pose_error(e.pose, f.pose)[0] for e, f in
              zip(_run(azgym.make_tracker("ransac"), scenario, frames), frames, strict=True)]
    ours = _run(azgym.make_tracker("tkf"), scenario, frames)
    errors = [pose_error(e.pose, f.pose) for e, f in zip(ours, frames, strict=True) if e.ok]
    position = np.array([p for p, _ in errors])
    assert len(errors) >= sum(e is not False for e in ransac)  # at least as available
    assert np.percentile(position, 95) < 0.05  # ransac's own 95th percentile is ~0.9 m here
    assert np.percentile(position, 95) < np.percentile([e for e in ransac if e is not False], 95)
    assert max(h for _, h in errors) < math.radians(2.0)
    covariance = ours[-1].covariance
    assert covariance.shape == (3, 3) and np.all(np.linalg.eigvalsh(covariance) > 0)


def test_without_a_start_pose_the_first_fix_waits_for_a_second(route):
    scenario, frames = route
    estimates = _run(azgym.make_tracker("tkf"), scenario, frames[:20], initial=False)
    assert not estimates[0].ok and "waiting for a second" in estimates[0].reason
    assert all(e.ok for e in estimates[2:])
    assert pose_error(estimates[-1].pose, frames[19].pose)[0] < 0.05


def test_a_short_gap_is_bridged_and_a_long_one_reported(route):
    scenario, frames = route
    short = _run(azgym.make_tracker("tkf"), scenario, frames[:120], blind=(5.0, 6.5))
    inside = [(e, f) for e, f in zip(short, frames[:120], strict=True) if 5.0 <= f.time < 6.5]
    assert all(e.ok and e.diagnostics["fix"] == "none" for e, _ in inside)
    assert max(pose_error(e.pose, f.pose)[0] for e, f in inside) < 0.15
    long = _run(azgym.make_tracker("tkf", max_holdover=1.0), scenario, frames[:120],
                blind=(5.0, 8.0))
    lost = [e for e, f in zip(long, frames[:120], strict=True) if 6.05 < f.time < 8.0]
    assert lost and all(not e.ok and e.reason.startswith("no fix for") for e in lost)
    assert "max_holdover 1.0 s" in lost[-1].reason
    after = [(e, f) for e, f in zip(long, frames[:120], strict=True) if f.time >= 8.5]
    assert all(e.ok for e, _ in after)
    assert pose_error(after[-1][0].pose, after[-1][1].pose)[0] < 0.05


@pytest.mark.parametrize(("params", "message"), [
    ({"accel_variance": 0}, r"Tkf.accel_variance must be > 0, got 0"),
    ({"orientation_variance": -1.0}, r"Tkf.orientation_variance must be > 0"),
    ({"max_holdover": math.nan}, r"Tkf.max_holdover must be a finite number, got nan"),
    ({"gate": True}, r"Tkf.gate must be a finite number or inf, got True"),
    ({"camera_from_imu": math.inf}, r"Tkf.camera_from_imu must be a finite number, got inf"),
    ({"localizer": 3}, r"Tkf.localizer must be a localizer spec \(a string\), got 3"),
    ({"localizer": "tkf"}, r"Tkf.localizer must name a per-frame localizer, got 'tkf'"),
])
def test_bad_hyperparameters_are_refused(params, message):
    with pytest.raises(InvalidInputError, match=message):
        azgym.make_tracker("tkf", **params)


def test_an_unknown_fix_localizer_is_named():
    with pytest.raises(azgym.UnknownNameError, match="Did you mean 'ransac'"):
        azgym.make_tracker("tkf", localizer="ransacc")


def test_lpkf_refuses_a_bad_cutoff_and_takes_specs():
    with pytest.raises(InvalidInputError, match=r"Lpkf.cutoff_hz must be > 0"):
        azgym.make_tracker("lpkf", cutoff_hz=0)
    tracker = azgym.make_tracker("lpkf:cutoff_hz=2,gate=Infinity")
    assert tracker.get_params()["cutoff_hz"] == 2 and tracker.gate == math.inf
    tracker.accel_variance = -1.0
    with pytest.raises(InvalidInputError, match=r"Lpkf.accel_variance must be > 0"):
        tracker.reset()


def test_a_hyperparameter_set_mid_route_is_checked_and_used_from_the_next_frame(route):
    # The prediction's constants are compiled-in numbers: setting one must reach them (and a bad
    # value be refused) at the next frame, not at the next reset.
    scenario, frames = route
    changed = azgym.make_tracker("lpkf")
    _run(changed, scenario, frames[:50])
    changed.cutoff_hz = 0.0
    with pytest.raises(InvalidInputError, match=r"Lpkf.cutoff_hz must be > 0"):
        changed.predict(frames[50].motion)
    changed.cutoff_hz = 5.0
    fresh = azgym.make_tracker("lpkf")
    _run(fresh, scenario, frames[:50])
    fresh.predict(frames[50].motion)
    changed.predict(frames[50].motion)
    assert changed._P[2, 2] != fresh._P[2, 2] or not np.array_equal(changed._x, fresh._x)

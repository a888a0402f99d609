"""Plotter's Kalman filter: the textbook steps by hand, the trackers on a simulated route."""

from __future__ import annotations

import math

import numpy as np
import pytest

import azgym
from azgym import InvalidInputError
from azgym.core import Measurements, pose_error
from azgym.track.kalman import SIZE, inertial_step, predict, update
from azgym.track.kinematics import LowPass
from azgym.world.drive import simulate


def test_a_constant_velocity_step_by_hand():
    # p = 0, v = 1, P = I; F moves one second; then a position reading of 1.5 with variance 1.
    x, P = np.array([0.0, 1.0]), np.eye(2)
    predict(x, P, np.array([[1.0, 1.0], [0.0, 1.0]]), np.zeros((2, 2)))
    np.testing.assert_allclose(x, [1.0, 1.0])
    np.testing.assert_allclose(P, [[2.0, 1.0], [1.0, 1.0]])
    H = np.array([[1.0, 0.0]])
    distance = update(x, P, np.array([1.5]), H @ x, H, np.array([[1.0]]))
    # S = 3, K = (2/3, 1/3): x = (1 + 1/3, 1 + 1/6), P = P − K S Kᵀ.
    assert distance == pytest.approx(0.25 / 3)
    np.testing.assert_allclose(x, [4 / 3, 7 / 6])
    np.testing.assert_allclose(P, [[2 / 3, 1 / 3], [1 / 3, 2 / 3]])


def test_process_noise_adds_to_the_covariance():
    x, P = np.zeros(2), np.zeros((2, 2))
    predict(x, P, np.eye(2), np.diag([0.5, 0.25]), u=np.array([1.0, 2.0]))
    np.testing.assert_allclose(x, [1.0, 2.0])
    np.testing.assert_allclose(P, np.diag([0.5, 0.25]))


def test_the_gate_leaves_the_state_alone_for_an_outlier():
    x, P = np.array([0.0]), np.eye(1)
    H = np.eye(1)
    distance = update(x, P, np.array([10.0]), H @ x, H, np.eye(1), gate=16.0)
    assert distance == pytest.approx(50.0)
    assert x[0] == 0.0 and P[0, 0] == 1.0


def test_an_angle_innovation_is_wrapped():
    x, P = np.array([math.pi - 0.01]), np.eye(1)
    H = np.eye(1)
    update(x, P, np.array([-math.pi + 0.01]), H @ x, H, np.eye(1), angles=(0,))
    assert x[0] == pytest.approx(math.pi, abs=1e-9)  # halfway across ±π, not through zero
    update(x, P, np.array([-math.pi + 0.01]), H @ x, H, np.eye(1))
    assert abs(x[0]) < 2  # without the wrap, 2π − 0.02 apart: pulled through zero


def test_the_inertial_step_turns_body_acceleration_into_the_world():
    x, P = np.zeros(SIZE), np.zeros((SIZE, SIZE))
    x[4] = math.pi / 2  # facing north: forward acceleration is northward
    for _ in range(100):
        inertial_step(x, P, (1.0, 0.0), 0.0, 0.01, 0.0, 0.0, 0.0)
    np.testing.assert_allclose(x[:4], [0.0, 0.5, 0.0, 1.0], atol=1e-12)  # a t² / 2, a t
    inertial_step(x, P, (0.0, 0.0), 0.0, 1.0, 0.01, 0.0, 0.0)
    assert P[1, 1] == pytest.approx(0.01 / 4) and P[3, 3] == pytest.approx(0.01)


def test_the_low_pass_reaches_63_percent_after_one_time_constant():
    lowpass = LowPass(1.0)
    lowpass(np.zeros(1), 0.0)
    rc, steps = 1 / (2 * math.pi), 1000
    for _ in range(steps):
        value = lowpass(np.ones(1), rc / steps)
    assert value[0] == pytest.approx(1 - math.exp(-1), abs=1e-3)


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

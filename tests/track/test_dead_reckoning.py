"""Dead reckoning: odometry alone from a start pose, its drift growing with time."""

from __future__ import annotations

import math

import numpy as np
import pytest

import azgym
from azgym import InvalidInputError
from azgym.core import Measurements, pose_error
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples
from azgym.world.drive import simulate

NOTHING = Measurements(np.zeros(0, int), np.zeros(0))
BEACONS = azgym.BeaconMap([1], [[0.0, 0.0, 3.0]])


def drive(speed, steer, seconds, rate=50.0, yaw_rate=0.0):
    """Motion of one frame holding ``speed`` and ``steer`` (and the gyro's ``yaw_rate``)."""
    times = np.arange(1, int(seconds * rate) + 1) / rate
    return Motion(float(times[-1]), OdometrySamples(times, np.full(times.size, speed),
                                                    np.full(times.size, steer)),
                  ImuSamples(times, np.full(times.size, yaw_rate), np.zeros((times.size, 2)),
                             np.full(times.size, math.nan)))


def start(tracker, speed, steer, yaw_rate=0.0):
    """Reset at the origin facing east, the forklift already moving as it will."""
    tracker.reset(initial=(0.0, 0.0, 0.0))
    tracker.predict(Motion(0.0, OdometrySamples(np.zeros(1), np.full(1, speed),
                                                np.full(1, steer)),
                           ImuSamples(np.zeros(1), np.full(1, yaw_rate),
                                      np.zeros((1, 2)), np.full(1, math.nan))))


def test_without_a_start_pose_it_answers_no():
    tracker = azgym.make_tracker("dead-reckoning")
    tracker.reset()
    tracker.predict(drive(1.0, 0.0, 1.0))
    estimate = tracker.update(NOTHING, BEACONS)
    assert not estimate.ok and "needs a start pose" in estimate.reason


def test_a_straight_drive_is_exact():
    tracker = azgym.make_tracker("dead-reckoning")
    start(tracker, 2.0, 0.0)
    tracker.predict(drive(2.0, 0.0, 3.0))
    estimate = tracker.update(NOTHING, BEACONS)
    assert estimate.pose == pytest.approx((6.0, 0.0, 0.0), abs=1e-9)
    assert estimate.diagnostics["travelled"] == pytest.approx(6.0)


@pytest.mark.parametrize("yaw_source", ["odometry", "gyro"])
def test_a_steady_turn_follows_the_bicycle_model(yaw_source):
    # v = 1 m/s, δ = 30°: ω = tan 30° / 1.6; a point on the reference axle runs a circle of
    # radius 1 / ω, the camera (0.5 m behind it) a circle of the same centre.
    speed, steer, wheelbase = 1.0, math.radians(30.0), 1.6
    omega = speed * math.tan(steer) / wheelbase
    tracker = azgym.make_tracker("dead-reckoning", yaw_source=yaw_source, camera_ahead=0.0)
    start(tracker, speed, steer, yaw_rate=omega)
    quarter = (math.pi / 2) / omega
    tracker.predict(drive(speed, steer, quarter, rate=1000.0, yaw_rate=omega))
    estimate = tracker.update(NOTHING, BEACONS)
    radius = 1.0 / omega
    assert estimate.heading == pytest.approx(omega * round(quarter * 1000) / 1000, abs=1e-6)
    assert (estimate.x, estimate.y) == pytest.approx((radius, radius), abs=2e-3)


def test_measurements_change_nothing():
    results = []
    for measurements in (NOTHING, Measurements([1], [0.3])):
        tracker = azgym.make_tracker("dead-reckoning")
        start(tracker, 1.0, 0.1)
        tracker.predict(drive(1.0, 0.1, 2.0))
        results.append(tracker.update(measurements, BEACONS).pose)
    assert results[0] == results[1]


def test_its_drift_grows_with_time_on_a_route():
    scenario = azgym.load_scenario("warehouse-small")
    frames = list(simulate(scenario, "aisle-loop", seed=2))
    tracker = azgym.make_tracker("dead-reckoning")
    tracker.reset(initial=frames[0].pose)
    errors = []
    for frame in frames:
        tracker.predict(frame.motion)
        errors.append(pose_error(tracker.update(frame.measurements, scenario.beacons).pose,
                                 frame.pose)[0])
    errors = np.array(errors)
    times = np.array([frame.time for frame in frames])
    early, late = errors[times < 5.0].max(), errors[times > 40.0].mean()
    assert early < 0.05  # the first seconds are as good as the odometry
    assert late > 5 * early and late > 0.1  # and then it drifts away


@pytest.mark.parametrize(("params", "message"), [
    ({"yaw_source": "compass"},
     r"DeadReckoning.yaw_source must be one of 'gyro', 'odometry', got 'compass'"),
    ({"vehicle": "boat"}, r"DeadReckoning.vehicle must be one of 'forklift', 'differential-drive'"),
    ({"speed_factor": -1.0}, r"DeadReckoning.speed_factor must be > 0"),
    ({"wheelbase": 0.0}, r"DeadReckoning.wheelbase must be > 0, got 0.0"),
    ({"wheelbase": True}, r"DeadReckoning.wheelbase must be a finite number, got True"),
    ({"camera_ahead": math.nan}, r"DeadReckoning.camera_ahead must be a finite number, got nan"),
])
def test_bad_hyperparameters_are_refused(params, message):
    with pytest.raises(InvalidInputError, match=message):
        azgym.make_tracker("dead-reckoning", **params)

"""The frame source: repeatable frames along a route, with sensor streams at their own rates."""

from __future__ import annotations

import math

import numpy as np
import pytest

import azgym
from azgym.sensing.motion import ImuModel
from azgym.world.drive import simulate


@pytest.fixture(scope="module")
def frames():
    return list(simulate("warehouse-small", "cross-aisle", seed=4))


def test_frames_come_at_the_camera_rate_and_end_at_the_route_end(frames):
    times = np.array([frame.time for frame in frames])
    assert np.allclose(np.diff(times), 0.1, atol=0.021)  # 10 Hz on a 50 Hz physics clock
    assert [frame.index for frame in frames] == list(range(len(frames)))
    x, y, _ = frames[-1].pose
    assert math.hypot(x - 27.4, y - 18.3) < 0.5  # the camera, 0.3 m ahead of the body centre
    assert sum(frame.contacts for frame in frames) == 0


def test_the_same_seed_gives_the_same_frames_bit_for_bit(frames):
    again = list(simulate("warehouse-small", "cross-aisle", seed=4))
    assert len(again) == len(frames)
    for a, b in zip(frames, again, strict=True):
        assert a.pose == b.pose
        assert np.array_equal(a.measurements.ids, b.measurements.ids)
        assert np.array_equal(a.measurements.azimuth, b.measurements.azimuth)
        assert np.array_equal(a.odometry.speed, b.odometry.speed)
        assert np.array_equal(a.imu.yaw_rate, b.imu.yaw_rate)
    other = list(simulate("warehouse-small", "cross-aisle", seed=5))
    assert any(not np.array_equal(a.measurements.azimuth, b.measurements.azimuth)
               for a, b in zip(frames, other, strict=False))


def test_odometry_and_imu_track_the_truth(frames):
    speeds = np.concatenate([frame.odometry.speed for frame in frames])
    assert 1.3 < speeds.max() < 1.7  # the route's cruise speed is 1.5 m/s
    # The gyro integrates to the heading change, up to its bias and noise.
    rates = np.concatenate([frame.imu.yaw_rate for frame in frames])
    turned = rates.sum() * 0.02
    assert turned == pytest.approx(frames[-1].pose[2] - frames[0].pose[2], abs=0.15)
    assert np.isnan(frames[1].imu.heading).all()  # no orientation sensor by default


def test_the_plotter_preset_adds_an_orientation_sensor_with_its_noise():
    frames = list(simulate("warehouse-small", "cross-aisle", seed=1, imu=ImuModel.plotter(),
                           max_time=8.0))
    error = np.concatenate([frame.imu.heading - frame.pose[2] for frame in frames[1:]])
    assert np.degrees(error).var() == pytest.approx(0.235, rel=0.35)
    counts = [len(frame.imu.time) for frame in frames[1:]]
    assert 2 <= min(counts) and max(counts) <= 3  # 26 Hz against 10 Hz frames


def test_ransac_beats_lsq_on_the_faulty_frames(frames):
    scenario = azgym.load_scenario("warehouse-small")
    errors = {}
    for name in ("ransac", "lsq"):
        localizer = azgym.make_localizer(name)
        estimates = [localizer.localize(f.measurements, scenario.beacons) for f in frames]
        errors[name] = np.array([math.hypot(e.x - f.pose[0], e.y - f.pose[1])
                                 for e, f in zip(estimates, frames, strict=True) if e.ok])
    faulty = [k for k, f in enumerate(frames) if (f.truth.label >= 2).any()]
    assert len(faulty) > 10
    assert np.median(errors["ransac"]) < 0.05
    assert np.mean(errors["lsq"]) > 5 * np.mean(errors["ransac"])


def test_unknown_route_names_are_refused():
    with pytest.raises(azgym.UnknownNameError, match="Did you mean 'aisle-loop'"):
        next(simulate("warehouse-small", "aisle-lop"))


def test_the_drive_takes_frames_at_the_sensors_own_rate_and_refuses_a_non_sensor():
    import pytest

    import azgym
    from azgym.sensing.image.sensor import ImageSensor
    from azgym.world.drive import simulate

    room = azgym.load_scenario("warehouse-small")
    frames = simulate(room, seed=0, sensor=ImageSensor(room, ids="blink"))
    times = [next(frames).time for _ in range(4)]
    assert times[1] - times[0] == pytest.approx(1 / 30, abs=0.02)  # 30 Hz on 0.02 s steps
    with pytest.raises(azgym.InvalidInputError, match="sensor must be an azgym Sensor"):
        next(simulate(room, seed=0, sensor="image"))

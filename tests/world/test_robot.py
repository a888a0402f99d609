"""The differential-drive robot of robot-arena: its drive, its frames and their figures."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from azgym.bench.suites import robot as robot_suite
from azgym.errors import InvalidInputError
from azgym.profile import DIFFERENTIAL_DRIVE
from azgym.sensing.motion import DifferentialOdometryModel, ImuModel, OdometryModel
from azgym.site import load_scenario
from azgym.site.elements import Vehicle
from azgym.world.drive import camera_trajectory, motion_models, simulate
from azgym.world.forklift import ForkliftSpec
from azgym.world.motion_sensors import RobotMotionSensors
from azgym.world.robot import Robot, RobotDriver, RobotSpec
from azgym.world.robot_figures import odometry_heading, route_figures

SCENARIO = load_scenario("robot-arena")


@pytest.fixture(scope="module")
def routes():
    """Every frame of the suite's four routes, seeds 0-3 (as the figures' command draws them)."""
    return {name: list(simulate(SCENARIO, name, seed=k))
            for k, name in enumerate(robot_suite.ROUTES)}


@pytest.fixture(scope="module")
def figures(routes):
    return [route_figures(SCENARIO, frames) for frames in routes.values()]


def test_the_same_seed_gives_the_same_frames_bit_for_bit():
    first = list(simulate(SCENARIO, "wander-2", seed=3, max_time=20.0))
    again = list(simulate(SCENARIO, "wander-2", seed=3, max_time=20.0))
    assert len(first) == len(again) == 102  # 5 Hz from 0 to the first frame past 20 s
    for a, b in zip(first, again, strict=True):
        assert a.pose == b.pose and a.time == b.time
        assert np.array_equal(a.measurements.ids, b.measurements.ids)
        assert np.array_equal(a.measurements.azimuth, b.measurements.azimuth)
        for key in ("time", "speed", "yaw_rate"):
            assert np.array_equal(getattr(a.odometry, key), getattr(b.odometry, key))
    other = list(simulate(SCENARIO, "wander-2", seed=4, max_time=20.0))
    assert [a.pose for a in first] == [b.pose for b in other]  # the drive draws nothing
    assert any(not np.array_equal(a.odometry.speed, b.odometry.speed)
               for a, b in zip(first, other, strict=True))


def test_frames_carry_a_turn_rate_odometry_and_no_imu(routes):
    frames = routes["wander-1"]
    assert all(f.imu.time.size == 0 and f.contacts == 0 for f in frames)
    assert all(f.odometry.reports_yaw_rate for f in frames[1:] if f.odometry.time.size)
    for previous, frame in zip(frames, frames[1:], strict=False):  # each frame's own samples
        assert ((frame.odometry.time > previous.time) & (frame.odometry.time <= frame.time)).all()
    assert np.allclose(np.diff([f.time for f in frames]), 0.2)


def test_the_routes_figures_follow_the_real_recording(figures):
    """docs/robot.md states these, as ``python -m azgym.world.robot_figures`` prints them."""
    seen = np.array([f.landmarks_mean_seen for f in figures])
    assert (1.5 <= seen).all() and (seen <= 1.9).all()
    assert 1.4 <= np.mean([f.landmarks_mean for f in figures]) <= 1.8
    assert all(f.share_three < 0.15 for f in figures)  # three at once is rare
    assert all(0.05 < f.unmapped_share < 0.25 for f in figures)
    assert all(f.max_bearing <= 0.6 for f in figures)
    assert all(f.median_interval == pytest.approx(0.010, abs=1e-9) for f in figures)
    assert all(0.2 < f.busy_share < 0.3 and 0.01 < f.repeated_share < 0.05 for f in figures)
    assert all(1 <= f.gaps <= 0.005 * f.samples for f in figures)
    drift = np.degrees([f.drift_rms for f in figures])
    assert 1.7 <= np.mean(drift) <= 3.2 and (drift < 4.0).all()
    assert np.mean([f.distance_ratio for f in figures]) == pytest.approx(1 / 1.1, abs=0.03)


EXACT = DifferentialOdometryModel(speed_factor=1.0, speed_scale=0.0, speed_noise=0.0,
                                  turn_rate_noise=0.0, turn_rate_bias=0.0, bias_walk=0.0)


def test_exact_odometry_reads_the_velocity_of_the_step_at_each_stamp():
    route = SCENARIO.routes[0]
    robot = Robot(route.start_pose(), RobotSpec(), 0.01, 0.1)
    driver = RobotDriver(route, robot.spec)
    sensors = RobotMotionSensors(EXACT, None, np.random.default_rng(0), np.random.default_rng(1))
    held = []
    for _ in range(3000):
        robot.step(*driver.command(*robot.pose))
        sensors.step(robot)
        held.append((robot.time, robot.speed, robot.turn_rate))
    held = np.array(held)
    odometry, imu = sensors.take()
    assert imu.time.size == 0
    step = np.searchsorted(held[:, 0], odometry.time - 1e-9)  # the step whose span holds it
    assert np.array_equal(odometry.speed, held[step, 1])
    assert np.array_equal(odometry.yaw_rate, held[step, 2])
    assert np.ptp(held[:, 1]) > 0.2 and np.ptp(held[:, 2]) > 1.0  # it did speed up and turn


def test_exact_odometry_integrated_follows_the_truth():
    frames = list(simulate(SCENARIO, "wander-3", seed=1, odometry=EXACT))
    time = np.concatenate([f.odometry.time for f in frames])
    speed = np.concatenate([f.odometry.speed for f in frames])
    yaw_rate = np.concatenate([f.odometry.yaw_rate for f in frames])
    poses = np.array([f.pose for f in frames])
    frame_time = np.array([f.time for f in frames])
    heading = poses[0, 2] + odometry_heading(time, yaw_rate, frame_time[1:])
    error = np.degrees(np.abs(np.angle(np.exp(1j * (heading - poses[1:, 2])))))
    # Samples held over the logger's gaps miss part of the turns inside them: degrees over
    # minutes, against the noisy odometry's 1.7-3.2 degrees in every second.
    assert error.max() < 8.0 and error[-1] < 3.0
    axle = poses[:, :2] - 0.1 * np.column_stack([np.cos(poses[:, 2]), np.sin(poses[:, 2])])
    travelled = np.hypot(*np.diff(axle, axis=0).T).sum()
    assert np.sum(np.diff(time) * speed[:-1]) == pytest.approx(travelled, rel=0.005)


def test_the_robot_keeps_its_limits_and_drives_each_route_to_its_end():
    spec = RobotSpec()
    for route in SCENARIO.routes:
        poses = camera_trajectory(SCENARIO, route, camera_rate_hz=5.0)
        axle = poses[:, :2] - 0.1 * np.column_stack([np.cos(poses[:, 2]), np.sin(poses[:, 2])])
        assert np.hypot(*(axle[-1] - route.waypoints[-1])) < 0.06
        landmarks = SCENARIO.beacons.xy
        clearance = np.hypot(*(axle[:, None, :] - landmarks[None]).transpose(2, 0, 1)).min()
        assert clearance > 0.4  # the robot never drives through a landmark
        step = np.hypot(*np.diff(axle, axis=0).T)
        assert step.max() <= spec.max_speed * 0.2 + 1e-9
    robot = Robot((0.0, 0.0, 0.0), spec, 0.01, 0.1)
    speeds, turns = [], []
    for _ in range(100):
        robot.step(5.0, -5.0)  # beyond every limit
        speeds.append(robot.speed)
        turns.append(robot.turn_rate)
    assert np.diff(speeds).max() <= spec.max_accel * 0.01 + 1e-12
    assert max(speeds) == spec.max_speed and min(turns) == -spec.max_turn_rate
    assert np.abs(np.diff(turns)).max() <= spec.max_turn_accel * 0.01 + 1e-12


def test_a_turn_on_the_spot_swings_the_camera_round_the_axis():
    robot = Robot((1.0, 2.0, 0.0), RobotSpec(), 0.01, 0.1)
    while abs(robot.heading) < 1.0:
        robot.step(0.0, 1.0)
    x, y, heading = robot.camera_pose()
    assert (robot.x, robot.y) == (1.0, 2.0)
    assert (x, y) == pytest.approx((1.0 + 0.1 * math.cos(heading), 2.0 + 0.1 * math.sin(heading)))


def test_a_robot_with_an_imu_gets_one():
    frames = list(simulate(SCENARIO, "wander-1", seed=0, imu=ImuModel(), max_time=5.0))
    assert sum(f.imu.time.size for f in frames) == pytest.approx(50 * frames[-1].time, abs=2)
    assert motion_models(SCENARIO) == (DifferentialOdometryModel(), None)
    odometry, imu = motion_models(SCENARIO, 50.0)
    assert odometry.period == pytest.approx(0.02) and imu is None


@pytest.mark.parametrize(("change", "message"), [
    ({"odometry": OdometryModel()}, "odometry: scenario 'robot-arena' is driven by a "
                                    "differential-drive, whose odometry model is a "
                                    "DifferentialOdometryModel, got OdometryModel"),
    ({"spec": ForkliftSpec()}, "spec: .* whose spec is a RobotSpec, got ForkliftSpec"),
    ({"dt": 0.0}, "dt must be > 0"),
])
def test_a_model_of_the_other_vehicle_is_refused(change, message):
    with pytest.raises(InvalidInputError, match=message):
        next(simulate(SCENARIO, "wander-1", **change))


def test_the_suite_is_the_routes_as_sequences_from_their_start():
    cases = robot_suite.routes(5, quick=True)
    assert {c.sequence for c in cases} == {"robot-arena/wander-1"}
    assert cases[0].initial == cases[0].pose and all(c.initial is None for c in cases[1:])
    assert all(c.motion.odometry.reports_yaw_rate for c in cases[1:])
    frames = list(simulate(SCENARIO, "wander-1", seed=5))
    assert len(cases) == (len(frames) + 1) // 2
    assert [c.pose for c in cases] == [f.pose for f in frames[::2]]


def test_a_robot_vehicle_without_camera_ahead_has_its_camera_on_the_axis():
    on_axis = dataclasses.replace(SCENARIO, vehicle=Vehicle(DIFFERENTIAL_DRIVE))
    route = SCENARIO.routes[0]
    ahead = camera_trajectory(SCENARIO, route, max_time=5.0)  # camera_ahead = 0.1
    axis = camera_trajectory(on_axis, route, max_time=5.0)
    offset = 0.1 * np.column_stack([np.cos(ahead[:, 2]), np.sin(ahead[:, 2])])
    assert np.allclose(axis[:, :2], ahead[:, :2] - offset)
    assert np.array_equal(axis[:, 2], ahead[:, 2])

"""A real robot's bags, quirks included: each imports (with a note where data is changed).

:func:`robot_topics` writes what a robot records, not what azgym exports: detections at 30 Hz
(every fifth frame sees no beacon), odometry and IMU at 200 Hz, a motion-capture pose at
120 Hz, epoch times of 2026, every message received a little after its stamp, and no azgym
manifest. Each test breaks it the way a real driver does: header stamps never filled, a message
recorded twice, a truth topic that starts after the camera and stops before it, an IMU that
gives only its orientation, tf messages holding several frames.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
from logs.bag_helpers import Messages, ns_of, store, write_bag

from azgym.logs.ros import BagImport, import_bag
from azgym.logs.ros.log_files import Options
from azgym.site import load_scenario

START = 1772611200.0
"""2026-03-04, 08:00 UTC: an epoch time, as a robot's clock stamps it."""
SECONDS = 4.0
OPTIONS = BagImport(topics={"truth": "/mocap"}, log=Options(map="warehouse-small"))


def pose(t: float) -> tuple[float, float, float]:
    """The camera's true pose at time t: along x at 0.5 m/s, turning at 0.1 rad/s."""
    return 5.0 + 0.5 * (t - START), 5.0, 0.1 * (t - START)


def robot_topics(make: Messages) -> dict:
    """A robot's recording of SECONDS (module docstring), as topics for write_bag."""
    beacons = load_scenario("warehouse-small").beacons
    detections, odometry, imu, mocap = [], [], [], []
    for k in range(round(SECONDS * 30)):
        t = START + k / 30
        x, y, heading = pose(t)
        seen = slice(0, 0 if k % 5 == 0 else 3)
        bearing = np.arctan2(beacons.xyz[seen, 1] - y, beacons.xyz[seen, 0] - x) - heading
        detections.append((ns_of(t) + 3_000_000, make.detections(
            t, k, beacons.ids[seen], np.arctan2(np.sin(bearing), np.cos(bearing)))))
    for k in range(round(SECONDS * 200) + 40):
        t = START - 0.1 + k / 200
        odometry.append((ns_of(t) + 1_000_000, make.odometry(t, 0.5, 0.1)))
        imu.append((ns_of(t) + 1_000_000, make.imu(t, 0.1, (0.0, 0.05))))
    for k in range(round(SECONDS * 120) + 30):
        t = START - 0.1 + k / 120
        mocap.append((ns_of(t) + 500_000, make.pose_stamped(t, *pose(t))))
    return {"/azgym/detections": ("azgym_msgs/msg/BeaconAzimuths", detections),
            "/odom": ("nav_msgs/msg/Odometry", odometry), "/imu": ("sensor_msgs/msg/Imu", imu),
            "/mocap": ("geometry_msgs/msg/PoseStamped", mocap)}


def _import(tmp_path: Path, topics: dict, options: BagImport = OPTIONS, name: str = "bag"):
    return import_bag(write_bag(tmp_path / name, topics), tmp_path / f"{name}-log", options)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_robots_bag_at_its_own_rates_with_epoch_times_and_empty_frames_imports(tmp_path,
                                                                                storage):
    topics = robot_topics(Messages(store()))
    log = import_bag(write_bag(tmp_path / "bag", topics, storage), tmp_path / "log", OPTIONS)
    assert len(log.frames["time"]) == 120 and log.frames["time"][0] == START
    assert np.bincount(log.detections["frame"], minlength=120)[::5].sum() == 0
    expected = np.array([pose(t) for t in log.frames["time"]]).T
    assert np.abs(log.frames["x"] - expected[0]).max() < 1e-6
    assert np.abs(log.frames["heading"] - expected[2]).max() < 1e-6
    assert log.imu is not None and "ax" in log.imu.values


def test_header_stamps_never_filled_are_the_bags_times_with_a_note(tmp_path):
    topics = robot_topics(Messages(store()))
    for topic in ("/odom", "/imu"):
        for _, message in topics[topic][1]:
            message.header.stamp.sec, message.header.stamp.nanosec = 0, 0
    log = _import(tmp_path, topics)
    received = np.array([ns for ns, _ in topics["/odom"][1]])
    times = log.odometry["time"]  # the bag's times, those after the last frame trimmed
    assert times.tolist() == (received // 10**9 + received % 10**9 / 1e9)[:times.size].tolist()
    assert times.size > 800  # on the frames' clock: every sample up to the last frame kept
    notes = [note for note in log.notes if "header stamp" in note]
    assert len(notes) == 2 and "topic /odom" in notes[0] and "topic /imu" in notes[1]
    assert "every header stamp is 0" in notes[0] and "its time in the bag" in notes[0]


def test_a_message_recorded_twice_is_read_once_with_a_note(tmp_path):
    make = Messages(store())
    topics = robot_topics(make)
    mocap = topics["/mocap"][1]
    mocap.insert(40, copy.deepcopy(mocap[40]))  # a driver publishing its last pose again
    topics["/joint_states"] = ("sensor_msgs/msg/JointState", [
        (ns, make.joints(START - 0.1 + k / 200, ["steer"], [0.01]))
        for k, (ns, _) in enumerate(topics["/odom"][1])])
    joints = topics["/joint_states"][1]
    joints.insert(7, copy.deepcopy(joints[7]))
    log = _import(tmp_path, topics, BagImport(topics=OPTIONS.topics, log=Options(
        map="warehouse-small")))
    assert "steer" in log.odometry.values
    notes = [note for note in log.notes if "same stamp" in note]
    assert len(notes) == 2, log.notes
    assert "topic /mocap" in notes[0] and "message 41" in notes[0]
    assert "topic /joint_states" in notes[1] and "message 8" in notes[1]


def test_frames_before_the_truth_starts_or_after_it_ends_are_left_out_with_a_note(tmp_path):
    topics = robot_topics(Messages(store()))
    kind, mocap = topics["/mocap"]
    topics["/mocap"] = (kind, mocap[61:-90])  # started 0.5 s late (at 0.408 s), stopped early
    log = _import(tmp_path, topics)             # (at 3.392 s): frames 13 to 101 are covered
    assert np.array_equal(log.frames["frame"], np.arange(13, 102))
    expected = np.array([pose(t) for t in log.frames["time"]]).T
    assert np.abs(log.frames["x"] - expected[0]).max() < 1e-6
    everything = _import(tmp_path, robot_topics(Messages(store())), name="whole")
    kept = (everything.detections["frame"] >= 13) & (everything.detections["frame"] <= 101)
    assert np.array_equal(log.detections["azimuth"], everything.detections["azimuth"][kept])
    (note,) = [note for note in log.notes if "left out" in note]
    assert "topic /mocap" in note and "13 frame(s) before its first sample" in note
    assert "18 after its last" in note
    topics["/mocap"] = (kind, mocap[-20:])  # no frame within the truth: refused
    with pytest.raises(Exception, match="lies outside the truth samples' span"):
        _import(tmp_path, topics, name="none")


def test_an_imu_that_gives_only_its_orientation_is_left_out_with_a_note(tmp_path):
    topics = robot_topics(Messages(store()))
    for _, message in topics["/imu"][1]:
        message.angular_velocity_covariance[0] = -1.0  # not measured: an AHRS's orientation
        message.linear_acceleration_covariance[0] = -1.0
        message.orientation_covariance[0] = 0.0
    log = _import(tmp_path, topics)
    assert log.imu is None and log.odometry is not None
    (note,) = [note for note in log.notes if "topic /imu" in note]
    assert "angular_velocity_covariance" in note and "no yaw rate" in note


def test_truth_from_tf_messages_holding_several_frames(tmp_path):
    make = Messages(store())
    topics = robot_topics(make)
    messages = []
    for k, (ns, _) in enumerate(topics.pop("/mocap")[1]):
        t = START - 0.1 + k / 120
        tf = make.tf(t, "map", "camera_truth", *pose(t))
        tf.transforms[:0] = [make.tf(t, "odom", "base_link", 1.0, 2.0, 0.3).transforms[0],
                             make.tf(t, "map", "odom", 0.0, 0.0, 0.0).transforms[0]]
        messages.append((ns, tf))
    topics["/tf"] = ("tf2_msgs/msg/TFMessage", messages)
    log = _import(tmp_path, topics, BagImport(truth_frame="camera_truth",
                                              log=Options(map="warehouse-small")))
    expected = np.array([pose(t) for t in log.frames["time"]]).T
    assert np.abs(log.frames["x"] - expected[0]).max() < 1e-6
    assert math.isclose(log.frames["heading"][-1], expected[2][-1], abs_tol=1e-6)


def test_a_camera_mount_in_tf_static_the_profile_does_not_hold_is_noted(tmp_path):
    make = Messages(store())
    topics = robot_topics(make)
    mount = make.tf(START, "base_link", "camera", 0.3, 0.0, 0.0)
    mount.transforms.insert(0, make.tf(START, "base_link", "laser", 0.1, 0.0, 0.0).transforms[0])
    topics["/tf_static"] = ("tf2_msgs/msg/TFMessage", [(ns_of(START), mount)])
    profile = tmp_path / "robot.toml"
    profile.write_text("[vehicle]\ncamera_ahead = 0.12\n")
    log = _import(tmp_path, topics, BagImport(topics=OPTIONS.topics, log=Options(
        map="warehouse-small", profile=profile)))
    assert log.manifest.profile.vehicle.camera_ahead == 0.12  # the profile given is the log's
    (note,) = [note for note in log.notes if "/tf_static" in note]
    assert "puts the camera 0.3 m ahead of base_link" in note
    assert "the log's profile 0.12 m (vehicle.camera_ahead, which the log keeps)" in note
    log = _import(tmp_path, topics, name="unprofiled")
    (note,) = [note for note in log.notes if "/tf_static" in note]
    assert "the log's profile has none (give it with --profile)" in note
    mount.transforms[1] = make.tf(START, "base_link", "camera", 0.12, -0.05, math.pi / 2
                                  ).transforms[0]
    log = _import(tmp_path, topics, BagImport(topics=OPTIONS.topics, log=Options(
        map="warehouse-small", profile=profile)), name="turned")
    (note,) = [note for note in log.notes if "/tf_static" in note]
    assert "-0.05 m to its left, turned by 1.57079632679" in note
    assert "a log's profile holds the camera's offset ahead only" in note

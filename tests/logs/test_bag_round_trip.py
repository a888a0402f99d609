"""azgym import bag and azgym export bag: a log through a bag and back is the same log."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from logs.bag_helpers import Messages, bag_of_log, log_topics, same_logs, store, write_bag
from rosbags.highlevel import AnyReader

from azgym.errors import InvalidInputError
from azgym.logs import export_route, read_log
from azgym.logs.ros import BagImport, export_bag, import_bag
from azgym.logs.ros.detections import Mapping
from azgym.logs.ros.log_files import Options
from azgym.site import load_scenario


@pytest.mark.parametrize(("storage", "ros1"), [("sqlite3", False), ("mcap", False),
                                               ("sqlite3", True)],
                         ids=["ros2-sqlite3", "ros2-mcap", "ros1"])
def test_a_bag_written_with_rosbags_imports_to_the_log_it_was_written_from(
        mini_log, tmp_path, storage, ros1):
    # The mini log: format 1, a beacons.csv map, a quality column, undecoded and unknown ids, a
    # frame without detections, steer odometry, an IMU with a heading on one sample only.
    source = read_log(mini_log)
    bag = bag_of_log(source, tmp_path / ("bag.bag" if ros1 else "bag"), storage, ros1)
    same_logs(source, import_bag(bag, tmp_path / "back"))
    same_logs(source, read_log(tmp_path / "back"))


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_the_shipped_simulated_log_exports_in_standard_types_and_comes_back(tmp_path, storage):
    source = read_log("warehouse-small-simulated")
    bag = export_bag(source, tmp_path / "bag", storage=storage)
    assert sorted(path.name for path in bag.iterdir()) == \
        sorted(["metadata.yaml", f"bag.{'db3' if storage == 'sqlite3' else 'mcap'}"])
    with AnyReader([bag]) as reader:
        topics = {name: (info.msgtype, info.msgcount) for name, info in reader.topics.items()}
        odometry = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()
                    if c.topic == "/odom"]
    frames, samples = len(source.frames["time"]), source.odometry["time"].size
    assert topics == {
        "/azgym/log": ("std_msgs/msg/String", 1),
        "/azgym/detections": ("azgym_msgs/msg/BeaconAzimuths", frames),
        "/azgym/truth": ("geometry_msgs/msg/PoseStamped", frames),
        "/tf": ("tf2_msgs/msg/TFMessage", frames),
        "/odom": ("nav_msgs/msg/Odometry", samples),
        "/joint_states": ("sensor_msgs/msg/JointState", samples),
        "/imu": ("sensor_msgs/msg/Imu", source.imu["time"].size)}
    assert odometry[5].header.frame_id == "odom" and odometry[5].child_frame_id == "base_link"
    assert odometry[5].twist.twist.linear.x == source.odometry["speed"][5]
    assert math.isnan(odometry[5].twist.twist.angular.z)  # format 1: no wheelbase to turn with
    same_logs(source, import_bag(bag, tmp_path / "back"))


def test_a_differential_drive_route_round_trips_with_its_camera_mount(tmp_path):
    log = read_log(export_route("robot-arena", "wander-1", 3, tmp_path / "log"))
    assert "yaw_rate" in log.odometry.values and log.imu is None
    bag = export_bag(log, tmp_path / "bag")
    with AnyReader([bag]) as reader:
        static = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()
                  if c.topic == "/tf_static"]
        assert "/joint_states" not in reader.topics and "/imu" not in reader.topics
    (mount,) = static[0].transforms
    assert (mount.header.frame_id, mount.child_frame_id) == ("base_link", "camera")
    assert mount.transform.translation.x == log.manifest.profile.vehicle.camera_ahead
    back = import_bag(bag, tmp_path / "back")
    same_logs(log, back)
    assert back.notes == ()  # the mount read from /tf_static is the profile's


def test_a_forklift_route_gives_its_turn_rate_from_the_steering_angle_and_wheelbase(tmp_path):
    folder = export_route("warehouse-small", "cross-aisle", 1, tmp_path / "log")
    manifest = (folder / "log.toml").read_text()
    (folder / "log.toml").write_text(manifest.replace('kind = "forklift"',
                                                      'kind = "forklift"\nwheelbase = 1.4'))
    log = read_log(folder)
    wheelbase = log.manifest.profile.vehicle.wheelbase
    assert "steer" in log.odometry.values and wheelbase
    bag = export_bag(log, tmp_path / "bag", storage="mcap")
    with AnyReader([bag]) as reader:
        turn = np.array([reader.deserialize(raw, c.msgtype).twist.twist.angular.z
                         for c, _, raw in reader.messages() if c.topic == "/odom"])
        steer = np.array([reader.deserialize(raw, c.msgtype).position[0]
                          for c, _, raw in reader.messages() if c.topic == "/joint_states"])
    odometry = log.odometry.values
    assert np.array_equal(steer, odometry["steer"])
    assert np.allclose(turn, odometry["speed"] * np.tan(odometry["steer"]) / wheelbase,
                       rtol=0, atol=1e-12)
    same_logs(log, import_bag(bag, tmp_path / "back"))


def test_position_only_truth_travels_as_a_zero_quaternion_and_no_tf(mini_log, tmp_path):
    frames = (mini_log / "frames.csv").read_text().splitlines()
    (mini_log / "log.toml").write_text((mini_log / "log.toml").read_text().replace(
        "format = 1", "format = 2"))
    (mini_log / "odometry.csv").unlink()
    (mini_log / "frames.csv").write_text("\n".join(
        ",".join(line.split(",")[:4]) for line in frames) + "\n")
    source = read_log(mini_log)
    assert source.has_truth and not source.has_heading
    bag = export_bag(source, tmp_path / "bag")
    with AnyReader([bag]) as reader:
        assert "/tf" not in reader.topics
    same_logs(source, import_bag(bag, tmp_path / "back"))


def test_truth_at_its_own_rate_from_odometry_or_tf_is_interpolated_onto_the_frames(tmp_path):
    make = Messages(store())
    beacons = load_scenario("warehouse-small").beacons

    def truth(t):  # along the shipped log's first aisle, turning slowly
        return 2.3 + 0.5 * t, 6.0, 0.1 * t

    times = np.arange(20) / 10.0 + 0.025  # frames at 10 Hz, between the mocap's samples
    detections = []
    for k, t in enumerate(times):
        x, y, heading = truth(t)
        bearing = np.arctan2(beacons.xyz[:, 1] - y, beacons.xyz[:, 0] - x) - heading
        detections.append((round(t * 1e9), make.detections(
            t, k, beacons.ids, np.arctan2(np.sin(bearing), np.cos(bearing)))))
    mocap = np.arange(41) / 20.0  # 20 Hz, from before the first frame to after the last
    bag = write_bag(tmp_path / "bag", {
        "/azgym/detections": ("azgym_msgs/msg/BeaconAzimuths", detections),
        "/mocap": ("nav_msgs/msg/Odometry", [(round(t * 1e9), make.odometry(
            t, 0.0, 0.0, truth(t), frame_id="map")) for t in mocap]),
        "/tf": ("tf2_msgs/msg/TFMessage", [(round(t * 1e9), make.tf(t, "map", "rig", *truth(t)))
                                           for t in mocap])})
    expected = np.array([truth(t) for t in times]).T
    named = Options(map="warehouse-small", name="line")
    for name, options in (("odometry", BagImport(topics={"truth": "/mocap"}, log=named)),
                          ("tf", BagImport(truth_frame="rig", log=named))):
        log = import_bag(bag, tmp_path / name, options)
        assert np.allclose(log.frames["x"], expected[0], rtol=0, atol=1e-12)
        assert np.array_equal(log.frames["y"], expected[1])
        assert np.allclose(log.frames["heading"], expected[2], rtol=0, atol=1e-12)
        assert log.manifest.truth.startswith("ROS bag topic /") and log.manifest.name == "line"
    with pytest.raises(InvalidInputError, match="no beacon map"):
        import_bag(bag, tmp_path / "unnamed", BagImport(truth_frame="rig"))


def test_a_users_detection_type_is_read_through_a_field_mapping(tmp_path):
    definition = ("std_msgs/Header header\nmy_msgs/Blob[] blobs\n", "my_msgs/msg/Blobs")
    blob = ("int32 code\nfloat64 bearing\nfloat32 size\n", "my_msgs/msg/Blob")
    from rosbags.typesys import get_types_from_msg
    extra = {**get_types_from_msg(*blob), **get_types_from_msg(*definition)}
    types = store(extra=extra)
    make = Messages(types)
    source = read_log("warehouse-small-simulated")
    topics = log_topics(source, make, manifest=False)
    frames, found = source.frames, source.detections
    Blob, Blobs = types.types["my_msgs/msg/Blob"], types.types["my_msgs/msg/Blobs"]
    blobs = []
    for k, time in enumerate(frames["time"]):
        rows = np.flatnonzero(found["frame"] == k)
        blobs.append((round(time * 1e9), Blobs(header=make.header(time, "camera"), blobs=[
            Blob(code=int(found["id"][r]), bearing=float(found["azimuth"][r]),
                 size=float(np.float32(found["quality"][r, 0]))) for r in rows])))
    topics["/blobs"] = ("my_msgs/msg/Blobs", blobs)
    del topics["/azgym/detections"]
    bag = write_bag(tmp_path / "bag", topics, types=types)
    msg = tmp_path / "Blobs.msg"
    msg.write_text(definition[0])
    mapping = Mapping(("blobs", "code"), ("blobs", "bearing"), (("size", ("blobs", "size")),))
    log = import_bag(bag, tmp_path / "log", BagImport(
        topics={"detections": "/blobs"}, detections_type="my_msgs/msg/Blobs", mapping=mapping,
        log=Options(map="warehouse-small", name="blobs")))
    assert log.quality_names == ("size",) and not log.detections["labelled"]
    assert np.array_equal(log.frames["frame"], np.arange(len(frames["time"])))
    assert np.array_equal(log.detections["id"], found["id"])
    assert np.array_equal(log.detections["azimuth"], found["azimuth"])
    assert np.array_equal(log.detections["quality"][:, 0],
                          found["quality"][:, 0].astype(np.float32).astype(np.float64))
    assert np.array_equal(log.frames["x"], frames["x"])
    assert log.manifest.name == "blobs" and log.manifest.scenario == "warehouse-small"


@pytest.mark.parametrize("heading", [True, False])
def test_a_log_whose_truth_is_a_tum_file_round_trips_with_the_truth_on_its_frames(tmp_path,
                                                                                 heading):
    from logs.test_tum import tum_log

    source = read_log(tum_log(tmp_path, heading=heading, every=2))
    assert source.manifest.truth_file is not None and source.has_heading == heading
    back = import_bag(export_bag(source, tmp_path / "bag"), tmp_path / "back")
    assert back.manifest.truth_file is None  # the bag's truth is on the frames, not a file
    assert back.manifest.truth == source.manifest.truth
    same_logs(dataclasses.replace(source, manifest=back.manifest), back)

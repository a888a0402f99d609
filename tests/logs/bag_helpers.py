"""Bags the tests write themselves with rosbags, message by message (not through azgym's export).

:func:`write_bag` writes topics of messages (or of raw bytes, for malformed ones) as a ROS 2
bag (sqlite3 or MCAP) or a ROS 1 bag; :class:`Messages` makes the messages of a log's data in
the layout docs/ros2.md describes; :func:`bag_of_log` writes a whole log that way.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from azgym.logs.manifest import MANIFEST
from azgym.logs.ros.messages import DETECTIONS_MSG, DETECTIONS_TYPE
from azgym.sensing.labels import LABEL_NAMES


def store(ros1: bool = False, extra: dict | None = None):
    """ROS 2 Jazzy's (or ROS 1 Noetic's) types with azgym's detections (and ``extra``)."""
    types = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_JAZZY)
    types.register(get_types_from_msg(DETECTIONS_MSG, DETECTIONS_TYPE))
    if extra:
        types.register(extra)
    return types


def write_bag(path: Path, topics: dict, storage: str = "sqlite3", ros1: bool = False,
              types=None) -> Path:
    """Write ``topics`` (name -> (type, [(time ns, message or bytes)])) as a bag at ``path``."""
    types = types or store(ros1)
    if ros1:
        writer = Writer1(path)
    else:
        writer = Writer(path, version=9, storage_plugin=StoragePlugin[storage.upper()])
    with writer:
        for topic, (kind, messages) in topics.items():
            connection = writer.add_connection(topic, kind, typestore=types)
            for ns, message in messages:
                data = message if isinstance(message, (bytes, memoryview)) else \
                    types.serialize_ros1(message, kind) if ros1 else \
                    types.serialize_cdr(message, kind)
                writer.write(connection, ns, data)
    return path


def ns_of(time: float) -> int:
    """A time [s] in whole nanoseconds, as azgym's export rounds it."""
    sec = math.floor(time)
    return sec * 10**9 + round((time - sec) * 1e9)


class Messages:
    """Messages of the types docs/ros2.md names, with a type store's classes."""

    def __init__(self, types) -> None:
        self.types = types
        self.t = types.types

    def header(self, time: float, frame_id: str):
        ns = ns_of(time)
        stamp = self.t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        fields = {"stamp": stamp, "frame_id": frame_id}
        if "seq" in dict(self.types.fielddefs["std_msgs/msg/Header"][1]):
            fields["seq"] = 0  # ROS 1's header
        return self.t["std_msgs/msg/Header"](**fields)

    def vector(self, x=0.0, y=0.0, z=0.0):
        return self.t["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=float(z))

    def quaternion(self, heading):
        if heading is None:
            return self.t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=0.0)
        return self.t["geometry_msgs/msg/Quaternion"](
            x=0.0, y=0.0, z=math.sin(heading / 2), w=math.cos(heading / 2))

    def pose(self, x, y, heading):
        return self.t["geometry_msgs/msg/Pose"](
            position=self.t["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
            orientation=self.quaternion(heading))

    def pose_stamped(self, time, x, y, heading):
        return self.t["geometry_msgs/msg/PoseStamped"](header=self.header(time, "map"),
                                                      pose=self.pose(x, y, heading))

    def odometry(self, time, speed, yaw_rate, pose=(0.0, 0.0, 0.0), frame_id="odom"):
        t = self.t
        return t["nav_msgs/msg/Odometry"](
            header=self.header(time, frame_id), child_frame_id="base_link",
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=self.pose(*pose),
                                                           covariance=np.zeros(36)),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](linear=self.vector(speed),
                                                   angular=self.vector(0, 0, yaw_rate)),
                covariance=np.zeros(36)))

    def imu(self, time, yaw_rate, accel=None, heading=None):
        unknown = np.array([-1.0] + [0.0] * 8)
        return self.t["sensor_msgs/msg/Imu"](
            header=self.header(time, "base_link"),
            orientation=self.quaternion(heading if heading is not None else 0.0),
            orientation_covariance=np.zeros(9) if heading is not None else unknown,
            angular_velocity=self.vector(0, 0, yaw_rate), angular_velocity_covariance=np.zeros(9),
            linear_acceleration=self.vector(*(accel or (0.0, 0.0))),
            linear_acceleration_covariance=np.zeros(9) if accel is not None else unknown)

    def detections(self, time, frame, ids, azimuths, quality_names=(), quality=(), labels=(),
                   sequence="", event=""):
        return self.t[DETECTIONS_TYPE](
            header=self.header(time, "camera"), frame=int(frame),
            ids=np.asarray(ids, dtype=np.int64), azimuths=np.asarray(azimuths, dtype=np.float64),
            quality_names=list(quality_names), quality=np.asarray(quality, dtype=np.float64),
            labels=list(labels), sequence=sequence, event=event)

    def string(self, text):
        return self.t["std_msgs/msg/String"](data=text)

    def tf(self, time, parent, child, x, y, heading):
        t = self.t
        transform = t["geometry_msgs/msg/TransformStamped"](
            header=self.header(time, parent), child_frame_id=child,
            transform=t["geometry_msgs/msg/Transform"](translation=self.vector(x, y),
                                                       rotation=self.quaternion(heading)))
        return t["tf2_msgs/msg/TFMessage"](transforms=[transform])

    def joints(self, time, names, positions):
        return self.t["sensor_msgs/msg/JointState"](
            header=self.header(time, ""), name=list(names),
            position=np.asarray(positions, dtype=np.float64), velocity=np.zeros(0),
            effort=np.zeros(0))


def log_topics(log, make: Messages, manifest: bool = True) -> dict:
    """A log's data as topics (docs/ros2.md's layout), with its manifest and map if asked."""
    frames, found = log.frames, log.detections
    bounds = np.searchsorted(found["frame"], np.arange(len(frames["time"]) + 1))
    detections, poses = [], []
    for k, time in enumerate(frames["time"]):
        a, b = bounds[k], bounds[k + 1]
        detections.append((ns_of(time), make.detections(
            time, frames["frame"][k], found["id"][a:b], found["azimuth"][a:b], log.quality_names,
            found["quality"][a:b].ravel(),
            [LABEL_NAMES[label] for label in found["label"][a:b]] if found["labelled"] else [],
            frames["sequence"][k], frames["event"][k])))
        if log.has_truth:
            x, y, heading = log.pose(k)
            poses.append((ns_of(time), make.pose_stamped(
                time, x, y, heading if log.has_heading else None)))
    topics = {"/azgym/detections": (DETECTIONS_TYPE, detections)}
    if poses:
        topics["/azgym/truth"] = ("geometry_msgs/msg/PoseStamped", poses)
    if log.odometry is not None:
        o = log.odometry.values
        turn = o.get("yaw_rate", np.full(o["time"].size, math.nan))
        topics["/odom"] = ("nav_msgs/msg/Odometry", [
            (ns_of(t), make.odometry(t, s, r))
            for t, s, r in zip(o["time"], o["speed"], turn, strict=True)])
        if "steer" in o:
            topics["/joint_states"] = ("sensor_msgs/msg/JointState", [
                (ns_of(t), make.joints(t, ["steer"], [s]))
                for t, s in zip(o["time"], o["steer"], strict=True)])
    if log.imu is not None:
        i = log.imu.values
        topics["/imu"] = ("sensor_msgs/msg/Imu", [
            (ns_of(t), make.imu(t, i["yaw_rate"][k],
                                (i["ax"][k], i["ay"][k]) if "ax" in i else None,
                                None if "heading" not in i or np.isnan(i["heading"][k])
                                else i["heading"][k]))
            for k, t in enumerate(i["time"])])
    if manifest:
        start = ns_of(frames["time"][0])
        topics["/azgym/log"] = ("std_msgs/msg/String", [
            (start, make.string((log.folder / MANIFEST).read_text()))])
        if log.manifest.beacons:
            topics["/azgym/map"] = ("std_msgs/msg/String", [
                (start, make.string((log.folder / log.manifest.beacons).read_text()))])
    return topics


def bag_of_log(log, path: Path, storage: str = "sqlite3", ros1: bool = False) -> Path:
    """A log written as a bag by the test's own code (not azgym's export)."""
    return write_bag(path, log_topics(log, Messages(store(ros1))), storage, ros1)


def same_logs(a, b, time_tolerance=1e-9, angle_tolerance=1e-15) -> None:
    """Two logs hold the same data: exactly, but times (to the nanosecond) and headings."""
    assert a.manifest == b.manifest and a.map_name == b.map_name
    assert a.quality_names == b.quality_names
    assert np.array_equal(a.beacons.ids, b.beacons.ids)
    assert np.array_equal(a.beacons.xyz, b.beacons.xyz)
    assert np.array_equal(a.beacons.width, b.beacons.width)
    for table in ("frames", "detections", "odometry", "imu"):
        x, y = getattr(a, table), getattr(b, table)
        assert (x is None) == (y is None), table
        if x is None:
            continue
        assert sorted(x.values) == sorted(y.values), table
        for key, value in x.values.items():
            other = y.values[key]
            if not isinstance(value, np.ndarray):
                assert value == other, (table, key)
                continue
            assert value.shape == other.shape and value.dtype == other.dtype, (table, key)
            tolerance = time_tolerance if key == "time" else \
                angle_tolerance if key == "heading" else 0.0
            assert np.allclose(value, other, rtol=0, atol=tolerance, equal_nan=True), \
                (table, key, np.nanmax(np.abs(value - other)))

"""``azgym export bag``: a log written as a ROS 2 bag (sqlite3 or MCAP) that a ROS stack replays.

:func:`export_bag` writes a log (as :func:`~azgym.logs.read_log` reads it) on the topics of
:data:`~azgym.logs.ros.topics.TOPICS`, in standard types and REP-105 frames: each frame's
detections (azgym's type, frame ``camera``), the camera's true pose (``map``) on its own topic
and in tf (``map`` to ``camera_truth``), the odometry (``odom`` to ``base_link``; a steered
vehicle's steering angle as a joint state too), the IMU (``base_link``), the camera's mount
(``base_link`` to ``camera`` in ``/tf_static``, when the profile gives ``camera_ahead``), and
the log's manifest and map file as text, so that ``azgym import bag`` gives the log back
(docs/ros2.md says what travels exactly). Messages are written in time order; the bag is
made in a scratch folder inside ``out`` and moved into place when complete.
"""

from __future__ import annotations

import heapq
import math
import os
import tempfile
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from azgym.errors import InvalidInputError
from azgym.files import claim_folder, prepare_folder
from azgym.logs.files import MAX_TABLE_BYTES
from azgym.logs.manifest import MANIFEST, MAX_MANIFEST_BYTES
from azgym.logs.read import Log
from azgym.logs.ros.messages import (
    BASE_LINK,
    CAMERA,
    CAMERA_TRUTH,
    DETECTIONS_TYPE,
    IMU,
    JOINT_STATE,
    MAP,
    ODOM,
    ODOMETRY,
    POSE,
    STRING,
    TF,
    TRANSFORM,
    require_rosbags,
    stamps,
    typestore,
    yaw_quaternion,
)
from azgym.logs.ros.topics import TF_STATIC_TOPIC, TF_TOPIC, TOPICS
from azgym.sensing.labels import LABEL_NAMES
from azgym.site.toml_writer import to_toml
from azgym.untrusted import read_regular_file

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ["BAG_FILES", "STORAGES", "claim_bag", "export_bag"]

STORAGES = ("sqlite3", "mcap")
"""The storage formats of a ROS 2 bag azgym writes (rosbag2's plugins)."""
BAG_FILES = ("metadata.yaml", "*.db3", "*.mcap")
"""The files of a ROS 2 bag's folder, which an export refuses to replace without ``overwrite``."""
ROSBAG2_VERSION: Literal[8] = 8
"""The rosbag2 metadata version written (rosbags writes 8 and 9; 8 is read by more ROS 2
releases)."""

Message = tuple[int, int, int, str, Any]
"""A message to write: its time [ns], its stream's rank and its rank in it (for a stable
order), its topic, and its bytes."""


def export_bag(log: Log, out: str | Path, *, storage: str = "sqlite3",
               overwrite: bool = False) -> Path:
    """Write ``log`` as a ROS 2 bag folder ``out`` (docs/ros2.md).

    Args:
        log: The log, as :func:`~azgym.logs.read_log` reads it.
        out: The bag's folder (created if needed; the bag's files are named after it).
        storage: ``sqlite3`` or ``mcap`` (:data:`STORAGES`).
        overwrite: Whether a bag already in ``out`` may be replaced.

    Returns:
        The bag's folder.

    Raises:
        DependencyNotInstalled: rosbags is missing (``pip install "azgym[ros]"``).
        InvalidInputError: An unknown storage, a bag in ``out`` (without ``overwrite``), or a
            log a bag cannot hold (a time beyond a ROS stamp, a map file that is not text),
            before anything is written.
    """
    require_rosbags()
    from rosbags.rosbag2 import StoragePlugin, Writer

    out = Path(out)
    written = claim_bag(out, storage, overwrite)
    name = out.resolve().name
    store = typestore()
    for table, columns in (("frames.csv", log.frames), ("odometry", log.odometry),
                           ("imu", log.imu)):
        if columns is not None:  # a time a stamp cannot hold: refused before anything is written
            stamps(columns["time"], f"{log.folder}: {table}")
    streams = _streams(log, store)
    prepare_folder(out)
    with tempfile.TemporaryDirectory(dir=out, prefix=".azgym-bag-") as scratch:
        path = Path(scratch) / name
        with Writer(path, version=ROSBAG2_VERSION,
                    storage_plugin=StoragePlugin[storage.upper()]) as writer:
            connections = {topic: writer.add_connection(topic, kind, typestore=store)
                           for topic, (kind, _) in streams.items()}
            for ns, _, _, topic, data in heapq.merge(*(stream for _, stream in
                                                        streams.values())):
                writer.write(connections[topic], ns, data)
        for file in written:
            os.replace(path / file, out / file)
    return out


def claim_bag(out: Path, storage: str, overwrite: bool) -> list[str]:
    """``out`` as a bag's folder to write: its files, checked before any work is done.

    Raises:
        InvalidInputError: An unknown storage, ``out`` a file, a bag there (without
            ``overwrite``), or a file of it the new bag would leave beside it.
    """
    if storage not in STORAGES:
        raise InvalidInputError(f"storage: {storage!r} is none of {', '.join(STORAGES)}")
    written = ["metadata.yaml",
               f"{out.resolve().name}.{'db3' if storage == 'sqlite3' else 'mcap'}"]
    if out.is_file():
        raise InvalidInputError(f"out: {out} is a file; a ROS 2 bag is a folder")
    claim_folder(out, BAG_FILES, overwrite, "out")
    left = sorted(str(path) for pattern in BAG_FILES if out.is_dir()
                  for path in out.glob(pattern) if path.name not in written)
    if left:
        raise InvalidInputError(f"out: {', '.join(left)} belong to the bag there and would be "
                                "left beside the new one; move them away first (nothing was "
                                "written)")
    return written


def _streams(log: Log, store: Typestore) -> dict[str, tuple[str, Iterator[Message]]]:
    """Each topic's type and messages (made as they are written), in the order written."""
    build = _Builder(store)
    frames, odometry, imu = log.frames, log.odometry, log.imu
    start = min(float(table["time"][0]) for table in (frames, odometry, imu)
                if table is not None and table["time"].size)
    streams: dict[str, tuple[str, Iterator[Message]]] = {
        TOPICS["log"].default: (STRING, build.once(0, TOPICS["log"].default, start, STRING,
                                                   data=_manifest_text(log)))}
    if (text := _map_text(log)) is not None:
        streams[TOPICS["map"].default] = (STRING, build.once(1, TOPICS["map"].default, start,
                                                             STRING, data=text))
    ahead = log.manifest.profile.vehicle.camera_ahead
    if ahead is not None:
        mount = build.transform(start, BASE_LINK, CAMERA, (ahead, 0.0), 0.0)
        streams[TF_STATIC_TOPIC] = (TF, build.once(2, TF_STATIC_TOPIC, start, TF,
                                                   transforms=[mount]))
    streams[TOPICS["detections"].default] = (DETECTIONS_TYPE, build.detections(3, log))
    if log.has_truth:
        streams[TOPICS["truth"].default] = (POSE, build.poses(4, log))
        if log.has_heading:
            streams[TF_TOPIC] = (TF, build.truth_tf(5, log))
    if odometry is not None:
        streams[TOPICS["odometry"].default] = (ODOMETRY, build.odometry(6, log))
        if "steer" in odometry.values:
            streams[TOPICS["steering"].default] = (JOINT_STATE, build.steering(7, log))
    if imu is not None:
        streams[TOPICS["imu"].default] = (IMU, build.imu(8, log))
    return streams


def _manifest_text(log: Log) -> str:
    """The log's manifest file, as text: as it is, unless it takes the truth from a TUM file.

    The bag carries the truth on the frames (topic ``/azgym/truth``), where the reader put it,
    and no TUM file: the manifest then keeps the truth's ``source`` alone, written anew.
    """
    text = read_regular_file(log.folder / MANIFEST, MAX_MANIFEST_BYTES, "manifest").decode()
    if log.manifest.truth_file is None:
        return text
    data = tomllib.loads(text)
    source = {key: value for key, value in data.pop("truth").items() if key == "source"}
    file = log.manifest.truth_file.name
    return to_toml(data | ({"truth": source} if source else {}),
                   f"An azgym log (docs/logs.md); its truth, read from {file}, is on the frames "
                   "of the bag (docs/ros2.md).")


def _map_text(log: Log) -> str | None:
    """The log's map file as text (None for a shipped scenario)."""
    manifest = log.manifest
    name = manifest.beacons or (None if log.shipped_map else manifest.scenario)
    if name is None:
        return None
    data = read_regular_file(log.folder / name, MAX_TABLE_BYTES, "map file")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise InvalidInputError(f"{log.folder / name}: not text; a bag carries the map file as "
                                "text (write the beacon table as CSV)") from None


class _Builder:
    """Messages of each kind, made from a log's columns with the type store's classes."""

    def __init__(self, store: Typestore) -> None:
        self.store = store
        self.types = store.types

    def serialize(self, message: object, typename: str) -> Any:
        return self.store.serialize_cdr(message, typename)

    def header(self, sec: int, nanosec: int, frame_id: str) -> Any:
        stamp = self.types["builtin_interfaces/msg/Time"](sec=int(sec), nanosec=int(nanosec))
        return self.types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)

    def vector(self, x: float, y: float, z: float = 0.0) -> Any:
        return self.types["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=float(z))

    def quaternion(self, heading: float | None) -> Any:
        """A yaw's quaternion; the zero quaternion (no orientation) for None."""
        x, y, z, w = (0.0, 0.0, 0.0, 0.0) if heading is None else yaw_quaternion(heading)
        return self.types["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def transform(self, time: float, parent: str, child: str, xy: tuple[float, float],
                  heading: float) -> Any:
        sec, nanosec = stamps(np.array([time]), f"{parent} to {child}")
        return self.types[TRANSFORM](
            header=self.header(sec[0], nanosec[0], parent), child_frame_id=child,
            transform=self.types["geometry_msgs/msg/Transform"](
                translation=self.vector(*xy), rotation=self.quaternion(heading)))

    def once(self, rank: int, topic: str, time: float, typename: str, **fields: Any
             ) -> Iterator[Message]:
        """One message at ``time``."""
        sec, nanosec = stamps(np.array([time]), topic)
        yield (int(sec[0]) * 10**9 + int(nanosec[0]), rank, 0, topic,
               self.serialize(self.types[typename](**fields), typename))

    def stamped(self, rank: int, topic: str, times: np.ndarray, where: str
                ) -> Iterator[tuple[int, tuple[int, int, int, str], tuple[int, int]]]:
        """For each time: its row, the message's place in the stream, and its stamp's parts."""
        sec, nanosec = stamps(times, where)
        for k in range(times.size):
            yield k, (int(sec[k]) * 10**9 + int(nanosec[k]), rank, k, topic), \
                (int(sec[k]), int(nanosec[k]))

    def detections(self, rank: int, log: Log) -> Iterator[Message]:
        frames, found = log.frames, log.detections
        bounds = np.searchsorted(found["frame"], np.arange(len(frames["time"]) + 1))
        quality = np.ascontiguousarray(found["quality"], dtype=np.float64)
        topic, kind = TOPICS["detections"].default, self.types[DETECTIONS_TYPE]
        for k, place, stamp in self.stamped(rank, topic, frames["time"], "frames.csv, time"):
            a, b = bounds[k], bounds[k + 1]
            message = kind(
                header=self.header(*stamp, CAMERA), frame=int(frames["frame"][k]),
                ids=found["id"][a:b].astype(np.int64), azimuths=found["azimuth"][a:b],
                quality_names=list(log.quality_names), quality=quality[a:b].ravel(),
                labels=[LABEL_NAMES[label] for label in found["label"][a:b]]
                if found["labelled"] else [],
                sequence=frames["sequence"][k], event=frames["event"][k])
            yield (*place, self.serialize(message, DETECTIONS_TYPE))

    def poses(self, rank: int, log: Log) -> Iterator[Message]:
        frames, pose = log.frames, self.types[POSE]
        topic = TOPICS["truth"].default
        for k, place, stamp in self.stamped(rank, topic, frames["time"], "frames.csv, time"):
            x, y, heading = log.pose(k) or (math.nan,) * 3
            yield (*place, self.serialize(pose(
                header=self.header(*stamp, MAP),
                pose=self.types["geometry_msgs/msg/Pose"](
                    position=self.types["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                    orientation=self.quaternion(heading if log.has_heading else None))), POSE))

    def truth_tf(self, rank: int, log: Log) -> Iterator[Message]:
        frames, tf = log.frames, self.types[TF]
        for k, place, _ in self.stamped(rank, TF_TOPIC, frames["time"], "frames.csv, time"):
            x, y, heading = log.pose(k) or (math.nan,) * 3
            transform = self.transform(float(frames["time"][k]), MAP, CAMERA_TRUTH, (x, y),
                                       heading)
            yield (*place, self.serialize(tf(transforms=[transform]), TF))

    def odometry(self, rank: int, log: Log) -> Iterator[Message]:
        """Odometry: its speed and turn rate in the twist; no pose.

        A steered vehicle's turn rate is speed · tan(steer) / wheelbase with the profile's
        wheelbase, NaN without one.
        """
        assert log.odometry is not None
        columns, kind = log.odometry.values, self.types[ODOMETRY]
        wheelbase = log.manifest.profile.vehicle.wheelbase
        turn = columns["yaw_rate"] if "yaw_rate" in columns else \
            columns["speed"] * np.tan(columns["steer"]) / wheelbase if wheelbase else \
            np.full(columns["speed"].size, np.nan)
        covariance = np.zeros(36)
        pose = self.types["geometry_msgs/msg/PoseWithCovariance"](
            pose=self.types["geometry_msgs/msg/Pose"](
                position=self.types["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                orientation=self.quaternion(0.0)), covariance=covariance)
        topic = TOPICS["odometry"].default
        for k, place, stamp in self.stamped(rank, topic, columns["time"], "odometry, time"):
            twist = self.types["geometry_msgs/msg/TwistWithCovariance"](
                twist=self.types["geometry_msgs/msg/Twist"](
                    linear=self.vector(columns["speed"][k], 0.0),
                    angular=self.vector(0.0, 0.0, turn[k])), covariance=covariance)
            yield (*place, self.serialize(kind(header=self.header(*stamp, ODOM),
                                               child_frame_id=BASE_LINK, pose=pose,
                                               twist=twist), ODOMETRY))

    def steering(self, rank: int, log: Log) -> Iterator[Message]:
        """A steered vehicle's steering angle: joint ``steer`` at each odometry sample."""
        assert log.odometry is not None
        columns, kind = log.odometry.values, self.types[JOINT_STATE]
        topic, empty = TOPICS["steering"].default, np.zeros(0)
        for k, place, stamp in self.stamped(rank, topic, columns["time"], "odometry, time"):
            yield (*place, self.serialize(kind(
                header=self.header(*stamp, ""), name=["steer"],
                position=columns["steer"][k:k + 1], velocity=empty, effort=empty), JOINT_STATE))

    def imu(self, rank: int, log: Log) -> Iterator[Message]:
        """The IMU: turn rate, accelerations and heading (as the orientation).

        A covariance's first element is -1 where its value is not measured.
        """
        assert log.imu is not None
        columns, kind = log.imu.values, self.types[IMU]
        zeros = np.zeros(9)
        unknown = np.array([-1.0, *zeros[1:]])
        accelerations = "ax" in columns
        heading = columns.get("heading")
        topic = TOPICS["imu"].default
        for k, place, stamp in self.stamped(rank, topic, columns["time"], "imu, time"):
            value = math.nan if heading is None else float(heading[k])
            known = math.isfinite(value)
            yield (*place, self.serialize(kind(
                header=self.header(*stamp, BASE_LINK),
                orientation=self.quaternion(value if known else 0.0),
                orientation_covariance=zeros if known else unknown,
                angular_velocity=self.vector(0.0, 0.0, columns["yaw_rate"][k]),
                angular_velocity_covariance=zeros,
                linear_acceleration=self.vector(columns["ax"][k], columns["ay"][k])
                if accelerations else self.vector(0.0, 0.0),
                linear_acceleration_covariance=zeros if accelerations else unknown), IMU))

"""The ROS messages azgym reads and writes: its detection type, the standard types, times, yaw.

A camera frame's detections travel as azgym's own type, :data:`DETECTIONS_TYPE`, whose ``.msg``
definition is :data:`DETECTIONS_MSG` (docs/ros2.md prints it); its ``VERSION`` constant,
:data:`DETECTIONS_VERSION`, changes with any change to its fields, as a log's ``format`` does.
Everything else is a standard type of ROS 2 (:data:`STORE`: the definitions rosbags ships for
it, which a bag's own definitions override). A header stamp is whole seconds and nanoseconds:
:func:`stamps` and :func:`seconds` convert azgym's float seconds both ways, and
:func:`yaw_quaternion` and :func:`yaw` a heading and an orientation. rosbags (``pip install
"azgym[ros]"``) is imported only when a type store is built (:func:`typestore`), so that
``import azgym`` never loads it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from azgym.errors import InvalidInputError, require
from azgym.logs.tum import quaternion_yaw

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ["BASE_LINK", "CAMERA", "CAMERA_TRUTH", "DETECTIONS_MSG", "DETECTIONS_TYPE",
           "DETECTIONS_VERSION", "IMU", "JOINT_STATE", "MAP", "ODOM", "ODOMETRY", "POSE", "STORE",
           "STRING", "TF", "TRANSFORM", "require_rosbags", "seconds", "stamps", "typestore",
           "yaw", "yaw_quaternion"]

DETECTIONS_TYPE = "azgym_msgs/msg/BeaconAzimuths"
"""The ROS type of a camera frame's beacon detections."""
DETECTIONS_VERSION = 1
"""The version of :data:`DETECTIONS_MSG`: its ``VERSION`` constant, bumped with any field."""
DETECTIONS_MSG = f"""\
# One camera frame's beacon detections, as azgym logs them (docs/ros2.md, docs/logs.md).
uint8 VERSION={DETECTIONS_VERSION}
std_msgs/Header header     # stamp: the frame's time; frame_id: "camera"
int64 frame                # the camera's frame number
int64[] ids                # each detection's decoded beacon id; negative: not decoded
float64[] azimuths         # [rad], camera frame, counter-clockwise from its x-axis, in [-pi, pi]
string[] quality_names     # the names of the quality values (blob size, brightness, ...)
float64[] quality          # row-major, len(ids) x len(quality_names); empty: none
string[] labels            # each detection's truth (direct, partial, ghost, ...); empty: none
string sequence            # the frame's sequence; empty: the log's
string event               # "kidnap" or "outage" on the first frame after one, else empty
"""
"""The ``.msg`` definition of :data:`DETECTIONS_TYPE`."""

ODOMETRY = "nav_msgs/msg/Odometry"
IMU = "sensor_msgs/msg/Imu"
POSE = "geometry_msgs/msg/PoseStamped"
TF = "tf2_msgs/msg/TFMessage"
TRANSFORM = "geometry_msgs/msg/TransformStamped"
JOINT_STATE = "sensor_msgs/msg/JointState"
STRING = "std_msgs/msg/String"

MAP, ODOM, BASE_LINK, CAMERA = "map", "odom", "base_link", "camera"
"""The frames of REP-105 azgym writes (and the camera's, where detections are measured)."""
CAMERA_TRUTH = "camera_truth"
"""The tf child frame of the camera's true pose, under ``map``."""


STORE = "ROS 2 Jazzy"
"""Whose standard types' definitions :func:`typestore` holds: the current LTS's (rosbags')."""


def require_rosbags() -> None:
    """Stop with the install line when rosbags (the ``ros`` extra) is missing."""
    require("rosbags", "ros")


def typestore(extra: dict[str, object] | None = None) -> Typestore:
    """The types azgym reads and writes: ROS 2's standard ones, its detections, and ``extra``.

    Args:
        extra: More types (rosbags' parsed definitions: ``get_types_from_msg``), e.g. a user's
            detection type.

    Raises:
        DependencyNotInstalled: rosbags is not installed.
    """
    require_rosbags()
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(DETECTIONS_MSG, DETECTIONS_TYPE))
    if extra:
        store.register(extra)  # type: ignore[arg-type]
    return store


def stamps(times: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Float seconds as a header's (sec, nanosec), each rounded to the nearest nanosecond.

    Raises:
        InvalidInputError: A time that is not finite, negative (a bag's times are not), or
            beyond a stamp's int32 seconds (``what`` names where).
    """
    times = np.asarray(times, dtype=np.float64)
    bad = ~(np.isfinite(times) & (times >= 0) & (times < 2.0**31 - 1))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InvalidInputError(f"{what}: time {times[k].item()!r} (row {k}) does not fit a ROS "
                                "stamp (seconds from 0 to 2**31 - 1)")
    sec = np.floor(times)
    nanosec = np.rint((times - sec) * 1e9)
    carry = nanosec >= 1e9
    sec, nanosec = sec + carry, np.where(carry, 0.0, nanosec)
    return sec.astype(np.int64), nanosec.astype(np.int64)


def seconds(sec: np.ndarray, nanosec: np.ndarray) -> np.ndarray:
    """A header's (sec, nanosec) as float seconds: ``sec + nanosec / 1e9``."""
    return np.asarray(sec, dtype=np.float64) + np.asarray(nanosec, dtype=np.float64) / 1e9


def yaw_quaternion(heading: float) -> tuple[float, float, float, float]:
    """The quaternion (x, y, z, w) of a turn by ``heading`` about the z-axis."""
    return 0.0, 0.0, math.sin(heading / 2.0), math.cos(heading / 2.0)


def yaw(x: np.ndarray, y: np.ndarray, z: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The yaw of quaternions (:func:`~azgym.logs.tum.quaternion_yaw`); NaN for a zero one.

    A zero quaternion (all four zero) is how a message says it has no orientation.
    """
    zero = (x == 0) & (y == 0) & (z == 0) & (w == 0)
    return np.where(zero, np.nan, quaternion_yaw(x, y, z, w))

"""The topics of an azgym bag: what each carries, its default name, its type, and its limits.

``azgym export bag`` writes every topic under its default name (:data:`TOPICS`), and ``azgym
import bag`` reads the same names unless told others. The limits bound what an import holds in
memory, as a log's tables are bounded (:mod:`azgym.logs.files`): a topic's message count, a
message's size (checked before it is deserialized), and the detections in all.
"""

from __future__ import annotations

from dataclasses import dataclass

from azgym.logs.files import MAX_TABLE_BYTES, MAX_TABLE_CELLS
from azgym.logs.manifest import MAX_MANIFEST_BYTES
from azgym.logs.ros.messages import (
    DETECTIONS_TYPE,
    IMU,
    JOINT_STATE,
    ODOMETRY,
    POSE,
    STRING,
    TF,
)

__all__ = ["MAX_MESSAGES", "MAX_MESSAGE_BYTES", "TF_STATIC_TOPIC", "TF_TOPIC", "TOPICS", "Topic"]

MAX_MESSAGES = MAX_TABLE_CELLS // 3
"""The most messages a topic may carry: the rows of a three-column table (a log's smallest)."""
MAX_MESSAGE_BYTES = 1024 * 1024
"""The largest message read [bytes] (a frame's detections: some 20 000 of them)."""


@dataclass(frozen=True)
class Topic:
    """One kind of data in a bag.

    Attributes:
        default: The topic's name unless an option names another.
        types: The message types it may carry.
        what: What it holds, for messages and ``--help``.
        max_bytes: The largest message of it read [bytes].
        single: Whether it carries exactly one message (the manifest, the map).
    """

    default: str
    types: tuple[str, ...]
    what: str
    max_bytes: int = MAX_MESSAGE_BYTES
    single: bool = False


TOPICS = {
    "detections": Topic("/azgym/detections", (DETECTIONS_TYPE,), "each frame's detections"),
    "odometry": Topic("/odom", (ODOMETRY,), "the wheel odometry"),
    "imu": Topic("/imu", (IMU,), "the IMU"),
    "truth": Topic("/azgym/truth", (POSE, ODOMETRY, TF), "the camera's true pose"),
    "steering": Topic("/joint_states", (JOINT_STATE,), "a steered vehicle's steering angle"),
    "log": Topic("/azgym/log", (STRING,), "the log's manifest (log.toml)",
                 MAX_MANIFEST_BYTES + 64, single=True),
    "map": Topic("/azgym/map", (STRING,), "the log's beacon map file",
                 MAX_TABLE_BYTES + 64, single=True),
}
"""Each kind of data by name: the names ``--KIND-topic`` options take."""
TF_TOPIC = "/tf"
"""Where the truth is in tf (parent ``map``, child ``camera_truth``), and read from with
``--truth-frame``."""
TF_STATIC_TOPIC = "/tf_static"
"""Where the camera's mount on the vehicle is (``base_link`` to ``camera``)."""

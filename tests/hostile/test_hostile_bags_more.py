"""More hostile bags: what tests/hostile/test_hostile_bags.py does not try, each refused by name.

A user type's field paths that name an element past a sequence's end or several frame numbers,
a quaternion that is no rotation (Euler angles written into it), a time before 1970, a truth
sample stamped like the one before but elsewhere, an IMU that measures its turn rate in some
messages only. Each is refused with a sentence naming the bag, topic, message and field, never
a traceback of numpy's or a log silently wrong.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
from logs.bag_helpers import Messages, log_topics, store, write_bag
from logs.mini_log import mini_files, write_log

from azgym.errors import InvalidInputError
from azgym.logs import read_log
from azgym.logs.ros import BagImport, import_bag
from azgym.logs.ros.detections import Mapping
from azgym.logs.ros.log_files import Options

BLOB = ("int64 code\nfloat64 bearing\n", "my_msgs/msg/Blob")
BLOBS = ("std_msgs/Header header\nmy_msgs/Blob[] blobs\nint64[] ids\nfloat64[] bearings\n",
         "my_msgs/msg/Blobs")


def _refused(bag: Path, out: Path, match: str, options: BagImport | None = None) -> str:
    with pytest.raises(InvalidInputError, match=match) as refused:
        import_bag(bag, out, options or BagImport())
    assert not out.exists(), "a refused bag writes nothing"
    return str(refused.value)


def _blobs_bag(tmp_path: Path) -> Path:
    """A user's detection type: frame k has k % 2 blobs (message 0 none) and k % 2 + 1 ids."""
    from rosbags.typesys import get_types_from_msg

    types = store(extra={**get_types_from_msg(*BLOB), **get_types_from_msg(*BLOBS)})
    make = Messages(types)
    blob, blobs = types.types[BLOB[1]], types.types[BLOBS[1]]
    messages = [(10**8 * (k + 1), blobs(
        header=make.header(0.1 * (k + 1), "camera"), blobs=[blob(code=k, bearing=0.1)] * (k % 2),
        ids=np.arange(k % 2 + 1), bearings=np.full(k % 2 + 1, 0.2))) for k in range(4)]
    return write_bag(tmp_path / "blobs", {"/blobs": (BLOBS[1], messages)}, types=types)


def _mapped(mapping: Mapping) -> BagImport:
    return BagImport(topics={"detections": "/blobs"}, detections_type=BLOBS[1], mapping=mapping,
                     log=Options(map="warehouse-small"))


def test_a_frame_number_field_that_holds_no_number_or_several_is_named(tmp_path):
    bag = _blobs_bag(tmp_path)
    _refused(bag, tmp_path / "out", r"topic /blobs, message 0, field blobs.code: 0 values, "
                                    r"a frame number is one",
             _mapped(Mapping(("ids",), ("bearings",), frame=("blobs", "code"))))
    _refused(bag, tmp_path / "out", r"topic /blobs, message 1, field ids: 2 values, a frame "
                                    r"number is one",
             _mapped(Mapping(("ids",), ("bearings",), frame=("ids",))))


def test_an_element_past_the_end_of_a_sequence_is_named(tmp_path):
    bag = _blobs_bag(tmp_path)
    _refused(bag, tmp_path / "out", r"topic /blobs, message 0, field bearings.1: no element 1 "
                                    r"\(bearings has 1\)",
             _mapped(Mapping(("ids",), ("bearings",), (("q", ("bearings", 1)),))))


def _mini_topics(tmp_path: Path) -> tuple[dict, Messages]:
    make = Messages(store())
    log = read_log(write_log(tmp_path / "mini", mini_files()))
    return log_topics(log, make), make


def test_a_quaternion_that_is_no_rotation_is_named(tmp_path):
    topics, make = _mini_topics(tmp_path)
    for _, message in topics["/azgym/truth"][1]:  # yaw written into z, w left 0: Euler angles
        orientation = message.pose.orientation
        orientation.z, orientation.w = 2 * math.atan2(orientation.z, orientation.w) + 0.5, 0.0
    _refused(write_bag(tmp_path / "bag", topics), tmp_path / "out",
             r"topic /azgym/truth, message 0, field pose.orientation: the quaternion's norm is "
             r"0.5, not 1 \(within 0.001\): not an orientation \(3 such message\(s\)\)")
    topics, make = _mini_topics(tmp_path / "2")
    topics["/imu"][1][1][1].orientation.w = 1.5
    _refused(write_bag(tmp_path / "bag2", topics), tmp_path / "out",
             r"topic /imu, message 1, field orientation: the quaternion's norm is 1.5")


def test_a_stamp_before_1970_is_named(tmp_path):
    topics, make = _mini_topics(tmp_path)
    topics["/azgym/detections"][1][0][1].header.stamp.sec = -5
    _refused(write_bag(tmp_path / "bag", topics), tmp_path / "out",
             r"topic /azgym/detections, message 0, field header.stamp.sec: -5 is negative \(a "
             r"ROS time counts from 1970\)")


def test_a_truth_sample_stamped_like_the_one_before_but_elsewhere_is_named(tmp_path):
    topics, make = _mini_topics(tmp_path)
    truth = topics["/azgym/truth"][1]
    other = copy.deepcopy(truth[1])
    other[1].pose.position.x += 0.2
    truth.insert(2, other)
    _refused(write_bag(tmp_path / "bag", topics), tmp_path / "out",
             r"topic /azgym/truth, message 2: the same stamp as message 1 \(0.1 s\), another "
             r"pose: which is the truth\?")


def test_an_imu_measuring_its_turn_rate_in_some_messages_only_is_named(tmp_path):
    topics, make = _mini_topics(tmp_path)
    topics["/imu"][1][1][1].angular_velocity_covariance[0] = -1.0
    _refused(write_bag(tmp_path / "bag", topics), tmp_path / "out",
             r"topic /imu, message 1, field angular_velocity_covariance: a yaw rate measured in "
             r"some messages only")


@pytest.mark.parametrize(("version", "expected"), [
    (2, r"the bag's azgym_msgs/msg/BeaconAzimuths is version 2, with fields header, frame, ids, "
        r"azimuths, seen; this azgym reads version 1 \(docs/ros2.md\)"),
    (1, r"the bag's azgym_msgs/msg/BeaconAzimuths says version 1 but its fields are header, "
        r"frame, ids, azimuths, seen; version 1's are header, frame, ids, azimuths, "
        r"quality_names, quality, labels, sequence, event \(docs/ros2.md\)")])
def test_another_version_of_azgyms_detection_type_is_named(tmp_path, version, expected):
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from azgym.logs.ros.messages import DETECTIONS_TYPE

    types = get_typestore(Stores.ROS2_JAZZY)
    types.register(get_types_from_msg(
        f"uint8 VERSION={version}\nstd_msgs/Header header\nint64 frame\nint64[] ids\n"
        "float64[] azimuths\nbool seen\n", DETECTIONS_TYPE))
    make = Messages(types)
    message = types.types[DETECTIONS_TYPE](header=make.header(0.0, "camera"), frame=0,
                                           ids=np.array([1]), azimuths=np.array([0.1]),
                                           seen=True)
    bag = write_bag(tmp_path / "bag", {"/azgym/detections": (DETECTIONS_TYPE, [(0, message)])},
                    types=types)
    _refused(bag, tmp_path / "out", expected)

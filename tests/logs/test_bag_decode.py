"""The fixed-layout fast path reads every number exactly as rosbags' deserializer does."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from logs.bag_helpers import Messages, store

from azgym.logs.ros.decode import FixedLayout, field_problem, field_values, read_columns

PATHS = {
    "nav_msgs/msg/Odometry": [("header", "stamp", "sec"), ("header", "stamp", "nanosec"),
                              ("twist", "twist", "linear", "x"),
                              ("twist", "twist", "angular", "z"), ("pose", "covariance", 35)],
    "sensor_msgs/msg/Imu": [("header", "stamp", "sec"), ("angular_velocity", "z"),
                            ("linear_acceleration", "y"), ("orientation", "w"),
                            ("linear_acceleration_covariance", 0)],
    "geometry_msgs/msg/PoseStamped": [("header", "stamp", "nanosec"), ("pose", "position", "x"),
                                      ("pose", "orientation", "z")],
}
numbers = st.floats(allow_nan=True, allow_infinity=True, width=64)


def _message(make: Messages, kind: str, frame_id: str, values: list[float], time: float):
    if kind == "nav_msgs/msg/Odometry":
        message = make.odometry(time, values[0], values[1], (values[2], values[3], 0.0),
                                frame_id=frame_id)
        message.pose.covariance[35] = values[4]
        return message
    if kind == "sensor_msgs/msg/Imu":
        message = make.imu(time, values[0], (values[1], values[2]), None)
        message.header.frame_id = frame_id
        message.orientation.w = values[3]
        return message
    message = make.pose_stamped(time, values[0], values[1], None)
    message.header.frame_id = frame_id
    message.pose.orientation.z = values[2]
    return message


def _bits(values: np.ndarray) -> np.ndarray:
    return values.view(np.int64) if values.dtype == np.float64 else values


@settings(max_examples=60, deadline=None)
@given(kind=st.sampled_from(sorted(PATHS)), ros1=st.booleans(),
       frame_ids=st.lists(st.sampled_from(["odom", "odom", "map", "", "a_long_frame_name"]),
                          min_size=1, max_size=12),
       values=st.lists(numbers, min_size=5, max_size=5),
       times=st.lists(st.floats(0, 2e9), min_size=12, max_size=12))
def test_the_fast_path_reads_what_deserializing_reads(kind, ros1, frame_ids, values, times):
    types = store(ros1)
    make = Messages(types)
    serialize = types.serialize_ros1 if ros1 else types.serialize_cdr
    deserialize = types.deserialize_ros1 if ros1 else types.deserialize_cdr
    messages = [_message(make, kind, frame_id, [v * (k + 1) for v in values], times[k])
                for k, frame_id in enumerate(frame_ids)]
    raws = [bytes(serialize(message, kind)) for message in messages]
    layout = FixedLayout.of(types, kind, raws[0], cdr=not ros1)
    assert layout is not None
    paths = PATHS[kind]
    fast = read_columns(raws, paths, layout, lambda k, raw: deserialize(raw, kind))
    slow = read_columns(raws, paths, None, lambda k, raw: deserialize(raw, kind))
    for path, a, b in zip(paths, fast, slow, strict=True):
        expected = np.array([field_values(deserialize(raw, kind), path)[0] for raw in raws])
        assert np.array_equal(_bits(a), _bits(b)), path
        assert np.array_equal(_bits(a.astype(expected.dtype)), _bits(expected)), path
    read, _ = layout.read(raws, paths)
    assert read.tolist() == [frame_id == frame_ids[0] for frame_id in frame_ids]


def test_a_type_with_a_sequence_has_no_fixed_layout_and_paths_are_checked():
    types = store()
    make = Messages(types)
    raw = bytes(types.serialize_cdr(make.joints(0.0, ["steer"], [0.1]),
                                    "sensor_msgs/msg/JointState"))
    assert FixedLayout.of(types, "sensor_msgs/msg/JointState", raw, cdr=True) is None
    assert field_problem(types, "nav_msgs/msg/Odometry", ("twist", "twist", "linear", "x")) is None
    assert "has no field 'speed'" in field_problem(types, "nav_msgs/msg/Odometry",
                                                   ("twist", "speed"))
    assert "not a number" in field_problem(types, "nav_msgs/msg/Odometry", ("child_frame_id",))
    assert field_problem(types, "sensor_msgs/msg/JointState", ("position",)) is None

"""Hostile bags: each refused with a sentence naming the bag, topic, message and field.

Missing topics, wrong types, stamps that run back, arrays of different lengths, NaN and
infinite values, ids a log cannot hold, truncated files (sqlite3 and MCAP), garbage, a
message or a topic too large. What could hang or eat memory if a guard regressed runs in a
child process with a time limit and an address-space limit.
"""

from __future__ import annotations

import math
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from logs.bag_helpers import Messages, log_topics, ns_of, store, write_bag
from logs.mini_log import mini_files, write_log

from azgym.errors import AzgymError, InvalidInputError
from azgym.logs import read_log
from azgym.logs.ros import BagImport, export_bag, import_bag
from azgym.logs.ros import streams as streams_module
from azgym.logs.ros.log_files import Options

MEMORY = 1536 * 2**20
"""The child's address-space limit [bytes]: three times what an import of a small bag peaks at."""
CHILD = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({memory}, {memory}))
from azgym.logs.ros import import_bag
try:
    import_bag(sys.argv[1], sys.argv[2])
except Exception as exc:
    print(type(exc).__name__, exc)
"""


def _topics(tmp_path: Path, log_topic: bool = True) -> tuple[dict, Messages]:
    """The mini log's topics (with its manifest and map unless told), and a message maker."""
    make = Messages(store())
    log = read_log(write_log(tmp_path / "mini", mini_files()))
    return log_topics(log, make, manifest=log_topic), make


def _refused(bag: Path, out: Path, match: str, options: BagImport | None = None) -> str:
    with pytest.raises(InvalidInputError, match=match) as refused:
        import_bag(bag, out, options or BagImport())
    assert not out.exists(), "a refused bag writes nothing"
    return str(refused.value)


def _refused_in_child(bag: Path, out: Path) -> str:
    """The import's refusal, run in a child process under a time and memory limit."""
    done = subprocess.run([sys.executable, "-c", CHILD.format(memory=MEMORY), str(bag), str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("InvalidInputError "), done.stdout + done.stderr[-2000:]
    assert not out.exists()
    return done.stdout


def test_missing_topics_are_named_with_the_bags_topics_and_types(tmp_path):
    topics, _ = _topics(tmp_path)
    del topics["/azgym/detections"]
    bag = write_bag(tmp_path / "bag", topics)
    message = _refused(bag, tmp_path / "out", "no topic /azgym/detections")
    assert "the bag's topics: /azgym/log (std_msgs/msg/String, 1 messages)" in message
    assert "/odom (nav_msgs/msg/Odometry, 2 messages)" in message
    topics, _ = _topics(tmp_path / "2")
    bag = write_bag(tmp_path / "bag2", topics)
    _refused(bag, tmp_path / "out", "no topic /wheels .*the bag's topics: ",
             BagImport(topics={"odometry": "/wheels"}))
    _refused(bag, tmp_path / "out", "no topic /tf .*the bag's topics",
             BagImport(truth_frame="rig"))
    with pytest.raises(AzgymError, match="unknown topic kind 'odom'. Did you mean 'odometry'"):
        import_bag(bag, tmp_path / "out", BagImport(topics={"odom": "/odom"}))


def test_a_topic_of_the_wrong_type_is_named(tmp_path):
    topics, make = _topics(tmp_path)
    topics["/odom"] = ("geometry_msgs/msg/PoseStamped",
                       [(ns_of(0.05), make.pose_stamped(0.05, 1.0, 2.0, 0.0))])
    bag = write_bag(tmp_path / "bag", topics)
    _refused(bag, tmp_path / "out", "topic /odom: its messages are geometry_msgs/msg/PoseStamped, "
                                    "not nav_msgs/msg/Odometry")
    _refused(bag, tmp_path / "out", "topic /azgym/log: its messages are std_msgs/msg/String, not "
             "azgym_msgs/msg/BeaconAzimuths", BagImport(topics={"detections": "/azgym/log"}))


def test_stamps_running_back_within_a_topic_are_named(tmp_path):
    topics, make = _topics(tmp_path)
    kind, messages = topics["/odom"]
    ns, _ = messages[1]
    messages[1] = (ns, make.odometry(0.01, 1.0, 0.0))  # stamped before message 0's 0.05 s
    bag = write_bag(tmp_path / "bag", topics)
    _refused(bag, tmp_path / "out", r"topic /odom, message 1, field header.stamp: 0.01 s is "
                                    r"before the message before's 0.05 s \(message 0\)")


def test_a_detection_message_whose_arrays_differ_is_named(tmp_path):
    topics, make = _topics(tmp_path)
    _, messages = topics["/azgym/detections"]
    ns, _ = messages[1]
    messages[1] = (ns, make.detections(0.1, 1, [1, 2, 3], [0.1, 0.2]))
    bag = write_bag(tmp_path / "bag", topics)
    _refused(bag, tmp_path / "out", "topic /azgym/detections, message 1, field azimuths: 2 "
                                    "azimuths for 3 ids")
    messages[1] = (ns, make.detections(0.1, 1, [1, 2], [0.1, 0.2], ["size"], [1.0, 2.0, 3.0]))
    bag = write_bag(tmp_path / "bag2", topics)
    _refused(bag, tmp_path / "out", r"message 1, field quality: 3 values for 2 ids × 1 quality")
    messages[1] = (ns, make.detections(0.1, 1, [1, 2], [0.1, 0.2], ["size"], [1.0, 2.0],
                                       ["direct"]))
    bag = write_bag(tmp_path / "bag3", topics)
    _refused(bag, tmp_path / "out", "message 1, field labels: 1 labels for 2 ids")


@pytest.mark.parametrize(("value", "topic", "match"), [
    (math.nan, "/azgym/detections", r"message 0, field azimuths: nan \(item 0\) is not in"),
    (math.inf, "/azgym/detections", r"message 0, field azimuths: inf \(item 0\) is not in"),
    (4.0, "/azgym/detections", r"message 0, field azimuths: 4.0 \(item 0\) is not in \[-π, π\]"),
    (math.inf, "/odom", "topic /odom, message 0, field twist.twist.linear.x: inf is not finite"),
    (math.nan, "/imu", "topic /imu, message 0, field angular_velocity.z: nan is not finite"),
    (math.nan, "/azgym/truth", "topic /azgym/truth, message 0, field pose.position.x: nan"),
])
def test_nan_and_infinite_values_are_named(tmp_path, value, topic, match):
    topics, make = _topics(tmp_path)
    _, messages = topics[topic]
    ns, message = messages[0]
    if topic == "/azgym/detections":
        message.azimuths[0] = value
    elif topic == "/odom":
        message.twist.twist.linear.x = value
    elif topic == "/imu":
        message.angular_velocity.z = value
    else:
        message.pose.position.x = value
    _refused(write_bag(tmp_path / "bag", topics), tmp_path / "out", match)


def test_a_stamp_with_a_second_of_nanoseconds_is_named(tmp_path):
    topics, make = _topics(tmp_path)
    _, messages = topics["/imu"]
    messages[1][1].header.stamp.nanosec = 1_000_000_000
    _refused(write_bag(tmp_path / "bag", topics), tmp_path / "out",
             "topic /imu, message 1, field header.stamp.nanosec: 1000000000 is not a "
             "nanosecond count below 1e9")


@pytest.mark.parametrize("ident", [10**18, -(10**18), 2**63 - 1])
def test_ids_a_log_cannot_hold_are_named(tmp_path, ident):
    topics, make = _topics(tmp_path)
    _, messages = topics["/azgym/detections"]
    messages[0][1].ids[1] = ident
    _refused(write_bag(tmp_path / "bag", topics), tmp_path / "out",
             rf"message 0, field ids: {ident} \(item 1 of 4\) is not a whole number within "
             r"±999999999999999999")


def test_a_users_ids_that_are_not_whole_are_named(tmp_path):
    from rosbags.typesys import get_types_from_msg

    extra = get_types_from_msg("float64[] ids\nfloat64[] angles\n", "my_msgs/msg/Seen")
    types = store(extra=dict(extra))
    seen = types.types["my_msgs/msg/Seen"]
    bag = write_bag(tmp_path / "bag", {"/seen": ("my_msgs/msg/Seen", [
        (10**8, seen(ids=np.array([1.0, 2.0]), angles=np.array([0.1, 0.2]))),
        (2 * 10**8, seen(ids=np.array([1.0, 2.5]), angles=np.array([0.1, 0.2])))])},
        types=types)
    from azgym.logs.ros.detections import Mapping

    options = BagImport(topics={"detections": "/seen"}, detections_type="my_msgs/msg/Seen",
                        mapping=Mapping(("ids",), ("angles",)),
                        log=Options(map="warehouse-small"))
    _refused(bag, tmp_path / "out", r"topic /seen, message 1, field ids: 2.5 \(item 1 of 2\) "
                                    "is not a whole number", options)
    options = BagImport(topics={"detections": "/seen"}, detections_type="my_msgs/msg/Seen",
                        mapping=Mapping(("ids",), ("bearing",)), log=Options(map="x.csv"))
    _refused(bag, tmp_path / "out", "field bearing: my_msgs/msg/Seen has no field 'bearing' "
                                    r"\(its fields: ids, angles\)", options)


def test_a_message_declaring_more_elements_than_its_bytes_hold_is_named(tmp_path):
    topics, make = _topics(tmp_path)
    types = store()
    _, messages = topics["/azgym/detections"]
    ns, message = messages[0]
    raw = bytearray(types.serialize_cdr(message, "azgym_msgs/msg/BeaconAzimuths"))
    at = 4 + 8 + 4 + len(b"camera\0") + 5 + 8  # encapsulation, stamp, frame_id, padding, frame
    assert raw[at:at + 4] == struct.pack("<I", 4)  # the ids' count: frame 0 has four
    raw[at:at + 4] = struct.pack("<I", 2**32 - 1)
    messages[0] = (ns, bytes(raw))
    _refused(write_bag(tmp_path / "bag", topics, types=types), tmp_path / "out",
             "topic /azgym/detections, message 0: not a valid azgym_msgs/msg/BeaconAzimuths "
             r"\(.*Invalid sequence length 4294967295")


def test_a_huge_message_is_refused_by_its_size_before_it_is_read(tmp_path):
    topics, make = _topics(tmp_path)
    _, messages = topics["/azgym/detections"]
    messages[1][1].labels.extend(["direct"] * 0 + ["x" * 1000] * 5000)  # 5 MB of labels
    bag = write_bag(tmp_path / "bag", topics)
    message = _refused_in_child(bag, tmp_path / "out")
    assert "topic /azgym/detections, message 1: 50" in message
    assert "bytes, more than the 1048576 a message of it may have" in message
    topics, make = _topics(tmp_path / "2")
    topics["/azgym/log"] = ("std_msgs/msg/String", [(0, make.string("#" * 100_000))])
    message = _refused_in_child(write_bag(tmp_path / "bag2", topics), tmp_path / "out")
    assert "topic /azgym/log, message 0: 100009 bytes, more than the 65600" in message


def test_a_topic_with_more_messages_than_a_log_holds_is_refused_as_it_is_read(tmp_path,
                                                                              monkeypatch):
    monkeypatch.setattr(streams_module, "MAX_MESSAGES", 40)
    topics, make = _topics(tmp_path)
    topics["/imu"] = ("sensor_msgs/msg/Imu", [(ns_of(k / 200), make.imu(k / 200, 0.0))
                                              for k in range(41)])
    _refused(write_bag(tmp_path / "bag", topics), tmp_path / "out",
             "topic /imu: more than 40 messages, the most a log's table holds")


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_truncated_or_damaged_bag_is_refused(tmp_path, storage):
    bag = export_bag(read_log("warehouse-small-simulated"), tmp_path / "bag", storage=storage)
    (data,) = [path for path in bag.iterdir() if path.name != "metadata.yaml"]
    blob = data.read_bytes()
    for fraction in (0.5, 0.97):
        data.write_bytes(blob[:int(len(blob) * fraction)])
        message = _refused_in_child(bag, tmp_path / "out")
        assert f"{bag}: cannot open the bag" in message, message
    middle = len(blob) // 2  # its index intact, its messages damaged
    data.write_bytes(blob[:middle] + bytes(range(256)) * 64 + blob[middle + 16384:])
    message = _refused_in_child(bag, tmp_path / "out")
    expected = "cannot open the bag" if storage == "sqlite3" else "cannot read the bag after"
    assert f"{bag}: {expected}" in message, message  # sqlite checks its pages when opened


def test_garbage_and_files_that_are_no_bag_are_refused(tmp_path):
    rng = np.random.default_rng(0)
    garbage = tmp_path / "garbage"
    garbage.mkdir()
    (garbage / "data.db3").write_bytes(rng.bytes(4096))
    assert "cannot open the bag" in _refused_in_child(garbage, tmp_path / "out")
    (garbage / "metadata.yaml").write_bytes(rng.bytes(4096))
    assert "cannot open the bag" in _refused_in_child(garbage, tmp_path / "out")
    (garbage / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: 5\n")
    assert "cannot open the bag" in _refused_in_child(garbage, tmp_path / "out")
    for name in ("random.db3", "random.mcap", "random.bag"):
        (tmp_path / name).write_bytes(rng.bytes(65536))
        assert "cannot open the bag" in _refused_in_child(tmp_path / name, tmp_path / "out")
    (tmp_path / "notes.txt").write_text("not a bag")
    _refused(tmp_path / "notes.txt", tmp_path / "out", "notes.txt: not a bag: a ROS 2 bag")
    _refused(tmp_path / "nowhere", tmp_path / "out", "nowhere: no such bag")


def test_large_messages_are_decoded_a_few_megabytes_at_a_time(tmp_path, monkeypatch):
    # 8192 messages of up to 1 MiB each would be 8 GiB held for one batch: bytes bound it too.
    monkeypatch.setattr(streams_module, "BATCH_BYTES", 2**20)
    held = []
    flush = streams_module.Fields.flush

    def spy(self):
        held.append(self.held)
        flush(self)

    monkeypatch.setattr(streams_module.Fields, "flush", spy)
    topics, make = _topics(tmp_path)
    topics["/imu"] = ("sensor_msgs/msg/Imu", [
        (ns_of(k / 100), make.imu(k / 100, 0.0, (0.0, 0.0))) for k in range(1, 20)])
    for _, message in topics["/imu"][1]:
        message.header.frame_id = "x" * 200_000
    import_bag(write_bag(tmp_path / "bag", topics), tmp_path / "out")
    assert max(held) < 2**20 + 210_000 and len(held) > 3


def test_export_refuses_a_log_a_bag_cannot_hold_before_writing_anything(tmp_path):
    files = mini_files()
    files["odometry.csv"] = files["odometry.csv"].replace("0.05,", "-0.05,")  # a negative time
    log = read_log(write_log(tmp_path / "log", files))
    with pytest.raises(InvalidInputError, match=r"odometry: time -0.05 \(row 0\) does not fit "
                                                r"a ROS stamp"):
        export_bag(log, tmp_path / "bag")
    assert not (tmp_path / "bag").exists()
    (tmp_path / "bag").write_text("a file")
    with pytest.raises(InvalidInputError, match="is a file; a ROS 2 bag is a folder"):
        export_bag(read_log("warehouse-small-simulated"), tmp_path / "bag")

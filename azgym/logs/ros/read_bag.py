"""``azgym import bag``: a ROS 1 or ROS 2 bag (sqlite3 or MCAP) written as an azgym log.

:func:`import_bag` reads the topics :data:`~azgym.logs.ros.topics.TOPICS` names (or those
:class:`BagImport` names instead): the frames and their detections, the truth, odometry (and a
steering angle), the IMU, and an azgym bag's manifest and map; and the camera's mount in
``/tf_static``, compared with the log's profile. A default topic the bag lacks leaves its table
out; a topic named and missing, or of another type, is refused, listing the bag's topics with
their types. What a robot's recording does that a log does not (stamps never filled, a message
recorded twice, frames outside the truth's span, an IMU without a yaw rate) is read, not
refused, each change noted (:attr:`Bag.notes <azgym.logs.ros.bag.Bag>`, the log's notes).
Each message is checked as it is read (:mod:`azgym.logs.ros.streams`,
:mod:`azgym.logs.ros.detections`), the log's files are made (:mod:`azgym.logs.ros.log_files`)
and read back with :func:`~azgym.logs.read_log` in a scratch folder, and only a log that passes
is written to ``out``: a refused bag writes nothing.
"""

from __future__ import annotations

import dataclasses
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from azgym.errors import InvalidInputError, LogError, unknown_name
from azgym.files import prepare_folder, write_file
from azgym.logs.export import claim_log
from azgym.logs.read import Log, read_log
from azgym.logs.ros.bag import Bag, open_bag
from azgym.logs.ros.decode import FieldPath, field_problem, shown_path
from azgym.logs.ros.detections import Detections, Mapping
from azgym.logs.ros.log_files import Options, log_files
from azgym.logs.ros.messages import (
    BASE_LINK,
    CAMERA,
    DETECTIONS_TYPE,
    MAP,
    ODOMETRY,
    POSE,
    TF,
    require_rosbags,
    typestore,
    yaw,
)
from azgym.logs.ros.streams import Fields, Joint, Stream, Text, Transforms
from azgym.logs.ros.topics import MAX_MESSAGE_BYTES, TF_STATIC_TOPIC, TF_TOPIC, TOPICS
from azgym.logs.truth import MAX_GAP
from azgym.untrusted import read_regular_file

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ["BagImport", "import_bag"]

MAX_MSG_FILE_BYTES = 64 * 1024
"""The largest ``.msg`` file read [bytes]."""
MOUNT_TOLERANCE = 1e-6
"""How far a camera mount in ``/tf_static`` may be from the profile's before a note says so
[m, rad]."""
_POSES: dict[str, FieldPath] = {"x": ("position", "x"), "y": ("position", "y"),
                               **{f"q{axis}": ("orientation", axis) for axis in "xyzw"}}
_FIELDS: dict[str, dict[str, FieldPath]] = {
    "odometry": {"speed": ("twist", "twist", "linear", "x"),
                 "yaw_rate": ("twist", "twist", "angular", "z")},
    "imu": {"yaw_rate": ("angular_velocity", "z"), "rate": ("angular_velocity_covariance", 0),
            "ax": ("linear_acceleration", "x"),
            "ay": ("linear_acceleration", "y"),
            "accelerations": ("linear_acceleration_covariance", 0),
            "orientation": ("orientation_covariance", 0),
            **{f"q{axis}": ("orientation", axis) for axis in "xyzw"}},
    POSE: {name: ("pose", *path) for name, path in _POSES.items()},
    ODOMETRY: {name: ("pose", "pose", *path) for name, path in _POSES.items()},
}
"""The numbers read from each fixed-layout topic (by kind, or by type for the truth)."""


@dataclass(frozen=True)
class BagImport:
    """What to read from a bag, and what to say of the log a bag without a manifest makes.

    Attributes:
        topics: Topics named instead of the defaults, by kind (:data:`TOPICS`): a topic named
            must be in the bag.
        detections_type: A user's detection type (``PKG/msg/T``; default azgym's).
        msg_file: The ``.msg`` definition of ``detections_type``, for a bag that carries none.
        mapping: Where ``detections_type`` holds the ids, azimuths, quality and frame number.
        truth_frame: Read the truth from tf: this child frame's pose (topic ``/tf`` unless
            ``topics`` names another).
        truth_parent: The parent frame of ``truth_frame``.
        max_gap: The longest gap between truth samples a frame's truth is interpolated
            across [s] (:func:`azgym.logs.truth.truth_at`).
        steer_joint: The joint whose position is the steering angle.
        imu_heading: Whether an IMU's orientation is the heading (in the map frame).
        log: What a bag without a manifest (topic ``/azgym/log``) needs: map, name, ...
    """

    topics: dict[str, str] = field(default_factory=dict)
    detections_type: str | None = None
    msg_file: Path | None = None
    mapping: Mapping | None = None
    truth_frame: str | None = None
    truth_parent: str = MAP
    max_gap: float = MAX_GAP
    steer_joint: str = "steer"
    imu_heading: bool = True
    log: Options = Options()


def import_bag(bag: str | Path, out: str | Path, options: BagImport = BagImport(), *,
               overwrite: bool = False) -> Log:
    """Read a bag and write it as a log folder (docs/ros2.md).

    Args:
        bag: A ROS 2 bag's folder (or its ``.db3`` or ``.mcap`` file), or a ROS 1 ``.bag``.
        out: The log folder to write (created if needed).
        options: Topics, a user's detection type, and the manifest's fields for a bag
            without one.
        overwrite: Whether a log already in ``out`` may be replaced.

    Returns:
        The log written, as :func:`~azgym.logs.read_log` reads it, its notes preceded by what
        the import changed of what the bag says (``Bag.notes``: a robot's quirks read, not
        refused).

    Raises:
        DependencyNotInstalled: rosbags is missing (``pip install "azgym[ros]"``).
        InvalidInputError: A log in ``out`` (without ``overwrite``), or a problem of the bag
            (naming its topic, message and field) or of the log it makes; nothing is written.
    """
    require_rosbags()
    bag, out = Path(bag), Path(out)
    for kind in options.topics:
        if kind not in TOPICS:
            raise unknown_name("topic kind", kind, TOPICS)
    claim_log(out, overwrite)
    store = typestore(_msg_types(options))
    with open_bag(bag, store) as opened:
        streams = _streams(opened, options, store)
        by_topic = {stream.topic: stream for stream in streams.values()}
        connections = [c for topic in by_topic for c in opened.connections(topic)]
        for connection, ns, raw in opened.messages(connections):
            by_topic[connection.topic].add(ns, raw)
        files = log_files(opened, streams, options.log, options.max_gap,
                          explicit_steering="steering" in options.topics,
                          imu_heading=options.imu_heading)
        notes = tuple(opened.notes)
    with tempfile.TemporaryDirectory(prefix="azgym-bag-") as scratch:
        for name, text in files.items():
            (Path(scratch) / name).write_text(text, encoding="utf-8")
        try:
            log = read_log(scratch)
        except LogError as exc:
            raise InvalidInputError(f"{bag}: the log made of it is refused (nothing was written "
                                    f"to {out}):\n  " + "\n  ".join(exc.problems)) from None
    mount = streams.get("mount")
    if isinstance(mount, Transforms) and mount.rows:
        notes += _mount_notes(mount, log.manifest.profile.vehicle.camera_ahead)
    claim_log(out, overwrite, files)
    prepare_folder(out)
    for name, text in files.items():
        write_file(out / name, text)
    return dataclasses.replace(log, folder=out, notes=notes + log.notes)


def _msg_types(options: BagImport) -> dict[str, object] | None:
    """A user's detection type from its ``.msg`` file, if one is given."""
    if options.msg_file is None:
        return None
    from rosbags.typesys import TypesysError, get_types_from_msg

    if not options.detections_type:
        raise InvalidInputError("--msg-file: give the type it defines with --detections-type")
    data = read_regular_file(options.msg_file, MAX_MSG_FILE_BYTES, "message definition")
    try:
        return dict(get_types_from_msg(data.decode("utf-8"), options.detections_type))
    except (UnicodeDecodeError, TypesysError) as exc:
        raise InvalidInputError(f"{options.msg_file}: not a message definition "
                                f"({str(exc)[:200]})") from None


def _streams(bag: Bag, options: BagImport, store: Typestore) -> dict[str, Stream]:
    """A stream for each kind of data the bag has (or is told to have), its type checked."""
    streams: dict[str, Stream] = {}
    for kind, topic in TOPICS.items():
        named = options.topics.get(kind)
        if kind == "truth" and options.truth_frame is not None and named is None:
            named = TF_TOPIC
        name = named or topic.default
        types = (options.detections_type or DETECTIONS_TYPE,) if kind == "detections" else \
            topic.types
        found = bag.topics().get(name)
        if found is None:
            if named is not None or kind == "detections":
                raise InvalidInputError(f"{bag.path}: no topic {name} ({topic.what}); "
                                        f"{bag.listing()}")
            continue
        if found[0] not in types:
            raise InvalidInputError(f"{bag.where(name)}: its messages are "
                                    f"{found[0] or 'of several types'}, not {' or '.join(types)} "
                                    f"({topic.what}); {bag.listing()}")
        bag.define(found[0], store)
        streams[kind] = _stream(bag, kind, name, found[0], options)
    if bag.topics().get(TF_STATIC_TOPIC, (None,))[0] == TF and \
            all(stream.topic != TF_STATIC_TOPIC for stream in streams.values()):
        bag.define(TF, store)
        streams["mount"] = Transforms(bag, TF_STATIC_TOPIC, TF, MAX_MESSAGE_BYTES, CAMERA,
                                      BASE_LINK)
    return streams


def _mount_notes(mount: Transforms, ahead: float | None) -> tuple[str, ...]:
    """Notes on what the bag's camera mount says that the log's profile does not.

    The mount is ``base_link`` to ``camera`` in ``/tf_static`` (the last one given); noted: an
    offset ahead other than ``ahead`` (``vehicle.camera_ahead``) or none there, and any offset
    to the side or turn (a profile holds the offset ahead only).
    """
    columns = mount.columns()
    x, y = float(columns["x"][-1]), float(columns["y"][-1])
    turn = float(yaw(*(columns[f"q{axis}"][-1:] for axis in "xyzw"))[0])
    where = f"{mount.where()}: the camera's mount puts the camera {x!r} m ahead of {BASE_LINK}"
    notes = []
    if ahead is None:
        notes.append(f"{where}; the log's profile has none (give it with --profile)")
    elif abs(x - ahead) > MOUNT_TOLERANCE:
        notes.append(f"{where}, the log's profile {ahead!r} m (vehicle.camera_ahead, which the "
                     "log keeps)")
    if abs(y) > MOUNT_TOLERANCE or abs(turn) > MOUNT_TOLERANCE:
        notes.append(f"{where}, {y!r} m to its left, turned by {turn!r} rad: a log's profile "
                     "holds the camera's offset ahead only (the truth and the azimuths are the "
                     "camera's own: only a tracker's motion model assumes it faces ahead)")
    return tuple(notes)


def _stream(bag: Bag, kind: str, topic: str, typename: str, options: BagImport) -> Stream:
    """The stream that reads ``kind`` from ``topic``, its field paths checked on the type."""
    limit = TOPICS[kind].max_bytes
    if kind == "detections":
        mapping = _mapping(bag, topic, typename, options)
        return Detections(bag, topic, typename, limit, mapping)
    if kind == "steering":
        return Joint(bag, topic, typename, limit, options.steer_joint)
    if kind in ("log", "map"):
        return Text(bag, topic, typename, limit)
    if typename == TF:
        if options.truth_frame is None:
            raise InvalidInputError(f"{bag.where(topic)}: a tf topic; name the truth's child "
                                    "frame with --truth-frame")
        return Transforms(bag, topic, typename, limit, options.truth_frame,
                          options.truth_parent)
    paths = _FIELDS[kind if kind != "truth" else typename]
    _check_paths(bag, topic, typename, ("header", "stamp", "sec"), *paths.values())
    return Fields(bag, topic, typename, limit, paths)


def _mapping(bag: Bag, topic: str, typename: str, options: BagImport) -> Mapping | None:
    """A user's type's mapping (checked on its definition); None for azgym's own type."""
    if typename == DETECTIONS_TYPE:
        return None
    if options.mapping is None:
        raise InvalidInputError(f"{bag.where(topic)}: {typename} is not azgym's "
                                f"{DETECTIONS_TYPE}: say where its ids and azimuths are "
                                "(--ids-field, --azimuths-field)")
    mapping = options.mapping
    _check_paths(bag, topic, typename, mapping.ids, mapping.azimuths,
                 *(path for _, path in mapping.quality),
                 *([mapping.frame] if mapping.frame else []))
    return mapping


def _check_paths(bag: Bag, topic: str, typename: str, *paths: FieldPath) -> None:
    """Refuse a field path the type (as the bag defines it) does not have."""
    for path in paths:
        problem = field_problem(bag.reader.typestore, typename, path)
        if problem:
            raise InvalidInputError(f"{bag.where(topic, field=shown_path(path))}: {problem}")

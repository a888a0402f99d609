"""A bag's streams made into a log's files: the tables, the manifest and the map.

The frames come from the detections (:class:`~azgym.logs.ros.detections.Detections`), their
truth from a pose, odometry or tf topic put onto the frames' times
(:func:`~azgym.logs.truth.truth_at`; the frames outside its span left out), the odometry's turn
from a steering joint when there is one (else its turn rate), the IMU's turn rate,
accelerations and heading where the messages give them (a covariance's first element −1: not
measured; an IMU without a turn rate is left out). A truth or steering message repeating the
one before is read once; a quaternion must be a rotation's. What is changed is noted
(``Bag.notes``). The manifest and the map are an azgym bag's
own (topics ``/azgym/log`` and ``/azgym/map``: the log's files as they were) or, for any other
bag, made from :class:`Options`.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from azgym.errors import InvalidInputError, unknown_name
from azgym.logs.contents import QUALITY_PREFIX
from azgym.logs.export import csv_text
from azgym.logs.files import MAX_TABLE_BYTES
from azgym.logs.manifest import FORMAT_VERSION, MANIFEST, MAX_NAME, read_manifest
from azgym.logs.problems import Problems, places
from azgym.logs.problems import seconds as shown_seconds
from azgym.logs.ros.bag import Bag
from azgym.logs.ros.decode import shown_path
from azgym.logs.ros.detections import Detections
from azgym.logs.ros.messages import yaw
from azgym.logs.ros.streams import Fields, Joint, Stream, Text, Transforms
from azgym.logs.ros.topics import TOPICS
from azgym.logs.truth import covered, truth_at
from azgym.logs.tum import UNIT_TOLERANCE, not_unit
from azgym.profile import profile_toml, read_profile
from azgym.site import list_scenarios
from azgym.site.reader import name_problem
from azgym.site.toml_writer import to_toml
from azgym.untrusted import read_regular_file

__all__ = ["Options", "log_files"]

NOT_MEASURED = -1.0
"""A covariance's first element saying the value is not measured (sensor_msgs/Imu)."""


@dataclass(frozen=True)
class Options:
    """The manifest of a bag without one (every field None: not given).

    Attributes:
        map: The beacon map: a shipped scenario's name, a scenario file (``.toml``) or a beacon
            table (``.csv``), copied into the log.
        name: The dataset's name (default: the bag's).
        description: One line about it.
        simulated: Whether its frames are simulated (default: false).
        profile: A profile file (``PROFILE.toml``) whose sections the manifest takes.
    """

    map: str | None = None
    name: str | None = None
    description: str | None = None
    simulated: bool | None = None
    profile: Path | None = None


def log_files(bag: Bag, streams: dict[str, Stream], options: Options, max_gap: float, *,
              explicit_steering: bool, imu_heading: bool) -> dict[str, str]:
    """The log's files (name → text) from every stream read."""
    detections = streams["detections"]
    assert isinstance(detections, Detections)
    frames, found = detections.columns()
    truth, frames, found = _truth(streams.get("truth"), frames, found, max_gap)
    files = _manifest(bag, streams, options, truth is not None)
    files["frames.csv"] = csv_text(
        ["frame", "time", *(truth or {}), *(k for k in ("sequence", "event") if frames[k])],
        zip(frames["frame"].tolist(), frames["time"].tolist(),
            *(column.tolist() for column in (truth or {}).values()),
            *(frames[k] for k in ("sequence", "event") if frames[k]), strict=True))
    names = detections.quality_names or ()
    files["detections.csv"] = csv_text(
        ["frame", "id", "azimuth", *(QUALITY_PREFIX + name for name in names),
         *(["label"] if found["label"] is not None else [])],
        zip(frames["frame"][found["row"]].tolist(), found["id"].tolist(),
            found["azimuth"].tolist(), *found["quality"].T.tolist(),
            *([found["label"]] if found["label"] is not None else []), strict=True))
    odometry = streams.get("odometry")
    if isinstance(odometry, Fields) and odometry.count:  # a topic without messages: no table
        files["odometry.csv"] = _odometry(bag, odometry, streams.get("steering"),
                                          explicit_steering)
    imu = streams.get("imu")
    if isinstance(imu, Fields) and imu.count and (text := _imu(imu, imu_heading)) is not None:
        files["imu.csv"] = text
    return files


def _truth(stream: Stream | None, frames: dict[str, Any], found: dict[str, Any],
           max_gap: float) -> tuple[dict[str, np.ndarray] | None, dict[str, Any], dict[str, Any]]:
    """x, y (and heading) on every frame (None without a truth topic), and the frames kept.

    A message repeating the one before is read once; the frames before the truth's first sample
    and after its last are left out, with a note, when the samples cover some frame (else
    :func:`~azgym.logs.truth.truth_at` refuses them all).
    """
    if stream is None:
        return None, frames, found
    assert isinstance(stream, (Fields, Transforms))
    columns = stream.columns()
    if isinstance(stream, Fields):
        stream.check_finite(columns, "x", "y", "qx", "qy", "qz", "qw")
    columns = _once(stream, columns, "another pose: which is the truth?")
    quaternion = [columns[f"q{axis}"] for axis in "xyzw"]
    heading = yaw(*quaternion)
    given = np.isfinite(heading)
    field = shown_path(stream.paths["qx"][:-1]) if isinstance(stream, Fields) else \
        "transforms.transform.rotation"
    if given.any() and not given.all():
        k = int(np.flatnonzero(~given)[0])
        raise InvalidInputError(f"{stream.where(int(columns['index'][k]), field)}: a zero "
                                "quaternion (no orientation) while other poses have one")
    if given.all():
        _rotations(stream, columns["index"], quaternion, field)
    keep = covered(frames["time"], columns["time"])
    if keep.any() and not keep.all():
        frames, found = _trim(stream, frames, found, keep)
    x, y, h = truth_at(frames["time"], columns["time"], columns["x"], columns["y"],
                       heading if given.all() else None, source=stream.where(),
                       max_gap=max_gap, numbers=frames["frame"])
    return {"x": x, "y": y} | ({"heading": h} if h is not None else {}), frames, found


def _once(stream: Stream, columns: dict[str, np.ndarray], other: str
          ) -> dict[str, np.ndarray]:
    """A topic's samples, each message that repeats the one before read once, with a note.

    A message stamped like the one before with every value the same is a driver publishing its
    last sample again.

    Raises:
        InvalidInputError: A message stamped like the one before with another value (``other``
            says what, and asks which is right).
    """
    time, index = columns["time"], columns["index"]
    repeated = np.flatnonzero(time[1:] == time[:-1]) + 1
    if not repeated.size:
        return columns
    for k in repeated:
        if any(values[k] != values[k - 1] for name, values in columns.items() if name != "index"):
            raise InvalidInputError(f"{stream.where(int(index[k]))}: the same stamp as message "
                                    f"{int(index[k - 1])} ({shown_seconds(time[k])}), {other}")
    stream.bag.notes.append(f"{stream.where()}: {repeated.size} message(s) with the same stamp "
                            "and values as the message before "
                            f"({places(index[repeated].tolist(), 'message')}) read once")
    kept = np.ones(time.size, dtype=bool)
    kept[repeated] = False
    return {name: values[kept] for name, values in columns.items()}


def _rotations(stream: Stream, index: np.ndarray, quaternion: list[np.ndarray], field: str
               ) -> None:
    """Refuse a quaternion that is no rotation (:func:`~azgym.logs.tum.not_unit`)."""
    norm, off = not_unit(*quaternion)
    if off.size:
        k = int(off[0])
        raise InvalidInputError(f"{stream.where(int(index[k]), field)}: the quaternion's norm is "
                                f"{float(norm[k])!r}, not 1 (within {UNIT_TOLERANCE:g}): not an "
                                f"orientation ({off.size} such message(s))")


def _trim(stream: Stream, frames: dict[str, Any], found: dict[str, Any], keep: np.ndarray
          ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The frames within the truth's span and their detections, with a note on those left out.

    ``keep`` is a run (the frames' times increase): the frames before it and after it go.
    """
    first, last = int(np.argmax(keep)), int(keep.size - np.argmax(keep[::-1]))
    numbers = frames["frame"]
    stream.bag.notes.append(
        f"{stream.where()}: {first} frame(s) before its first sample and {keep.size - last} "
        f"after its last left out (frames {numbers[0]} to {numbers[-1]} became "
        f"{numbers[first]} to {numbers[last - 1]}): a frame's truth is interpolated, never "
        "extrapolated")
    rows = (found["row"] >= first) & (found["row"] < last)
    annotations = {key: (value[first:last] if value is not None and any(value[first:last])
                         else None) for key, value in frames.items()
                   if key in ("sequence", "event")}
    return frames | {"frame": numbers[first:last], "time": frames["time"][first:last]} | \
        annotations, found | {"row": found["row"][rows] - first, "id": found["id"][rows],
                              "azimuth": found["azimuth"][rows],
                              "quality": found["quality"][rows],
                              "label": None if found["label"] is None else
                              [label for label, kept in zip(found["label"], rows, strict=True)
                               if kept]}


def _odometry(bag: Bag, odometry: Fields, steering: Stream | None, explicit: bool) -> str:
    """odometry.csv: speed, and the steering angle (from a joint) or the turn rate."""
    columns = odometry.columns()
    odometry.check_finite(columns, "speed")
    joint = steering.columns() if isinstance(steering, Joint) else None
    if joint is None:
        if explicit and isinstance(steering, Joint):
            raise InvalidInputError(f"{steering.where()}: no message names joint "
                                    f"{steering.joint!r} (joints: "
                                    f"{', '.join(sorted(steering.names)) or 'none'})")
        odometry.check_finite(columns, "yaw_rate")
        turn = ("yaw_rate", columns["yaw_rate"])
    else:
        assert isinstance(steering, Joint)
        turn = ("steer", _steer_at(steering, joint, columns["time"]))
    return csv_text(["time", "speed", turn[0]], zip(
        columns["time"].tolist(), columns["speed"].tolist(), turn[1].tolist(), strict=True))


def _steer_at(steering: Joint, joint: dict[str, np.ndarray], times: np.ndarray) -> np.ndarray:
    """The steering angle at each odometry time: linear between the joint states around it."""
    joint = _once(steering, joint, "another steering angle: which is it?")
    stamps = joint["time"]
    outside = np.flatnonzero((times < stamps[0]) | (times > stamps[-1]))
    if outside.size:
        raise InvalidInputError(f"{steering.where()}: odometry at "
                                f"{times[outside[0]].item()!r} s lies outside the steering "
                                "angles' span "
                                f"({stamps[0].item()!r} to {stamps[-1].item()!r} s); "
                                f"{outside.size} odometry sample(s) do")
    return np.interp(times, stamps, joint["position"])


def _imu(imu: Fields, with_heading: bool) -> str | None:
    """imu.csv: the turn rate, the accelerations if measured, the heading where given.

    None, with a note, for an IMU that measures no turn rate (an AHRS giving its orientation
    only): a log's IMU gives one.
    """
    columns = imu.columns()
    imu.check_finite(columns, "rate", "accelerations", "orientation")
    if not _measured(imu, columns, "rate", "angular_velocity_covariance", "a yaw rate").any():
        imu.bag.notes.append(f"{imu.where(field='angular_velocity_covariance')}: no yaw rate "
                             "(element 0 is -1 in every message): a log's IMU gives one, so "
                             "the IMU is left out (no imu.csv)")
        return None
    imu.check_finite(columns, "yaw_rate")
    measured = _measured(imu, columns, "accelerations", "linear_acceleration_covariance",
                         "accelerations")
    header = ["time", "yaw_rate"]
    values = [columns["time"], columns["yaw_rate"]]
    if measured.all() and measured.size:
        imu.check_finite(columns, "ax", "ay")
        header += ["ax", "ay"]
        values += [columns["ax"], columns["ay"]]
    given = columns["orientation"] != NOT_MEASURED
    if with_heading and given.any():
        quaternion = [np.where(given, columns[f"q{axis}"], 0.0) for axis in "xyzw"]
        imu.finite(quaternion[0] + quaternion[1] + quaternion[2] + quaternion[3],
                   columns["index"], "orientation")
        _rotations(imu, columns["index"][given], [q[given] for q in quaternion], "orientation")
        header.append("heading")
        values.append(yaw(*quaternion))
    return csv_text(header, zip(*(column.tolist() for column in values), strict=True))


def _measured(imu: Fields, columns: dict[str, np.ndarray], name: str, field: str, what: str
              ) -> np.ndarray:
    """Whether each message measures ``what`` (its covariance's element 0 is not -1).

    Raises:
        InvalidInputError: Some messages do and others do not.
    """
    measured = columns[name] != NOT_MEASURED
    if measured.any() and not measured.all():
        k = int(np.flatnonzero(measured != measured[0])[0])
        raise InvalidInputError(f"{imu.where(k, field)}: {what} measured in some messages only "
                                "(element 0 is -1 in the others)")
    return measured


def _manifest(bag: Bag, streams: dict[str, Stream], options: Options, truth: bool
              ) -> dict[str, str]:
    """log.toml and the map's file: the bag's own, or made from the options."""
    log = streams.get("log")
    if isinstance(log, Text) and log.text is not None:
        given = [f"--{key}" for key, value in vars(options).items() if value is not None]
        if given:
            raise InvalidInputError(f"{bag.path}: the bag carries its log's manifest (topic "
                                    f"{log.topic}); {', '.join(given)} are for a bag without one")
        return {MANIFEST: log.text, **_map_file(bag, log.text, streams.get("map"))}
    if options.map is None:
        raise InvalidInputError(f"{bag.path}: no beacon map: the bag has no azgym manifest "
                                f"(topic {TOPICS['log'].default}); name the map with --map "
                                "SCENARIO, --map beacons.csv or --map scenario.toml")
    name = options.name or (bag.path.name if bag.path.is_dir() else bag.path.stem)
    if problem := name_problem(name, MAX_NAME):
        raise InvalidInputError(f"--name: {problem}{'' if options.name else ' (the bag name)'}")
    where, files = _map_option(options.map)
    topic = streams["truth"] if truth else None
    manifest = {
        "format": FORMAT_VERSION, "name": name,
        "description": options.description or f"imported from the ROS bag {bag.path.name}",
        "simulated": bool(options.simulated), "map": where,
        **({"truth": {"source": f"ROS bag topic {topic.topic} ({topic.typename})"}}
           if topic else {}),
        **(profile_toml(read_profile(options.profile)) if options.profile else {})}
    return {MANIFEST: to_toml(manifest, "An azgym log (docs/logs.md), imported from a ROS bag "
                                        "(docs/ros2.md)."), **files}


def _map_option(value: str) -> tuple[dict[str, str], dict[str, str]]:
    """``--map``: the manifest's map, and the file copied into the log (if any)."""
    if value in list_scenarios():
        return {"scenario": value}, {}
    for suffix, key, name in ((".toml", "scenario", "scenario.toml"),
                              (".csv", "beacons", "beacons.csv")):
        if value.endswith(suffix):
            data = read_regular_file(Path(value), MAX_TABLE_BYTES, "map file")
            try:
                return {key: name}, {name: data.decode("utf-8")}
            except UnicodeDecodeError:
                raise InvalidInputError(f"--map {value}: not UTF-8 text") from None
    raise unknown_name("scenario", value, list_scenarios())


def _map_file(bag: Bag, manifest: str, stream: Stream | None) -> dict[str, str]:
    """The map file an azgym bag's manifest names, from its map topic."""
    with tempfile.TemporaryDirectory() as folder:
        Path(folder, MANIFEST).write_text(manifest, encoding="utf-8")
        problems = Problems(f"{bag.path}: topic {TOPICS['log'].default}")
        parsed = read_manifest(Path(folder), problems)
    problems.check()
    assert parsed is not None
    shipped = parsed.scenario is None or parsed.scenario in list_scenarios()
    name = parsed.beacons or (None if shipped else parsed.scenario)
    if name is None:
        return {}
    if Path(name).name != name or name in (MANIFEST, "frames.csv", "detections.csv",
                                            "odometry.csv", "imu.csv"):
        raise InvalidInputError(f"{bag.path}: topic {TOPICS['log'].default}: the map {name!r} "
                                "is no file name of a log's folder")
    if not isinstance(stream, Text) or stream.text is None:
        raise InvalidInputError(f"{bag.path}: no topic {TOPICS['map'].default}: the manifest's "
                                f"map is the file {name}, which that topic carries")
    return {name: stream.text}


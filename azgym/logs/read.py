"""Read a log folder, checking every file, and hold it as frames of measurements with their truth.

:func:`read_log` checks the whole log before refusing it (:class:`~azgym.logs.problems.LogError`
lists every problem with its file, line and column). The rules (docs/logs.md): frames numbered
strictly increasing and timed never decreasing (one clock for the whole log); each detection in
a listed frame, the detections in frame order; azimuths in [−π, π]; the truth given on every
frame or not at all (x and y, and in format 2 the heading optionally); motion samples never
decreasing in time. Ids missing from the map are kept (a localizer ignores them), and so is the
same id twice in a frame at different azimuths (a mirror image carries its beacon's id); the
very same detection twice is refused as a logging bug. What real loggers' clocks do (repeated
time stamps, motion before the first frame or after the last) is settled, not refused, with a
note (:mod:`azgym.logs.clocks`, ``Log.notes``).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from azgym.core import BeaconMap, Pose
from azgym.logs.clocks import settle_frames, settle_stream
from azgym.logs.manifest import MANIFEST, Manifest, read_manifest, read_map
from azgym.logs.plausible import check_plausible
from azgym.logs.problems import LogError, Problems, shown
from azgym.logs.tables import (
    Columns,
    Table,
    check_columns,
    find_table,
    floats,
    integers,
    read_table,
)
from azgym.profile import DIFFERENTIAL_DRIVE
from azgym.sensing.labels import LABEL_NAMES
from azgym.site.load import SCENARIO_PACKAGE

__all__ = ["QUALITY_PREFIX", "Columns", "Log", "log_digest", "map_bytes", "read_log",
           "shipped_logs"]

TRUTH = ("x", "y", "heading")
"""The true camera pose's columns in ``frames.csv`` [m, m, rad] (format 2: heading optional)."""
EVENTS = ("", "kidnap", "outage")
"""What the ``event`` column of ``frames.csv`` may say (azgym.bench.suites.Case.event)."""
QUALITY_PREFIX = "quality_"
"""A ``detections.csv`` column named ``quality_NAME`` is a quality column."""
TURNS = ("steer", "yaw_rate")
"""An odometry's turn columns (format 2): exactly one, the steering angle or the turn rate."""
ACCELERATIONS = ("ax", "ay")
"""An IMU's acceleration columns (format 2: both or neither)."""
_TABLES = {
    "frames": (("frame", "time"), (*TRUTH, "sequence", "event")),
    "detections": (("frame", "id", "azimuth"), ("label",)),
    "odometry": (("time", "speed"), TURNS),
    "imu": (("time", "yaw_rate"), (*ACCELERATIONS, "heading")),
}
"""Each table's required and optional columns (format 2)."""
_FORMAT_1 = {
    "odometry": (("time", "speed", "steer"), ()),
    "imu": (("time", "yaw_rate", "ax", "ay"), ("heading",)),
}
"""Where format 1 differs."""


@dataclass(frozen=True, eq=False)
class Log:
    """A checked log: the manifest, the map, every frame's data and the motion samples.

    Attributes:
        folder: Where it was read from.
        manifest: Its ``log.toml``.
        map_name: The cases' ``scenario``: a shipped scenario's name, or the dataset's.
        beacons: The beacon map.
        shipped_map: Whether the map is a shipped scenario (the figures draw its floor plan).
        frames: ``frames.csv``'s columns: frame (its number), time (settled:
            :mod:`azgym.logs.clocks`), x/y/heading (if given), sequence, event.
        detections: ``detections.csv``'s: frame (its row in ``frames``), id, azimuth,
            quality (D, Q), label (−1 without labels) and labelled (whether it has labels).
        quality_names: The quality columns' names, without the prefix.
        odometry: ``odometry.csv``'s columns (time, speed, and steer or yaw_rate; settled), or
            None.
        imu: ``imu.csv``'s columns (time, yaw_rate, ax/ay if given, heading NaN where empty;
            settled), or None.
        sha256: The digest of the files read (:func:`log_digest`).
        notes: What the reader changed (:mod:`azgym.logs.clocks`), each naming its file, lines
            and count.
    """

    folder: Path
    manifest: Manifest
    map_name: str
    beacons: BeaconMap
    shipped_map: bool
    frames: Columns
    detections: Columns
    quality_names: tuple[str, ...]
    odometry: Columns | None
    imu: Columns | None
    sha256: str
    notes: tuple[str, ...] = ()

    @property
    def driven(self) -> bool:
        """Whether it has motion samples (odometry or IMU): its sequences are driven tracks."""
        return self.odometry is not None or self.imu is not None

    @property
    def has_truth(self) -> bool:
        """Whether every frame has its true position."""
        return "x" in self.frames.values

    @property
    def has_heading(self) -> bool:
        """Whether every frame has its true heading too (else the truth is position-only)."""
        return "heading" in self.frames.values

    def pose(self, k: int) -> Pose | None:
        """The true pose of frame row ``k`` (heading NaN: position-only truth), or None."""
        if not self.has_truth:
            return None
        x, y, heading = (float(self.frames[key][k]) if key in self.frames.values else math.nan
                         for key in TRUTH)
        return x, y, heading


def shipped_logs() -> dict[str, Path]:
    """Name → folder of every log shipped with azgym (``envs/logs/``)."""
    folder = Path(str(resources.files(SCENARIO_PACKAGE).joinpath("logs")))
    return {path.name: path for path in sorted(folder.iterdir()) if (path / MANIFEST).is_file()} \
        if folder.is_dir() else {}


def read_log(folder: str | Path) -> Log:
    """Read and check a log folder (docs/logs.md), or a shipped log by name.

    Raises:
        LogError: Listing every problem found (up to a cap), each with its file, line and column.
        DependencyNotInstalled: A table is Parquet and pyarrow is missing.
    """
    folder = Path(folder)
    if not folder.is_dir() and str(folder) in shipped_logs():
        folder = shipped_logs()[str(folder)]
    if not folder.is_dir():
        raise LogError(str(folder), ["no such folder (a log is a folder with log.toml)"])
    problems = Problems(str(folder))
    manifest = read_manifest(folder, problems)
    problems.check()
    assert manifest is not None
    map_name, beacons, shipped, extent = read_map(folder, manifest, problems)
    used = [folder / MANIFEST] + _map_files(folder, manifest)
    shipped_bytes = {f"map:{map_name}": map_bytes(beacons)} if shipped and beacons else {}
    tables: dict[str, Table | None] = {}
    for name in _TABLES:
        before = problems.total
        path = find_table(folder, name, problems)
        if path is None and name in ("frames", "detections") and problems.total == before:
            problems.add(f"{name}.csv", "missing (docs/logs.md)")
        tables[name] = None if path is None else read_table(path, problems)
        used += [] if path is None else [path]
    frames = _frames(tables["frames"], manifest, problems)
    detections, quality = _detections(tables["detections"], frames, problems)
    motion = {name: _samples(tables[name], manifest, problems) for name in ("odometry", "imu")}
    check_plausible(tables, {"frames": frames, "detections": detections, **motion}, beacons,
                    extent, manifest.camera_rate_hz, problems)
    problems.check()
    assert beacons is not None and frames is not None and detections is not None
    notes: list[str] = []
    frames, motion = _settled(tables, frames, motion, notes, problems)
    problems.check()
    return Log(folder, manifest, map_name, beacons, shipped, frames, detections, quality,
               motion["odometry"], motion["imu"], log_digest(used, shipped_bytes), tuple(notes))


def _settled(tables: dict[str, Table | None], frames: Columns,
             motion: dict[str, Columns | None], notes: list[str], problems: Problems
             ) -> tuple[Columns, dict[str, Columns | None]]:
    """Frames and motion with their clocks settled (:mod:`azgym.logs.clocks`), with notes."""
    assert tables["frames"] is not None
    time = settle_frames(tables["frames"], frames["time"], notes)
    settled: dict[str, Columns | None] = {}
    for name, columns in motion.items():
        table = tables[name]
        settled[name] = None if columns is None or table is None else Columns(settle_stream(
            table, columns.values, time, frames["sequence"], notes, problems))
    return Columns(frames.values | {"time": time}), settled


def _map_files(folder: Path, manifest: Manifest) -> list[Path]:
    """The map's file in the folder, if the map is one (a shipped scenario is none)."""
    name = manifest.beacons or manifest.scenario or ""
    path = folder / Path(name).name
    return [path] if name and path.is_file() else []


def map_bytes(beacons: BeaconMap) -> bytes:
    """A beacon map as canonical text: ``id,x,y,z,width`` rows, floats by ``repr``, in map order.

    What a shipped scenario contributes to a log's digest: its beacons, which score the frames
    (a change to its racks or routes leaves the dataset the same).
    """
    rows = (",".join([str(int(i)), *(repr(float(v)) for v in (*xyz, w))])
            for i, xyz, w in zip(beacons.ids, beacons.xyz, beacons.width, strict=True))
    return ("id,x,y,z,width\n" + "".join(f"{row}\n" for row in rows)).encode()


def log_digest(paths: list[Path], named: dict[str, bytes] | None = None) -> str:
    """SHA-256 of a log's files, and of a shipped map: each one's name and bytes, by name.

    The dataset's identity: the same name and digest are the same frames, truth and map. A
    shipped scenario's map enters as ``named`` (``map:NAME`` → :func:`map_bytes`), so that a
    changed shipped map changes the digest of the logs that use it.
    """
    blobs = {path.name: path.read_bytes() for path in paths} | dict(named or {})
    digest = hashlib.sha256()
    for name in sorted(blobs):
        digest.update(f"{name}\0{len(blobs[name])}\0".encode() + blobs[name])
    return digest.hexdigest()


def _columns(name: str, log_format: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """A table's required and optional columns in a log format."""
    return _FORMAT_1[name] if log_format == 1 and name in _FORMAT_1 else _TABLES[name]


def _checked(table: Table | None, name: str, problems: Problems, prefix: str = "",
             log_format: int = 2) -> bool:
    required, optional = _columns(name, log_format)
    return table is not None and check_columns(table, required, optional, problems, prefix)


def _increasing(table: Table, column: str, values: np.ndarray, problems: Problems,
                good: np.ndarray | None = None, strictly: bool = True) -> None:
    """Report each value smaller than the one before it (or equal, ``strictly``).

    A row whose cell did not parse (NaN, or not ``good``: already reported) is compared with
    neither neighbour, so that one bad cell is one problem.
    """
    ok = np.isfinite(values) if good is None else good
    wrong = values[1:] <= values[:-1] if strictly else values[1:] < values[:-1]
    than, rule = ("not greater than", "must increase strictly") if strictly else \
        ("less than", "a clock never runs back")
    for k in np.flatnonzero(wrong & ok[1:] & ok[:-1]) + 1:
        table.report(problems, f"{values[k].item()!r} is {than} the row before's "
                               f"{values[k - 1].item()!r} ({rule})", int(k), column)


def _frames(table: Table | None, manifest: Manifest, problems: Problems) -> Columns | None:
    """``frames.csv``: numbers increasing, times never decreasing, the truth whole or absent."""
    if not _checked(table, "frames", problems):
        return None
    assert table is not None
    if not len(table):
        problems.add(table.file, "no frames: a log holds at least one")
    number, good = integers(table, "frame", problems)
    _increasing(table, "frame", number, problems, good)
    values: dict[str, Any] = {"frame": number, "time": floats(table, "time", problems)}
    _increasing(table, "time", values["time"], problems, strictly=False)
    if (problem := _truth_problem([key for key in TRUTH if table.has(key)], manifest.format)):
        problems.add(table.file, problem)
    else:
        values |= {key: floats(table, key, problems) for key in TRUTH if table.has(key)}
    sequence = table.cells("sequence") if table.has("sequence") else \
        [manifest.sequence] * len(table)
    _check_sequences(table, sequence, problems)
    event = table.cells("event") if table.has("event") else [""] * len(table)
    for k, text in enumerate(event):
        if text not in EVENTS:
            table.report(problems, f"{shown(text)} is no event (known: kidnap, outage, or "
                                   "empty)", k, "event")
    return Columns(values | {"sequence": sequence, "event": event})


def _truth_problem(given: list[str], log_format: int) -> str | None:
    """What is wrong with the truth columns given: x and y (and a heading) or none."""
    needed = list(TRUTH) if log_format == 1 else ["x", "y"]
    if not given or all(key in given for key in needed):
        return None
    missing = ", ".join(key for key in needed if key not in given)
    rule = "give x, y and heading, or none of them" if log_format == 1 else \
        "give x and y, and optionally heading, or none of them"
    return f"truth partly present: columns {', '.join(given)} without {missing} ({rule})"


def _check_sequences(table: Table, sequence: list[str], problems: Problems) -> None:
    """Each sequence named, and its frames together (a sequence cannot come back)."""
    ended: set[str] = set()
    for k, name in enumerate(sequence):
        if not name.strip():
            table.report(problems, "empty: each frame names its sequence", k, "sequence")
        elif k and name != sequence[k - 1]:
            ended.add(sequence[k - 1])
            if name in ended:
                table.report(problems, f"sequence {shown(name)} resumes after another; a "
                                       "sequence's frames are consecutive", k, "sequence")


def _detections(table: Table | None, frames: Columns | None, problems: Problems
                ) -> tuple[Columns | None, tuple[str, ...]]:
    """``detections.csv``: each in a listed frame, in frame order, azimuths in [−π, π]."""
    if not _checked(table, "detections", problems, QUALITY_PREFIX):
        return None, ()
    assert table is not None
    quality_names = tuple(c for c in table.header if c.startswith(QUALITY_PREFIX))
    number, good = integers(table, "frame", problems)
    row_of = {} if frames is None else {int(n): k for k, n in enumerate(frames["frame"])}
    row = np.array([row_of.get(int(n), -1) for n in number], dtype=np.int64)
    for k in np.flatnonzero(good & (row < 0)):
        table.report(problems, f"frame {number[k]} is not in frames.csv", int(k), "frame")
    for k in np.flatnonzero((row[1:] < row[:-1]) & (row[1:] >= 0)) + 1:
        table.report(problems, f"frame {number[k]} after frame {number[k - 1]}: detections are "
                               "listed in frame order", int(k), "frame")
    ids, _ = integers(table, "id", problems)
    azimuth = floats(table, "azimuth", problems)
    for k in np.flatnonzero(np.abs(azimuth) > math.pi):
        table.report(problems, f"{float(azimuth[k])!r} is outside [-π, π] (radians, "
                               "counter-clockwise from the camera's x-axis; degrees?)", int(k),
                     "azimuth")
    quality = np.column_stack([floats(table, name, problems) for name in quality_names]) \
        if quality_names else np.zeros((len(table), 0))
    label = np.full(len(table), -1, dtype=np.int64)
    if table.has("label"):
        for index, text in enumerate(table.cells("label")):
            if text not in LABEL_NAMES:
                table.report(problems, f"{shown(text)} is no label (known: "
                                       f"{', '.join(LABEL_NAMES)})", index, "label")
            else:
                label[index] = LABEL_NAMES.index(text)
    _check_duplicates(table, row, ids, azimuth, problems)
    names = tuple(name.removeprefix(QUALITY_PREFIX) for name in quality_names)
    return Columns({"frame": row, "id": ids, "azimuth": azimuth, "quality": quality,
                    "label": label, "labelled": table.has("label")}), names


def _check_duplicates(table: Table, row: np.ndarray, ids: np.ndarray, azimuth: np.ndarray,
                      problems: Problems) -> None:
    """The very same detection (frame, id, azimuth) twice is a logging bug."""
    seen: dict[tuple[int, int, float], int] = {}
    for k in range(len(table)):
        key = (int(row[k]), int(ids[k]), float(azimuth[k]))
        if key in seen and not math.isnan(key[2]):
            table.report(problems, f"the same detection (id {ids[k]}, azimuth {key[2]!r}) "
                                   f"as {table.unit} {table.lines[seen[key]]}: a frame lists "
                                   "each detection once", k, "id")
        seen.setdefault(key, k)


def _samples(table: Table | None, manifest: Manifest, problems: Problems) -> Columns | None:
    """``odometry.csv`` or ``imu.csv``: finite samples, never decreasing in time."""
    if table is None:
        return None
    name = Path(table.file).stem
    if not _checked(table, name, problems, log_format=manifest.format):
        return None
    required, optional = _columns(name, manifest.format)
    if name == "odometry" and manifest.format >= 2 and \
            not _odometry_turns(table, manifest, problems):
        return None
    if name == "imu" and table.has(ACCELERATIONS[0]) != table.has(ACCELERATIONS[1]):
        given, missing = sorted(ACCELERATIONS, key=lambda key: not table.has(key))
        problems.add(table.file, f"column {given} without {missing} (give both accelerations "
                                 "or neither)")
        return None
    values = {key: floats(table, key, problems, empty_ok=key == "heading")
              for key in required + optional if table.has(key)}
    _increasing(table, "time", values["time"], problems, strictly=False)
    return Columns(values)


def _odometry_turns(table: Table, manifest: Manifest, problems: Problems) -> bool:
    """Exactly one turn column, and not a steering angle on a differential drive."""
    given = [key for key in TURNS if table.has(key)]
    if len(given) != 1:
        which = "both columns steer and" if given else "neither column steer nor"
        problems.add(table.file, f"{which} yaw_rate: odometry reports exactly one (steer: a "
                                 "steered vehicle's steering angle; yaw_rate: its turn rate)")
        return False
    kind = manifest.profile.vehicle.kind
    if given == ["steer"] and kind == DIFFERENTIAL_DRIVE:
        problems.add(table.file, f"column steer, but {MANIFEST} says vehicle.kind = "
                                 f"{kind!r}: a differential drive has no steering angle "
                                 "(write its turn rate as yaw_rate)", column="steer")
        return False
    return True

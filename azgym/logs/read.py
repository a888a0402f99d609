"""Read a log folder, checking every file, and hold it as frames of measurements with their truth.

:func:`read_log` checks the whole log before refusing it (:class:`~azgym.logs.problems.LogError`
lists every problem with its file, line and column). The rules (docs/logs.md): frames numbered
strictly increasing and timed never decreasing (one clock for the whole log); each detection in
a listed frame, the detections in frame order; azimuths in [−π, π]; the truth given on every
frame or not at all (x and y, and in format 2 the heading optionally); motion samples never
decreasing in time; a truth file (``[truth] file``, TUM) instead of truth columns, covering every
frame. Ids missing from the map are kept (a localizer ignores them), and so is the
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

from azgym.core import BeaconMap, Pose
from azgym.logs.clocks import settle_frames, settle_stream
from azgym.logs.contents import (
    QUALITY_PREFIX,
    TABLES,
    TRUTH,
    detections_columns,
    frames_columns,
    samples_columns,
    tum_truth,
)
from azgym.logs.files import log_file, read_limited
from azgym.logs.manifest import MANIFEST, Manifest, read_manifest, read_map
from azgym.logs.plausible import check_plausible
from azgym.logs.problems import LogChanged, LogError, Problems, shown
from azgym.logs.tables import (
    Columns,
    Table,
    find_table,
    parse_table,
)
from azgym.site.load import SCENARIO_PACKAGE

__all__ = ["QUALITY_PREFIX", "Columns", "Log", "log_digest", "map_bytes", "read_log",
           "shipped_logs"]

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


def read_log(folder: str | Path, sha256: str | None = None) -> Log:
    """Read and check a log folder (docs/logs.md), or a shipped log by name.

    Args:
        folder: The log's folder, or a shipped log's name.
        sha256: The digest its files must have (:func:`log_digest`; a dataset entry's), checked
            on the bytes read before any table is parsed.

    Raises:
        LogError: Listing every problem found (up to a cap), each with its file, line and column.
        LogChanged: The files' digest is not ``sha256``.
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
    data = _table_bytes(folder, problems)
    truth = _truth_bytes(folder, manifest, problems)
    named = {path.name: blob for path, blob in data.values()} | \
        ({} if truth is None or manifest.truth_file is None
         else {manifest.truth_file.name: truth})
    if shipped and beacons:
        named[f"map:{map_name}"] = map_bytes(beacons)
    digest = "" if problems else log_digest([folder / MANIFEST, *_map_files(folder, manifest)],
                                            named)
    del named
    if sha256 is not None:
        problems.check()  # a log that cannot be hashed is refused before any table is parsed
        if digest != sha256:
            raise LogChanged(str(folder), digest, sha256)
    tables: dict[str, Table | None] = dict.fromkeys(TABLES)
    for name in list(data):
        path, blob = data.pop(name)
        tables[name] = parse_table(path.name, blob, problems)
    frames = frames_columns(tables["frames"], manifest, problems)
    if manifest.truth_file is not None and truth is not None:
        frames = tum_truth(frames, manifest.truth_file, truth, extent, problems)
    detections, quality = detections_columns(tables["detections"], frames, problems)
    motion = {name: samples_columns(tables[name], manifest, problems)
              for name in ("odometry", "imu")}
    check_plausible(tables, {"frames": frames, "detections": detections, **motion}, beacons,
                    extent, manifest.camera_rate_hz, problems)
    problems.check()
    assert beacons is not None and frames is not None and detections is not None
    notes: list[str] = []
    frames, motion = _settled(tables, frames, motion, notes, problems)
    problems.check()
    return Log(folder, manifest, map_name, beacons, shipped, frames, detections, quality,
               motion["odometry"], motion["imu"], digest, tuple(notes))


def _table_bytes(folder: Path, problems: Problems) -> dict[str, tuple[Path, bytes]]:
    """Each table's file and bytes (read up to the byte limit), by table name."""
    data = {}
    for name in TABLES:
        before = problems.total
        path = find_table(folder, name, problems)
        if path is None and name in ("frames", "detections") and problems.total == before:
            problems.add(f"{name}.csv", "missing (docs/logs.md)")
        blob = None if path is None else read_limited(path, problems)
        if path is not None and blob is not None:
            data[name] = (path, blob)
    return data


def _truth_bytes(folder: Path, manifest: Manifest, problems: Problems) -> bytes | None:
    """The truth file's bytes (read up to the byte limit), if the manifest names one."""
    if manifest.truth_file is None:
        return None
    before = problems.total
    path = log_file(folder, manifest.truth_file.name, problems, report_as=MANIFEST) \
        if Path(manifest.truth_file.name).name == manifest.truth_file.name else None
    if path is None:
        if problems.total == before:
            problems.add(MANIFEST, f"truth.file: {shown(manifest.truth_file.name)} is not a "
                                   "file in the log's folder")
        return None
    return read_limited(path, problems)


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

"""A log's manifest (``log.toml``) and its beacon map: what the log is, and where its map is.

The manifest says which format the log is in (:data:`FORMATS`), names and describes the
dataset, says whether it is simulated, describes the camera and where the truth came from, and
names the map: a shipped scenario, a scenario file in the log's folder, or ``beacons.csv``. From
format 2 on it may also state the vehicle, the camera's azimuth noise and view, and the motion
sensors' errors (``[vehicle]``, ``[sensor]``, ``[motion]``: a profile, :mod:`azgym.profile`),
and take the truth from a TUM file in the folder (``truth.file``, with ``truth.heading`` saying
whether its orientations are the heading, and ``truth.max_gap``: :mod:`azgym.logs.tum`).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from azgym.core import BeaconMap
from azgym.errors import AzgymError, unknown_name
from azgym.fields import Fields, Number
from azgym.logs.files import log_file
from azgym.logs.plausible import Extent
from azgym.logs.problems import Problems, shown
from azgym.logs.tables import check_columns, floats, integers, read_table
from azgym.logs.truth import MAX_GAP
from azgym.profile import SECTIONS, Profile, parse_profile
from azgym.site.reader import name_problem

__all__ = ["FORMATS", "FORMAT_VERSION", "MANIFEST", "MAX_NAME", "TRUTH_SUFFIXES", "Manifest",
           "TruthFile", "read_beacons", "read_manifest", "read_map"]

FORMAT_VERSION = 2
"""The log format this azgym writes (``format`` in ``log.toml``)."""
FORMATS = (1, 2)
"""The log formats this azgym reads: 2 added the profile sections, odometry with a turn rate,
an IMU without accelerations and truth without a heading (docs/logs.md)."""
MANIFEST = "log.toml"
MAX_MANIFEST_BYTES = 64 * 1024
"""The largest manifest read [bytes]."""
MAX_NAME = 64
"""The longest name a dataset may have [characters]; otherwise a plain file name, as a
scenario's (:func:`azgym.site.reader.name_problem`), since it names the log's folder."""
_CAMERA_RATE = Number(0.0, 1e4, low_open=True, high_open=True, unit="Hz")
"""The rule for ``camera.rate_hz``: frames per second, more than none and fewer than 10 000."""
_KEYS = {"": {"format", "name", "description", "simulated", "sequence", "camera", "map",
              "truth"},
         "camera": {"rate_hz", "description"}, "map": {"scenario", "beacons"},
         "truth": {"source"}}
_TRUTH_FILE_KEYS = {"file", "heading", "max_gap"}
"""The truth's keys from format 2 on: its TUM file."""
TRUTH_SUFFIXES = (".tum", ".txt")
"""What a truth file's name ends with (never a table's, the map's or the manifest's name)."""
_MAX_GAP = Number(0.0, 60.0, low_open=True, unit="s")
"""The rule for ``truth.max_gap``: the longest time between truth samples interpolated across."""


@dataclass(frozen=True)
class TruthFile:
    """The truth as a TUM file in the log's folder (``[truth] file``, format 2).

    Attributes:
        name: The file's name.
        heading: Whether its orientations are the true heading (else only its positions are
            truth: a prism, one marker).
        max_gap: The longest time between two of its samples a frame's truth is interpolated
            across [s] (:func:`azgym.logs.truth.truth_at`).
    """

    name: str
    heading: bool
    max_gap: float = MAX_GAP


@dataclass(frozen=True)
class Manifest:
    """What ``log.toml`` says.

    Attributes:
        format: The log format's version.
        name: The dataset's name.
        description: One line about it.
        simulated: Whether its frames were simulated (not a real camera's).
        sequence: The name of its frames' sequence where ``frames.csv`` has no ``sequence``
            column (default: the dataset's name).
        camera: The camera, in words.
        camera_rate_hz: The camera's nominal frame rate [Hz], if given.
        scenario: The map as a shipped scenario's name or a ``.toml`` file in the folder.
        beacons: The map as a table file name in the folder (``beacons.csv``).
        truth: Where the true poses came from, in words.
        profile: The vehicle, sensor and motion sections (format 2; empty in format 1).
        truth_file: The TUM file the truth is read from (format 2), or None.
    """

    format: int
    name: str
    description: str
    simulated: bool
    sequence: str
    camera: str = ""
    camera_rate_hz: float | None = None
    scenario: str | None = None
    beacons: str | None = None
    truth: str = ""
    profile: Profile = Profile()
    truth_file: TruthFile | None = None


def read_manifest(folder: Path, problems: Problems) -> Manifest | None:
    """The manifest, or None (with the problems recorded) when it is unusable."""
    path = folder / MANIFEST
    if not path.is_file():
        problems.add(MANIFEST, "missing: a log folder holds log.toml (docs/logs.md)")
        return None
    with path.open("rb") as stream:
        raw = stream.read(MAX_MANIFEST_BYTES + 1)
    if len(raw) > MAX_MANIFEST_BYTES:
        problems.add(MANIFEST, f"too large: a manifest has at most {MAX_MANIFEST_BYTES} bytes")
        return None
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        problems.add(MANIFEST, f"not UTF-8 text: byte 0x{raw[exc.start]:02x} at offset "
                               f"{exc.start}")
        return None
    except (tomllib.TOMLDecodeError, RecursionError) as exc:
        problems.add(MANIFEST, f"not valid TOML: {exc}")
        return None
    return _fields(data, problems)


def _fields(data: dict[str, Any], problems: Problems) -> Manifest | None:
    """The manifest's fields, each checked."""
    given = data.get("format", "(nothing)")
    if type(given) is not int or given not in FORMATS:
        whole = "" if type(given) is int else " (the format is a whole number)"
        readable = " and ".join(map(str, FORMATS))
        problems.add(MANIFEST, f"format: this azgym reads log formats {readable}, the log "
                               f"says {shown(given)}{whole}")
        return None
    known = _KEYS | ({"": _KEYS[""] | set(SECTIONS), "truth": _KEYS["truth"] | _TRUTH_FILE_KEYS}
                     if given >= 2 else {})
    read = Fields(report=lambda problem: problems.add(MANIFEST, problem))
    for table, keys in known.items():
        section = data if not table else data.get(table, {})
        if not isinstance(section, dict):
            problems.add(MANIFEST, f"{table}: must be a table ([{table}])")
            continue
        read.keys(section, keys, table)
    camera, where, truth = (_section(data, key) for key in ("camera", "map", "truth"))
    name = _text(data, "name", problems, required=True)
    if name and (problem := name_problem(name, MAX_NAME)):
        problems.add(MANIFEST, f"name: {problem}")
    simulated = data.get("simulated")
    if not isinstance(simulated, bool):
        problems.add(MANIFEST, "simulated: must be true or false (is the data from a real "
                               "camera?)")
    rate = camera.get("rate_hz")
    rate_ok = rate is None or read.check(rate, "camera.rate_hz", _CAMERA_RATE)
    maps = [key for key in ("scenario", "beacons") if key in where]
    if len(maps) != 1:
        problems.add(MANIFEST, "map: give exactly one of map.scenario (a shipped scenario or a "
                               ".toml file in the log's folder) and map.beacons (beacons.csv)")
    profile = parse_profile(data, lambda problem: problems.add(MANIFEST, problem)) \
        if given >= 2 else Profile()
    return Manifest(
        format=given, name=name, description=_text(data, "description", problems, True),
        simulated=bool(simulated), sequence=_text(data, "sequence", problems) or name,
        camera=_text(camera, "description", problems, where="camera."),
        camera_rate_hz=float(rate) if rate is not None and rate_ok else None,
        scenario=_text(where, "scenario", problems, where="map.") or None,
        beacons=_text(where, "beacons", problems, where="map.") or None,
        truth=_text(truth, "source", problems, where="truth."), profile=profile,
        truth_file=_truth_file(truth, read, problems) if given >= 2 else None)


def _truth_file(truth: dict[str, Any], read: Fields, problems: Problems) -> TruthFile | None:
    """``[truth] file``, ``heading`` and ``max_gap``: the truth's TUM file, if one is named."""
    name = _text(truth, "file", problems, where="truth.")
    if not name:
        for key in sorted(_TRUTH_FILE_KEYS & set(truth)):
            if key != "file":
                problems.add(MANIFEST, f"truth.{key}: only with truth.file (a TUM file)")
        return None
    if not name.endswith(TRUTH_SUFFIXES):
        problems.add(MANIFEST, f"truth.file: {shown(name)} must end with "
                               f"{' or '.join(TRUTH_SUFFIXES)} (a TUM file)")
    heading = truth.get("heading")
    if not isinstance(heading, bool):
        problems.add(MANIFEST, "truth.heading: must be true or false, and is required with "
                               "truth.file (are the file's orientations the true heading?)")
    gap = truth.get("max_gap", MAX_GAP)
    gap_ok = read.check(gap, "truth.max_gap", _MAX_GAP)
    return TruthFile(name, bool(heading), float(gap) if gap_ok else MAX_GAP)


def _section(data: dict[str, Any], key: str) -> dict[str, Any]:
    """The table ``key`` ({} when it is absent or no table: reported with the fields)."""
    value = data.get(key)
    return value if isinstance(value, dict) else {}


def _text(data: dict[str, Any], key: str, problems: Problems, required: bool = False,
          where: str = "") -> str:
    """A text field ("" when absent and not required)."""
    value = data.get(key)
    if value is None and not required:
        return ""
    if not isinstance(value, str) or (required and not value.strip()):
        problems.add(MANIFEST, f"{where}{key}: must be text"
                               f"{', and is required' if required else ''}")
        return ""
    return value


def read_map(folder: Path, manifest: Manifest, problems: Problems
             ) -> tuple[str, BeaconMap | None, bool, Extent | None]:
    """The map's name (the cases' ``scenario``), beacons, whether shipped, and where truth may lie.

    A shipped scenario keeps its name (the figures draw its floor plan); any other map is
    named after the dataset.
    """
    from azgym.site import list_scenarios, load_scenario

    if manifest.scenario is not None:
        shipped = manifest.scenario in list_scenarios()
        if not shipped and not manifest.scenario.endswith(".toml") and \
                not (folder / manifest.scenario).exists():
            unknown = unknown_name("scenario", manifest.scenario, list_scenarios())
            problems.add(MANIFEST, f"map.scenario: {unknown} (or a .toml file in the log's "
                                   "folder)")
            return manifest.name, None, False, None
        target = manifest.scenario if shipped else _inside(folder, manifest.scenario, problems)
        if target is None:
            return manifest.name, None, False, None
        try:
            scenario = load_scenario(target)
        except AzgymError as exc:
            problems.add(MANIFEST, f"map.scenario: {exc}")
            return manifest.name, None, False, None
        return (manifest.scenario if shipped else manifest.name), scenario.beacons, shipped, \
            Extent.of_scenario(scenario.bounds)
    path = None if manifest.beacons is None else _inside(folder, manifest.beacons, problems)
    beacons = None if path is None else _beacon_table(path, problems)
    return manifest.name, beacons, False, None if beacons is None else \
        Extent.of_beacons(beacons)


def _inside(folder: Path, name: str, problems: Problems) -> Path | None:
    """A file named in the manifest: a plain file name in the log's folder."""
    before = problems.total
    path = log_file(folder, name, problems, report_as=MANIFEST) \
        if Path(name).name == name else None
    if path is None and problems.total == before:
        problems.add(MANIFEST, f"map: {shown(name)} is not a file in the log's folder (give a "
                               "file name in it, or a shipped scenario's name)")
    return path


def read_beacons(path: Path) -> BeaconMap:
    """A beacon table (``beacons.csv``'s form, docs/logs.md) read on its own, checked.

    Raises:
        LogError: Every problem of the table, with its line and column.
    """
    problems = Problems(str(path.parent))
    beacons = _beacon_table(path, problems)
    problems.check()
    assert beacons is not None  # no problem was found, so the table was read
    return beacons


def _beacon_table(path: Path, problems: Problems) -> BeaconMap | None:
    """``beacons.csv``: id, x, y and optionally z (default 0) and width (default 0.03) [m]."""
    before = problems.total
    table = read_table(path, problems)
    if table is None or not check_columns(table, ("id", "x", "y"), ("z", "width"), problems):
        return None
    ids, _ = integers(table, "id", problems)
    columns = [floats(table, key, problems) if table.has(key) else np.full(len(table), fill)
               for key, fill in (("x", 0.0), ("y", 0.0), ("z", 0.0), ("width", 0.03))]
    if problems.total > before:
        return None
    try:
        return BeaconMap(ids, np.column_stack(columns[:3]), columns[3])
    except AzgymError as exc:
        problems.add(table.file, str(exc))
        return None

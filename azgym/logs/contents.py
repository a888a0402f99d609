"""A log's tables read into columns, each rule of docs/logs.md checked and every problem named.

``frames.csv``: frames numbered strictly increasing and timed never decreasing, the truth on
every frame or not at all, known events, each sequence in one run; ``detections.csv``: each
detection in a listed frame, in frame order, azimuths in [−π, π], known labels, no detection
logged twice; ``odometry.csv`` and ``imu.csv``: samples never decreasing in time, exactly one turn
column for the odometry, as the vehicle's kind reads it; a truth file (``[truth] file``, TUM:
:func:`tum_truth`) instead of truth columns, its samples within the map's extent and covering
every frame. Each problem goes to the log's :class:`~azgym.logs.problems.Problems` with its
file, line and column.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from azgym.errors import InvalidInputError
from azgym.logs.manifest import MANIFEST, Manifest, TruthFile
from azgym.logs.plausible import Extent
from azgym.logs.problems import Problems, shown
from azgym.logs.tables import Columns, Table, check_columns, floats, integers
from azgym.logs.truth import truth_at
from azgym.logs.tum import TumTrajectory, parse_tum
from azgym.profile import DIFFERENTIAL_DRIVE
from azgym.sensing.labels import LABEL_NAMES

__all__ = ["ACCELERATIONS", "EVENTS", "QUALITY_PREFIX", "TABLES", "TRUTH", "TURNS",
           "detections_columns", "frames_columns", "samples_columns", "tum_truth"]

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
TABLES = {
    "frames": (("frame", "time"), (*TRUTH, "sequence", "event")),
    "detections": (("frame", "id", "azimuth"), ("label",)),
    "odometry": (("time", "speed"), TURNS),
    "imu": (("time", "yaw_rate"), (*ACCELERATIONS, "heading")),
}
"""Each table's required and optional columns (format 2), by table name."""
_FORMAT_1 = {
    "odometry": (("time", "speed", "steer"), ()),
    "imu": (("time", "yaw_rate", "ax", "ay"), ("heading",)),
}
"""Where format 1 differs."""




def _columns(name: str, log_format: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """A table's required and optional columns in a log format."""
    return _FORMAT_1[name] if log_format == 1 and name in _FORMAT_1 else TABLES[name]


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


def frames_columns(table: Table | None, manifest: Manifest, problems: Problems) -> Columns | None:
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


def detections_columns(table: Table | None, frames: Columns | None, problems: Problems
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


def samples_columns(table: Table | None, manifest: Manifest, problems: Problems) -> Columns | None:
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


def tum_truth(frames: Columns | None, truth: TruthFile, data: bytes, extent: Extent | None,
              problems: Problems) -> Columns | None:
    """The frames with their truth from a TUM file (``[truth] file``), put onto their times.

    The file's poses (:func:`~azgym.logs.tum.parse_tum`; the heading only with
    ``truth.heading``) must lie within the map's extent, and cover every frame's time
    (:func:`~azgym.logs.truth.truth_at`: interpolated between the samples around it, within
    ``truth.max_gap``, never extrapolated); ``frames.csv`` then has no truth columns. The
    frames' times are as ``frames.csv`` writes them (before a repeated time is moved by the
    reader). When the truth cannot be had (a problem recorded), the frames as they are.
    """
    if frames is None:
        return None
    if given := [key for key in TRUTH if key in frames.values]:
        problems.add(MANIFEST, f"truth.file: {shown(truth.name)}, but frames.csv has truth "
                               f"columns too ({', '.join(given)}): give the truth once")
        return frames
    samples = parse_tum(truth.name, data, problems, truth.heading)
    if samples is None or not _within(samples, truth.name, extent, problems):
        return frames
    try:
        x, y, heading = truth_at(frames["time"], samples.time, samples.x, samples.y,
                                 samples.heading, source=truth.name, max_gap=truth.max_gap,
                                 numbers=frames["frame"])
    except InvalidInputError as exc:
        problems.add(truth.name, str(exc).removeprefix(f"{truth.name}: "))
        return frames
    return Columns(frames.values | {"x": x, "y": y} |
                   ({} if heading is None else {"heading": heading}))


def _within(samples: TumTrajectory, file: str, extent: Extent | None, problems: Problems
            ) -> bool:
    """Whether a truth file's positions lie within the map's extent (else the first is named).

    The bound of :mod:`azgym.logs.plausible`'s check of a truth column, on the file's own
    lines: a frame's truth, interpolated between samples within it, is within it too.
    """
    if extent is None:
        return True
    x0, y0, x1, y1 = extent.box
    x, y = samples.x, samples.y
    outside_x, outside_y = extent.outside(x, y)
    outside = np.flatnonzero(outside_x | outside_y)
    if outside.size:
        k = int(outside[0])
        problems.add(file, f"({float(x[k])!r}, {float(y[k])!r}) is outside the map's extent "
                           f"[{x0:.6g}, {x1:.6g}] × [{y0:.6g}, {y1:.6g}] m ({extent.what}; "
                           f"millimetres?); {outside.size} pose(s) are",
                     samples.lines[k], "tx")
    return not outside.size

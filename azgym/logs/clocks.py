"""Clocks as real loggers write them: what the reader changes in a log's times, each with a note.

A real recording's clocks are untidy without being wrong: the motion loggers start before the
camera and stop after it, a millisecond clock stamps two samples alike, two frames share a time
stamp. None of that is refused; :func:`settle_frames` and :func:`settle_stream` change the data
as little as a tracker needs (frame times strictly increasing; each motion sample in one frame's
span) and describe every change in a note (``Log.notes``) naming the file, the lines and the
count:

- a frame timed like the frame before it is moved :data:`FRAME_NUDGE` s after it (frames are
  kept: each is scored);
- motion samples with one time stamp are merged into one sample, the mean of their rows (an
  IMU heading by its circular mean);
- motion samples up to :data:`MOTION_LEAD` s before a sequence's first frame belong to that
  frame (its ``motion``); earlier ones, and every one after the last frame, are trimmed.

Jitter (irregular intervals) is left as it is. A motion stream none of whose samples is kept is
refused: it is on another clock than the frames.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.logs.problems import Problems, places, seconds, shown
from azgym.logs.tables import Table

__all__ = ["MOTION_LEAD", "nudged", "settle_frames", "settle_stream"]

MOTION_LEAD = 5.0
"""How long before a sequence's first frame motion samples are kept [s]. Motion loggers are
started before the camera (a second before it in the recording this was set on, a few seconds
for a camera driver that opens the device first); the first frame's motion then holds what the
vehicle did just before the start pose's time: enough for a tracker to know the latest speed
and turn rate when it starts, while samples from minutes before (a logger left running between
runs) describe another drive and are trimmed."""
FRAME_NUDGE = 1e-6
"""How far after the frame before it a frame of the same time stamp is moved [s]: far below
any camera's frame interval (1 ms at 1000 Hz), far above a float's resolution at an epoch time
(0.24 µs at 1.2e9 s); where that resolution is coarser, one step of it."""

Columns = dict[str, np.ndarray]
"""A table's number columns, by name."""


def nudged(time: np.ndarray) -> np.ndarray:
    """Whether each settled frame was moved after the one before (:func:`settle_frames`).

    Such a frame's stamp repeated the one before: its true time is unknown, so the intervals on
    either side of it say nothing of how fast the vehicle moved.

    Args:
        time: Settled frame times, strictly increasing.
    """
    step = np.maximum(FRAME_NUDGE, np.spacing(np.abs(time[:-1])))
    return np.concatenate([[False], np.diff(time) <= 2.0 * step])


def settle_frames(table: Table, time: np.ndarray, notes: list[str]) -> np.ndarray:
    """Frame times strictly increasing: each repeated one moved just after the one before.

    Args:
        table: ``frames.csv`` (for its lines).
        time: Its times, never decreasing (a decrease is refused before).
        notes: Where the note on the frames moved goes.
    """
    settled = time.copy()
    moved: list[int] = []
    repeated = np.flatnonzero(time[1:] <= time[:-1])
    for k in range(int(repeated[0]) + 1 if repeated.size else settled.size, settled.size):
        if settled[k] <= settled[k - 1]:
            previous = float(settled[k - 1])
            settled[k] = previous + max(FRAME_NUDGE, math.ulp(previous))
            moved.append(k)
    if moved:
        first = moved[0]
        overtaken = [k for k in moved if time[k] > time[k - 1]]
        late = f"; {len(overtaken)} of them ({_where(table, overtaken)}) stamped later but " \
            "overtaken by the frames moved before them" if overtaken else ""
        notes.append(f"{table.file}: {len(moved)} frame(s) ({_where(table, moved)}) had the time "
                     f"of the frame before: each moved {FRAME_NUDGE:g} s after it (frame times "
                     f"must increase; the first from {seconds(time[first])} to "
                     f"{seconds(settled[first])}){late}")
    return settled


def settle_stream(table: Table, columns: Columns, frames: np.ndarray, sequence: list[str],
                  notes: list[str], problems: Problems) -> Columns:
    """A motion stream with one sample per time stamp, each in some frame's span.

    Args:
        table: ``odometry.csv`` or ``imu.csv`` (for its name and lines).
        columns: Its columns (``time`` never decreasing: a decrease is refused before).
        frames: The frames' settled times (:func:`settle_frames`).
        sequence: Each frame's sequence.
        notes: Where the notes on what was changed go.
        problems: Where a stream on another clock is reported.
    """
    starts = np.array([k == 0 or name != sequence[k - 1] for k, name in enumerate(sequence)])
    rows = np.arange(columns["time"].size)
    columns, rows = _merge_repeats(table, columns, rows, notes)
    time = columns["time"]
    owner = np.searchsorted(frames, time, side="left")  # the frame whose span holds it
    late = owner >= frames.size
    owner = np.minimum(owner, frames.size - 1)
    early = ~late & starts[owner] & (time < frames[owner] - MOTION_LEAD)
    for frame in np.unique(owner[early]):
        trimmed = rows[early & (owner == frame)]
        which = "the first frame" if frame == 0 else \
            f"the first frame of sequence {shown(sequence[frame])}"
        notes.append(f"{table.file}: {trimmed.size} sample(s) ({_where(table, trimmed)}) more "
                     f"than {MOTION_LEAD:g} s before {which} ({seconds(frames[frame])}) trimmed")
    if late.any():
        notes.append(f"{table.file}: {int(late.sum())} sample(s) ({_where(table, rows[late])}) "
                     f"after the last frame ({seconds(frames[-1])}) trimmed")
    kept = ~(early | late)
    if time.size and not kept.any():
        problems.add(table.file, f"none of its samples ({seconds(time[0])} to "
                                 f"{seconds(time[-1])}) lies within the frames' time "
                                 f"({seconds(frames[0])} to {seconds(frames[-1])}, and up to "
                                 f"{MOTION_LEAD:g} s before a sequence's first frame): another "
                                 "clock than the frames'?", column="time")
    return {key: values[kept] for key, values in columns.items()}


def _merge_repeats(table: Table, columns: Columns, rows: np.ndarray, notes: list[str]
                   ) -> tuple[Columns, np.ndarray]:
    """Samples of one time stamp merged into one (the mean of their rows), with a note."""
    time = columns["time"]
    repeated = np.flatnonzero(time[1:] == time[:-1]) + 1
    if not repeated.size:
        return columns, rows
    group = np.concatenate([[0], np.cumsum(time[1:] != time[:-1])])
    count = np.bincount(group)
    starts = np.flatnonzero(np.concatenate([[True], time[1:] != time[:-1]]))
    merged: Columns = {"time": time[starts]}  # the stamp itself, not a sum's rounding of it
    for key, values in columns.items():
        if key == "time":
            continue
        if key == "heading":  # an angle: the circular mean of the rows that have one
            given = np.isfinite(values)
            sin = np.bincount(group, np.where(given, np.sin(values), 0.0))
            cos = np.bincount(group, np.where(given, np.cos(values), 0.0))
            merged[key] = np.where(np.bincount(group, given) > 0, np.arctan2(sin, cos), np.nan)
        else:
            merged[key] = np.bincount(group, values) / count
    involved = np.flatnonzero(count[group] > 1)
    notes.append(f"{table.file}: {int((count > 1).sum())} time stamp(s) repeated "
                 f"({_where(table, involved)}, {involved.size} rows): the rows of each merged "
                 "into one sample, their mean")
    return merged, rows[starts]


def _where(table: Table, rows: np.ndarray | list[int]) -> str:
    """The lines (or rows) of some of a table's rows, for a note."""
    return places([table.lines[int(k)] for k in rows], table.unit)

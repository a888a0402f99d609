"""The recent frames map repair re-runs the track over: a fixed lag, bounded in time and frames.

A moved beacon among few in view is first *fitted*: its azimuths pass the gate of a track they
pull off, for as long as the pull keeps pace with them, and only then are they rejected. By the
time it is suspected (:mod:`azgym.track.repair`) the track has been dragged, and its rays,
taken from the dragged track, locate it wrongly. So :class:`~azgym.track.robust.Robust` keeps
the latest frames here: each frame's motion steps and detections, and every
:data:`SNAPSHOT_EVERY_S` seconds the filter's state before a frame (a snapshot, opaque here).
On a suspicion it goes back to the last snapshot before the suspect's stretch of sightings
began (:meth:`Lag.replayable`) and re-runs the frames since without the suspects, taking the
suspect's rays from the re-run track. The stretch begins after a gap of more than
``STREAK_GAP_S`` (2 s) without a sighting, longer than :data:`SNAPSHOT_EVERY_S`: the frames
between the snapshot and the stretch do not hold the suspect, so the re-run is the one from the
stretch's first frame. Nothing answered is changed and no frame not yet reached is used: only
the state going forward is the re-run one.

**Bounded.** The lag keeps at most :data:`LAG_S` seconds and :data:`LAG_FRAMES` frames, and
the frames re-run never outnumber the frames tracked since ``reset`` (a credit of one a frame,
capped at :data:`LAG_FRAMES`): suspicions as frequent as a hostile input can make them at most
double the tracker's work, and one re-run is at most :data:`LAG_FRAMES` frames.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Mapping
from typing import Any

from azgym.core import Measurements
from azgym.track.unicycle import Step

__all__ = ["LAG_FRAMES", "LAG_S", "SNAPSHOT_EVERY_S", "Lag", "Lagged"]

LAG_S = 30.0
"""Seconds of frames kept [s]: longer than a beacon in view drags a track before its run of
rejections makes it a suspect (the repair's runs span ``repair_after`` and gaps up to
:data:`~azgym.track.repair.STREAK_GAP_S`; its fitted stretch before them, a few seconds)."""
LAG_FRAMES = 600
"""Frames kept, at most (:data:`LAG_S` at 20 frames a second): bounds the memory and one
re-run at any frame rate."""
SNAPSHOT_EVERY_S = 1.0
"""Seconds between the snapshots of the filter's state [s] (module docstring): a snapshot every
frame cost about 3 µs a frame, 6 % of robust's time."""


Lagged = tuple[int, list[Step], float, Measurements]
"""A frame kept, as :meth:`Lag.replayable` gives it: its number since ``reset``, its motion steps,
its time [s] and its detections (every one)."""


class Lag:
    """The latest frames, for a re-run of the track (module docstring).

    Args:
        snapshot: The tracker's state now (before the first frame).
    """

    def __init__(self, snapshot: Any) -> None:
        self.frames: deque[tuple[list[Step], float, Measurements]] = deque()
        self.snapshots: dict[int, Any] = {0: snapshot}
        """The tracker's state before a frame, by the frame's number (one every
        :data:`SNAPSHOT_EVERY_S`, the next frame's included)."""
        self._first = 0
        self._due = -math.inf
        self._credit = 0

    def close(self, time: float, steps: list[Step], measurements: Measurements,
              snapshot: Callable[[], Any]) -> None:
        """Keep a frame tracked; take ``snapshot()`` for the next when one is due.

        Frames beyond :data:`LAG_FRAMES` or older than :data:`LAG_S` are dropped.
        """
        frames = self.frames
        frames.append((steps, time, measurements))
        if time >= self._due:
            self.snapshots[self._first + len(frames)] = snapshot()
            self._due = time + SNAPSHOT_EVERY_S
        if self._credit < LAG_FRAMES:
            self._credit += 1
        while len(frames) > LAG_FRAMES or time - frames[0][1] > LAG_S:
            frames.popleft()
            self.snapshots.pop(self._first, None)
            self._first += 1

    def replayable(self, runs: Mapping[int, float], gap: float) -> list[Lagged]:
        """The frames to re-run for newly suspected beacons, oldest first; none if it cannot.

        From the last snapshot before the earliest frame of the stretch of sightings that led
        into each one's run of rejections: the frames since its run began (``runs``: beacon to
        the run's first time) and, before them, back while it was seen at most ``gap`` seconds
        apart; no further back than the lag and the credit allow (module docstring), and from
        the first snapshot after that when none is before. Spends the credit.
        """
        frames = self.frames
        first = len(frames) - 1
        for beacon, since in runs.items():
            seen = since
            for k in range(len(frames) - 1, -1, -1):
                _, time, measurements = frames[k]
                if time >= since:
                    first = min(first, k)
                    continue
                if seen - time > gap:
                    break
                if (measurements.ids == beacon).any():
                    first, seen = min(first, k), time
        oldest = max(0, len(frames) - self._credit)
        taken = sorted(k - self._first for k in self.snapshots
                       if oldest <= k - self._first < len(frames))
        if not taken:
            return []
        start = max((k for k in taken if k <= first), default=taken[0])
        self._credit -= len(frames) - start
        return [(self._first + k, *frames[k]) for k in range(start, len(frames))]

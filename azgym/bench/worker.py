"""The contender's side of an isolated run: one localizer in a process of its own.

A worker process receives what a real localizer would have and nothing more: the beacon maps
once, then batches of frames as measurements (ids, azimuths, optional quality). The arrays it
hands the localizer are views of immutable bytes, so they cannot be made writable, and the true
poses never enter the process: the parent scores the answers.

The worker writes each answer into shared memory as soon as it has it and publishes, before
every call into the localizer, which frame it is on and when the call began. So the parent can
enforce a time limit per call, and when the process dies (a segfault, ``os._exit``) the answers
before the fatal frame are kept. An exception in the localizer, ``SystemExit`` included, is
scored on its frame and the worker goes on.

Layouts shared with :mod:`azgym.bench.isolation`: ``progress`` holds (phase, start time in
``time.monotonic_ns``); ``answers`` holds ``ANSWER_SIZE`` numbers per frame of a batch.
"""

from __future__ import annotations

import math
import os
import signal
import time
import zlib
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from azgym.bench.wire import MapData, WorkerFrame, unpack, unpack_map
from azgym.core import BeaconMap, Measurements, estimated_pose
from azgym.errors import AzgymError
from azgym.localize.registry import is_builtin
from azgym.track.base import FrameByFrame, Tracker, make_tracker

_CLOCK = time.perf_counter_ns
"""The timer, bound when the worker loads, before any localizer's code runs (a plug-in that
replaces ``time.perf_counter_ns`` later does not change the runtimes recorded)."""

# Phases the worker publishes in progress[0]; a frame's index (>= 0) while it is being localized.
WARMING = -3
BUILDING = -2
IDLE = -1

# One frame's answer: x, y, heading, state, micros.
ANSWER_SIZE = 5
ANSWER_X, ANSWER_Y, ANSWER_HEADING, ANSWER_STATE, ANSWER_MICROS = range(ANSWER_SIZE)
PENDING, POSED, NO_POSE, RAISED = 0.0, 1.0, 2.0, 3.0
"""Answer states: not answered yet; a usable pose; an estimate without one; an exception."""

def serve(conn: Any, progress: Any, answers: Any, spec: str, params: dict[str, Any],
          maps: Mapping[str, MapData], folder: str) -> None:
    """The worker's main loop: build the contender, then answer batches until told to stop.

    A localizer runs as a tracker without memory (:class:`~azgym.track.base.FrameByFrame`).
    The tracker is reset at each new sequence (a frame on its own is a sequence of one), with
    the sequence's known start pose on its first frame; a worker that takes over in the middle
    of a sequence (after a lost frame) resets it without one.

    Messages to the parent: ``("ready",)`` once built, or ``("unbuildable", why)``; then per
    batch ``("error", k, text)`` for each frame k that raised, and ``("done",)`` at its end.

    Args:
        conn: The pipe to the parent; it sends lists of packed frames
            (:mod:`azgym.bench.wire`), or None to stop.
        progress: Shared int64 pair (phase, start time of the current call).
        answers: Shared float64 array, ``ANSWER_SIZE`` slots per frame of a batch.
        spec: The localizer's or tracker's spec.
        params: Its hyperparameters.
        maps: Each scenario's beacon map.
        folder: The runner's working folder: relative paths in the spec (a plug-in file, a
            weight file) mean what they meant where the run was started, whichever folder the
            fork server was started in.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    os.chdir(folder)
    beacon_maps = {name: unpack_map(data) for name, data in maps.items()}
    _mark(progress, BUILDING)
    try:
        tracker = make_tracker(spec, **params)
    except BaseException as exc:  # noqa: BLE001 - reported, the parent scores every frame
        why = str(exc) if isinstance(exc, AzgymError) else describe(exc)
        conn.send(("unbuildable", why))
        return
    warm = not isinstance(tracker, FrameByFrame)  # a localizer's first call loads its code
    if not warm and is_builtin(spec):  # azgym's own code compiles for as long as it takes
        _mark(progress, WARMING)
        try:
            warm_up_localizer(tracker.localizer)
        except BaseException:  # noqa: BLE001, S110 - the frames' own calls record a failure
            pass
        warm = True
    _mark(progress, IDLE)
    conn.send(("ready",))
    sequence = None
    while (batch := _receive(conn)) is not None:
        frames = [unpack(packed) for packed in batch]
        if not warm and frames:  # run it once untimed
            _mark(progress, 0)
            first = frames[0]
            call_untimed(tracker.localizer, first.measurements, beacon_maps[first.scenario])
            warm = True
        sequence = answer_batch(conn, progress, answers, tracker, frames, beacon_maps, sequence)
        _mark(progress, IDLE)
        conn.send(("done",))


def answer_batch(conn: Any, progress: Any, answers: Any, tracker: Tracker,
                 frames: Sequence[WorkerFrame], maps: Mapping[str, BeaconMap],
                 sequence: str | None) -> str | None:
    """Answer each frame, writing its answer (and sending its error) as soon as it is known.

    Returns the sequence the tracker is in at the end (the next batch may continue it).
    """
    for k, frame in enumerate(frames):
        base = k * ANSWER_SIZE
        answers[base + ANSWER_STATE] = PENDING
        _mark(progress, k)
        try:
            if not frame.sequence or frame.sequence != sequence:
                sequence = frame.sequence
                tracker.reset(zlib.crc32(sequence.encode()), frame.initial)
            start = _CLOCK()
            if frame.motion is not None:
                tracker.predict(frame.motion)
            estimate = tracker.update(frame.measurements, maps[frame.scenario])
            micros = (_CLOCK() - start) / 1000.0
            pose = estimated_pose(estimate)
        except BaseException as exc:  # noqa: BLE001 - SystemExit too: scored, never fatal
            answers[base + ANSWER_STATE] = RAISED
            conn.send(("error", k, describe(exc)))
            continue
        answers[base + ANSWER_MICROS] = micros
        if pose is not None:
            answers[base + ANSWER_X], answers[base + ANSWER_Y] = pose[0], pose[1]
            answers[base + ANSWER_HEADING] = pose[2]
        answers[base + ANSWER_STATE] = NO_POSE if pose is None else POSED
    return sequence


def call_untimed(localizer: Any, measurements: Measurements, beacons: BeaconMap) -> None:
    """One call whose outcome does not count (its frame is localized again, timed)."""
    try:
        localizer.localize(measurements, beacons)
    except BaseException:  # noqa: BLE001, S110 - the timed call records the failure
        pass


def _receive(conn: Any) -> Any:
    """The next batch, or None when told to stop or when the parent is gone."""
    try:
        return conn.recv()
    except (EOFError, OSError):
        return None


def _mark(progress: Any, phase: int) -> None:
    """Publish the phase and the time it began (the parent's time limit counts from it)."""
    progress[1] = time.monotonic_ns()
    progress[0] = phase


def describe(exc: BaseException) -> str:
    """An exception as the results report it: its type and message."""
    return f"{type(exc).__name__}: {exc}"


def warm_up_localizer(localizer: Any) -> None:
    """Run one localizer once on a small noise-free frame (five beacons round a room).

    Its first call loads its compiled code, or compiles it on a machine's first run.
    """
    xyz = np.array([[0.0, 0.0, 3.0], [10.0, 0.0, 3.0], [10.0, 8.0, 3.0], [0.0, 8.0, 3.0],
                    [5.0, 8.0, 3.0]])
    beacons = BeaconMap(np.arange(5), xyz)
    x, y, heading = 3.0, 2.5, 0.3
    azimuth = [math.remainder(math.atan2(by - y, bx - x) - heading, math.tau)
               for bx, by, _ in xyz]
    localizer.localize(Measurements(np.arange(5), azimuth), beacons)

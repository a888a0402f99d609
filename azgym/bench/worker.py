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

import signal
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from azgym.core import BeaconMap, Measurements, estimated_pose
from azgym.errors import AzgymError
from azgym.localize.registry import make_localizer

_CLOCK = time.perf_counter_ns
"""The timer, bound when the worker loads, before any localizer's code runs (a plug-in that
replaces ``time.perf_counter_ns`` later does not change the runtimes recorded)."""

# Phases the worker publishes in progress[0]; a frame's index (>= 0) while it is being localized.
BUILDING = -2
IDLE = -1

# One frame's answer: x, y, heading, state, micros.
ANSWER_SIZE = 5
ANSWER_X, ANSWER_Y, ANSWER_HEADING, ANSWER_STATE, ANSWER_MICROS = range(ANSWER_SIZE)
PENDING, POSED, NO_POSE, RAISED = 0.0, 1.0, 2.0, 3.0
"""Answer states: not answered yet; a usable pose; an estimate without one; an exception."""

FrameData = tuple[str, bytes, bytes, bytes | None, tuple[int, ...]]
"""One frame as sent: scenario name, ids (int64 bytes), azimuths (float64 bytes), quality
(float64 bytes or None) and quality's shape."""

MapData = tuple[np.ndarray, np.ndarray, np.ndarray]
"""One beacon map as sent: ids, xyz, width."""


def frame_data(scenario: str, measurements: Measurements) -> FrameData:
    """Pack one frame's measurements for a worker (nothing but the measurements travels)."""
    quality = measurements.quality
    return (scenario, np.ascontiguousarray(measurements.ids, dtype=np.int64).tobytes(),
            np.ascontiguousarray(measurements.azimuth, dtype=np.float64).tobytes(),
            None if quality is None else np.ascontiguousarray(quality, np.float64).tobytes(),
            () if quality is None else tuple(quality.shape))


def unpack_frame(data: FrameData) -> tuple[str, Measurements]:
    """The measurements of a packed frame, as read-only views of the received bytes."""
    scenario, ids, azimuth, quality, shape = data
    quality_array = None if quality is None else np.frombuffer(quality, np.float64).reshape(shape)
    return scenario, Measurements._from_frozen(np.frombuffer(ids, np.int64),
                                               np.frombuffer(azimuth, np.float64), quality_array)


def serve(conn: Any, progress: Any, answers: Any, spec: str, params: dict[str, Any],
          maps: Mapping[str, MapData]) -> None:
    """The worker's main loop: build the localizer, then localize batches until told to stop.

    Messages to the parent: ``("ready",)`` once built, or ``("unbuildable", why)``; then per
    batch ``("error", k, text)`` for each frame k that raised, and ``("done",)`` at its end.

    Args:
        conn: The pipe to the parent; it sends lists of :data:`FrameData`, or None to stop.
        progress: Shared int64 pair (phase, start time of the current call).
        answers: Shared float64 array, ``ANSWER_SIZE`` slots per frame of a batch.
        spec: The localizer's spec.
        params: Its hyperparameters.
        maps: Each scenario's beacon map.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    beacon_maps = {name: BeaconMap(*arrays) for name, arrays in maps.items()}
    _mark(progress, BUILDING)
    try:
        localizer = make_localizer(spec, **params)
    except BaseException as exc:  # noqa: BLE001 - reported, the parent scores every frame
        why = str(exc) if isinstance(exc, AzgymError) else _describe(exc)
        conn.send(("unbuildable", why))
        return
    _mark(progress, IDLE)
    conn.send(("ready",))
    warm = False
    while (batch := _receive(conn)) is not None:
        frames = [unpack_frame(data) for data in batch]
        if not warm and frames:  # the first call loads compiled code: run it once untimed
            _mark(progress, 0)
            _call_untimed(localizer, frames[0][1], beacon_maps[frames[0][0]])
            warm = True
        _localize_batch(conn, progress, answers, localizer, frames, beacon_maps)
        _mark(progress, IDLE)
        conn.send(("done",))


def _localize_batch(conn: Any, progress: Any, answers: Any, localizer: Any,
                    frames: Sequence[tuple[str, Measurements]],
                    maps: Mapping[str, BeaconMap]) -> None:
    """Localize each frame, writing its answer (and sending its error) as soon as it is known."""
    for k, (scenario, measurements) in enumerate(frames):
        base = k * ANSWER_SIZE
        answers[base + ANSWER_STATE] = PENDING
        _mark(progress, k)
        try:
            start = _CLOCK()
            estimate = localizer.localize(measurements, maps[scenario])
            micros = (_CLOCK() - start) / 1000.0
            pose = estimated_pose(estimate)
        except BaseException as exc:  # noqa: BLE001 - SystemExit too: scored, never fatal
            answers[base + ANSWER_STATE] = RAISED
            conn.send(("error", k, _describe(exc)))
            continue
        answers[base + ANSWER_MICROS] = micros
        if pose is not None:
            answers[base + ANSWER_X], answers[base + ANSWER_Y] = pose[0], pose[1]
            answers[base + ANSWER_HEADING] = pose[2]
        answers[base + ANSWER_STATE] = NO_POSE if pose is None else POSED


def _call_untimed(localizer: Any, measurements: Measurements, beacons: BeaconMap) -> None:
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


def _describe(exc: BaseException) -> str:
    """An exception as the results report it: its type and message."""
    return f"{type(exc).__name__}: {exc}"

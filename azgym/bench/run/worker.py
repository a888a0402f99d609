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

Layouts shared with :mod:`azgym.bench.run.isolation`: ``progress`` holds (phase, start time in
``time.monotonic_ns``); ``answers`` holds ``ANSWER_SIZE`` numbers per frame of a batch.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import signal
import sys
import time
import zlib
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from azgym.bench.run.profiles import contender_params
from azgym.bench.run.wire import (
    DONE,
    MapData,
    Packed,
    StepReader,
    WorkerFrame,
    pack,
    pack_map,
    say,
    unpack,
    unpack_map,
)
from azgym.core import BeaconMap, Measurements, estimated_pose
from azgym.errors import AzgymError
from azgym.localize.registry import SupportsLocalize, is_builtin
from azgym.profile import Profile
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples
from azgym.track.base import FrameByFrame, SupportsTrack, make_tracker

__all__ = ["ANSWER_HEADING", "ANSWER_MICROS", "ANSWER_SIZE", "ANSWER_STATE", "ANSWER_X", "ANSWER_Y",
           "BUILDING", "IDLE", "NO_POSE", "POSED", "WARMING", "answer_step", "call_untimed",
           "describe", "hide_process", "quiet_streams", "seal", "serve", "warm_up"]

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
          profile: Profile | None, maps: Mapping[str, MapData], folder: str) -> None:
    """The worker's main loop: build the contender, then answer steps until told to stop.

    A localizer runs as a tracker without memory (:class:`~azgym.track.base.FrameByFrame`).
    The tracker is reset at each new sequence (a frame on its own is a sequence of one), with
    the sequence's known start pose on its first frame; a worker that takes over in the middle
    of a sequence (after a lost frame) resets it without one.

    The parent sends a batch of frames in steps: a frame of a sequence alone, and the next one
    only once this one is answered, so nothing in this process (its memory, its call stack)
    ever holds a frame the tracker has not reached; frames on their own (no sequence), which
    have no future to see, several at a time.

    Messages to the parent (:func:`azgym.bench.run.wire.say`): ``["ready"]`` once built, or
    ``["unbuildable", why]``; then per step ``["error", k, text]`` for each frame k (of the
    step) that raised, ``["warmed"]`` after a plug-in's untimed first call, and ``["done"]``
    at the step's end.

    Args:
        conn: The pipe to the parent; it sends steps (:func:`azgym.bench.run.wire.step_message`)
            or :data:`~azgym.bench.run.wire.STOP`.
        progress: Shared int64 pair (phase: the frame of the step being answered; start time
            of the current call).
        answers: Shared float64 array, ``ANSWER_SIZE`` slots per frame of a step.
        spec: The localizer's or tracker's spec.
        params: Its hyperparameters.
        profile: The profile whose hyperparameters are its defaults (None: none), resolved
            here (:func:`~azgym.bench.run.profiles.contender_params`): the runner never imports a
            plug-in.
        maps: Each scenario's beacon map.
        folder: The runner's working folder: relative paths in the spec (a plug-in file, a
            weight file) mean what they meant where the run was started, whichever folder the
            fork server was started in.
    """
    fd = conn.fileno()
    seal(fd)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    os.chdir(folder)
    beacon_maps = {name: unpack_map(data) for name, data in maps.items()}
    if (built := _build(fd, progress, spec, params, profile)) is None:
        return
    tracker, warm = built
    sequence = None
    steps = StepReader(fd)
    while (step := _receive(steps)) is not None:
        frames = [unpack(packed) for packed in step]
        # a plug-in localizer (the only contender that starts cold): run it once untimed
        if not warm and frames and isinstance(tracker, FrameByFrame):
            _mark(progress, 0)
            first = frames[0]
            call_untimed(tracker.localizer, first.measurements, beacon_maps[first.scenario])
            warm = True
            say(fd, "warmed")
        sequence = answer_step(fd, progress, answers, tracker, frames, beacon_maps, sequence)
        _mark(progress, IDLE)
        os.write(fd, DONE)


def _build(fd: int, progress: Any, spec: str, params: dict[str, Any], profile: Profile | None
           ) -> tuple[SupportsTrack, bool] | None:
    """Build the contender (a built-in then runs through its warm-up) and say it is ready.

    Its hyperparameters are ``params`` with the profile's under them.

    Returns the tracker, and whether its first call may be timed (a plug-in localizer's first
    call, which loads its code, is not); None when it cannot be built (said to the parent).
    """
    _mark(progress, BUILDING)
    try:
        tracker = make_tracker(spec, **contender_params(spec, params, profile))
    except BaseException as exc:  # noqa: BLE001 - reported, the parent scores every frame
        say(fd, "unbuildable", str(exc) if isinstance(exc, AzgymError) else describe(exc))
        return None
    warm = not isinstance(tracker, FrameByFrame)  # a localizer's first call loads its code
    if is_builtin(spec):  # azgym's own code compiles for as long as it takes, untimed
        _mark(progress, WARMING)
        warm_up(tracker)
        warm = True
    _mark(progress, IDLE)
    say(fd, "ready")
    return tracker, warm


def answer_step(fd: int, progress: Any, answers: Any, tracker: SupportsTrack,
                 frames: Sequence[WorkerFrame], maps: Mapping[str, BeaconMap],
                 sequence: str | None) -> str | None:
    """Answer each frame of a step, writing its answer (and sending its error on ``fd``) at once.

    Returns the sequence the tracker is in at the end (the next step may continue it).
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
            say(fd, "error", k, describe(exc))
            continue
        answers[base + ANSWER_MICROS] = micros
        if pose is not None:
            answers[base + ANSWER_X], answers[base + ANSWER_Y] = pose[0], pose[1]
            answers[base + ANSWER_HEADING] = pose[2]
        answers[base + ANSWER_STATE] = NO_POSE if pose is None else POSED
    return sequence


def call_untimed(localizer: SupportsLocalize, measurements: Measurements,
                 beacons: BeaconMap) -> None:
    """One call whose outcome does not count (its frame is localized again, timed)."""
    try:
        localizer.localize(measurements, beacons)
    except BaseException:  # noqa: BLE001, S110 - the timed call records the failure
        pass


def _receive(steps: StepReader) -> list[Packed] | None:
    """The next step, or None when told to stop or when the parent is gone."""
    try:
        return steps.read()
    except OSError:
        return None


def _mark(progress: Any, phase: int) -> None:
    """Publish the phase and the time it began (the parent's time limit counts from it)."""
    progress[1] = time.monotonic_ns()
    progress[0] = phase


_LIBC = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith("linux") else None
"""The C library, for ``prctl`` and ``capset``: the protections below are Linux's."""
_PR_SET_PDEATHSIG, _PR_SET_DUMPABLE, _PR_CAPBSET_DROP, _PR_CAP_AMBIENT = 1, 4, 24, 47
_PR_CAP_AMBIENT_CLEAR_ALL = 4
_CAPABILITY_VERSION_3 = 0x20080522


def hide_process() -> None:
    """Make this process non-dumpable (Linux; elsewhere nothing is done).

    Other processes of the same user can then no longer read its memory (``/proc/PID/mem``),
    environment or open files (``/proc/PID/fd``), nor attach a debugger to it; only a process
    with ``CAP_SYS_PTRACE`` (root's, which workers drop: :func:`seal`) still can. Its command
    line (``/proc/PID/cmdline``) stays readable to all. A process that holds what a contender
    must not see (the cases drawn for a test split, a route's frames ahead) calls this first.
    """
    if _LIBC is not None:
        _LIBC.prctl(_PR_SET_DUMPABLE, 0, 0, 0, 0)


def quiet_streams() -> None:
    """Point standard input, output and error at ``/dev/null``."""
    null = os.open(os.devnull, os.O_RDWR)
    for fd in (0, 1, 2):
        os.dup2(null, fd)
    if null > 2:
        os.close(null)


def seal(keep: int) -> None:
    """Cut a worker off from what its parents hold, before any contender code runs.

    - Standard input, output and error become ``/dev/null``: the runner's output (redirected to
      a file, it is readable through ``/proc/self/fd/1``) is not the worker's.
    - Every other inherited descriptor is closed but ``keep`` (the pipe to the parent).
    - Linux: the worker dies with its parent (``PR_SET_PDEATHSIG``), so a Ray actor killed at a
      deadline takes its worker along; and a worker started as root drops every capability
      (the bounding set too, so no program it starts gets them back), so it can no longer
      read a non-dumpable process's memory (:func:`hide_process`) as root otherwise could.
    """
    quiet_streams()
    os.closerange(3, keep)
    os.closerange(keep + 1, os.sysconf("SC_OPEN_MAX"))
    if _LIBC is None:
        return
    parent = os.getppid()
    _LIBC.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the parent died before the line above
        os._exit(1)
    if _capabilities():
        for capability in range(64):
            _LIBC.prctl(_PR_CAPBSET_DROP, capability, 0, 0, 0)
        _LIBC.prctl(_PR_CAP_AMBIENT, _PR_CAP_AMBIENT_CLEAR_ALL, 0, 0, 0)
        header = (ctypes.c_uint32 * 2)(_CAPABILITY_VERSION_3, 0)
        if _LIBC.capset(header, (ctypes.c_uint32 * 6)()) != 0 or _capabilities():
            os._exit(1)  # never run a contender with the capabilities it should not have


def _capabilities() -> int:
    """This process's effective capabilities, as ``/proc/self/status`` shows them."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("CapEff:"):
                return int(line.split()[1], 16)
    return 0


def describe(exc: BaseException) -> str:
    """An exception as the results report it: its type and message."""
    return f"{type(exc).__name__}: {exc}"


def warm_up(tracker: SupportsTrack) -> None:
    """Run a tracker (a localizer through :class:`FrameByFrame`) through the warm-up route.

    Its calls load its compiled code, or compile it on a machine's first run, for every
    specialization a real frame reaches: numba compiles a kernel once per combination of argument
    types, and a run's frames come through the wire (read-only arrays), with no quality, one
    quality column or several (a copied column), with motion or without. The route's frames
    take every path a localizer has (an exact frame that a consensus settles, outliers that the
    network or the complete search sorts out, an unknown id, too few beacons to answer), so no
    compiling is left for a timed call. A call that raises is skipped: the run's frames record
    whatever failure is real.
    """
    beacons = unpack_map(pack_map(_WARM_UP_MAP))
    for quality_columns in (0, 1, 3):
        frames = [unpack(packed) for packed in _warm_up_route(quality_columns)]
        with contextlib.suppress(BaseException):
            tracker.reset(0, frames[0].initial)
        for frame in frames:
            with contextlib.suppress(BaseException):
                if frame.motion is not None:
                    tracker.predict(frame.motion)
                tracker.update(frame.measurements, beacons)


_WARM_UP_MAP = BeaconMap(np.arange(5), np.array([[0.0, 0.0, 3.0], [10.0, 0.0, 3.0],
                                                 [10.0, 8.0, 3.0], [0.0, 8.0, 3.0],
                                                 [5.0, 8.0, 3.0]]))
"""Five beacons round a 10 m × 8 m room: the warm-up route's map."""


def _warm_up_route(quality_columns: int) -> list[Packed]:
    """The warm-up route as a run sends it: five frames, each ``quality_columns`` wide (0: none).

    The frames: every beacon seen exactly (its start pose known, no motion yet), then, each
    after 0.1 s of motion, two outliers among them (a ghost and a misread id), an id not in
    the map, three beacons on one side of the camera (outside their hull: ``mex`` then searches
    beyond them), and two beacons only.
    """
    xyz = _WARM_UP_MAP.xyz
    x, y, heading = 3.0, 2.5, 0.3
    exact = [math.remainder(math.atan2(by - y, bx - x) - heading, math.tau) for bx, by, _ in xyz]
    views = [(list(range(5)), exact),
             ([0, 1, 2, 3, 4, 0, 2], [*exact, exact[0] + 1.2, exact[3]]),
             ([0, 1, 2, 3, 4, 9], [*exact, 0.5]),
             ([2, 3, 4], exact[2:5]),
             ([1, 2], exact[1:3])]
    packed = []
    for k, (ids, azimuth) in enumerate(views):
        quality = None if not quality_columns else \
            np.linspace(0.5, 1.5, len(ids) * quality_columns).reshape(len(ids), quality_columns)
        if quality is not None and quality_columns == 1:
            quality = quality[:, 0]
        samples = np.linspace(0.1 * k - 0.08, 0.1 * k, 5) if k else np.zeros(0)
        flat = np.zeros_like(samples)
        motion = Motion(0.1 * k, OdometrySamples(samples, flat + 0.5, flat),
                        ImuSamples(samples, flat, np.zeros((samples.size, 2)), flat + np.nan))
        packed.append(pack("warm-up", Measurements(ids, azimuth, quality), "warm-up",
                           (x, y, heading) if k == 0 else None, motion))
    return packed

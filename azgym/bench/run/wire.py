"""What crosses to a worker: the beacon maps, and each frame packed as immutable bytes.

A frame travels as its scenario's name, its sequence (the route it belongs to, for trackers),
the known start pose on a sequence's first frame, its measurements and the motion samples since
the previous frame. The worker unpacks the arrays as views of the received bytes, which cannot
be made writable: a localizer cannot change what it was given, let alone what others get.

Frames go in steps (a route's one frame at a time, :mod:`azgym.bench.run.isolation`), each one
message on the worker's pipe. A route costs a message a frame, so a route's messages are made
once a run and the worker reads each with one system call into a buffer of its own. What a
worker says back (:func:`say`) is JSON, never a pickle: unpickling runs code, and the worker
runs the contender's.
"""

from __future__ import annotations

import json
import os
import pickle
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.core import BeaconMap, Measurements, Pose
from azgym.errors import ProtocolError
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples

__all__ = ["DONE", "LENGTH", "MapData", "Packed", "ProtocolError", "STOP", "StepReader",
           "WorkerFrame", "framed", "heard", "pack", "pack_map", "say", "step_message", "unframed",
           "unpack", "unpack_map", "write_all"]

MapData = tuple[np.ndarray, np.ndarray, np.ndarray]
"""One beacon map as sent: ids, xyz, width."""

Packed = tuple[str, str, Pose | None, bytes, bytes, bytes | None, tuple[int, ...], bytes | None]
"""One frame as sent: scenario, sequence, initial pose, ids (int64 bytes), azimuths (float64
bytes), quality (float64 bytes or None) and its shape, motion (float64 bytes or None)."""


@dataclass(frozen=True, eq=False)
class WorkerFrame:
    """One frame as a worker sees it.

    Attributes:
        scenario: Whose beacon map applies.
        sequence: The sequence (route) it belongs to; "" for a frame on its own.
        initial: The known start pose, on a sequence's first frame only.
        measurements: Its detections.
        motion: The odometry and IMU samples since the previous frame, or None.
    """

    scenario: str
    sequence: str
    initial: Pose | None
    measurements: Measurements
    motion: Motion | None


def pack_map(beacons: BeaconMap) -> MapData:
    """A beacon map as sent once to each worker."""
    return beacons.ids, beacons.xyz, beacons.width


def unpack_map(data: MapData) -> BeaconMap:
    """The worker's own copy of a map (checked and frozen as any map is)."""
    return BeaconMap(*data)


def pack(scenario: str, measurements: Measurements, sequence: str = "",
         initial: Pose | None = None, motion: Motion | None = None) -> Packed:
    """Pack one frame for a worker."""
    quality = measurements.quality
    return (scenario, sequence, initial,
            np.ascontiguousarray(measurements.ids, dtype=np.int64).tobytes(),
            np.ascontiguousarray(measurements.azimuth, dtype=np.float64).tobytes(),
            None if quality is None else np.ascontiguousarray(quality, np.float64).tobytes(),
            () if quality is None else tuple(quality.shape),
            None if motion is None else _pack_motion(motion))


def unpack(packed: Packed) -> WorkerFrame:
    """A packed frame, its arrays read-only views of the received bytes."""
    scenario, sequence, initial, ids, azimuth, quality, shape, motion = packed
    quality_array = None if quality is None else np.frombuffer(quality, np.float64).reshape(shape)
    measurements = Measurements._from_frozen(np.frombuffer(ids, np.int64),
                                             np.frombuffer(azimuth, np.float64), quality_array)
    return WorkerFrame(scenario, sequence, initial, measurements,
                       None if motion is None else _unpack_motion(motion))


def _pack_motion(motion: Motion) -> bytes:
    """[time, K odometry samples, L IMU samples, then each column in turn] as float64 bytes."""
    odometry, imu = motion.odometry, motion.imu
    columns: list[Any] = [odometry.time, odometry.speed, odometry.steer, odometry.yaw_rate,
                          imu.time, imu.yaw_rate,
                          np.asarray(imu.accel).reshape(-1), imu.heading]
    head = [float(motion.time), float(np.size(odometry.time)), float(np.size(imu.time))]
    return np.concatenate([head, *(np.asarray(c, dtype=np.float64) for c in columns)]).tobytes()


def _unpack_motion(data: bytes) -> Motion:
    values = np.frombuffer(data, np.float64)
    time, k, n = float(values[0]), int(values[1]), int(values[2])
    sizes = (k, k, k, k, n, n, 2 * n, n)
    ends = 3 + np.cumsum(sizes)
    parts = [values[end - size:end] for size, end in zip(sizes, ends, strict=True)]
    return Motion(time, OdometrySamples(*parts[:4]),
                  ImuSamples(parts[4], parts[5], parts[6].reshape(n, 2), parts[7]))


LENGTH = struct.Struct("!i")
"""A message's length, as ``multiprocessing.connection.Connection.send_bytes`` frames it."""


def framed(payload: bytes) -> bytes:
    """A message as the pipes carry it: its length, then itself."""
    return LENGTH.pack(len(payload)) + payload


STOP = framed(pickle.dumps(None))
"""The message that tells a worker to stop."""


def step_message(frames: Sequence[Packed]) -> bytes:
    """A step: its packed frames, in one message (a list, pickled)."""
    return framed(pickle.dumps(list(frames), protocol=pickle.HIGHEST_PROTOCOL))


class StepReader:
    """Reads steps (:func:`step_message`) from the parent's pipe into a buffer of its own.

    One system call reads most of them.
    """

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.buffer = bytearray(1 << 16)

    def read(self) -> list[Packed] | None:
        """The next step's packed frames; None: told to stop, or the parent is gone."""
        got = os.readv(self.fd, [self.buffer])
        while 0 < got < LENGTH.size or got >= LENGTH.size and \
                got < LENGTH.size + LENGTH.unpack_from(self.buffer)[0]:
            if got == len(self.buffer):
                self.buffer.extend(bytes(len(self.buffer)))
            with memoryview(self.buffer) as view:
                more = os.readv(self.fd, [view[got:]])
            if not more:
                return None
            got += more
        if got < LENGTH.size:
            return None
        return pickle.loads(self.buffer[LENGTH.size:got])


MAX_MESSAGE = 1 << 20
"""The longest message a worker may send [bytes]; a longer one breaks the protocol."""


def say(fd: int, *message: str | int) -> None:
    """Send the parent a message: a JSON list, framed as ``Connection.send_bytes`` frames."""
    write_all(fd, framed(json.dumps(message).encode()))


DONE = framed(b'["done"]')
"""``say(fd, "done")``, framed once: a route sends it once a frame."""


def heard(inbox: bytearray) -> list[list[Any]]:
    """Take the complete messages out of what a worker has sent so far (``inbox``).

    Raises:
        ProtocolError: A message that is too long, or not a JSON list.
    """
    messages = []
    for payload in unframed(inbox, MAX_MESSAGE, lambda size: f"a message of {size} bytes"):
        try:
            message = json.loads(payload)
        except (ValueError, RecursionError):  # RecursionError: nested too deeply
            raise ProtocolError("a message that is not JSON") from None
        if not isinstance(message, list) or not message:
            raise ProtocolError("a message that is not a list")
        messages.append(message)
    return messages


def unframed(inbox: bytearray, cap: int, too_long: Callable[[int], str]) -> list[bytes]:
    """Take the complete messages (:func:`framed`) out of ``inbox``, each at most ``cap`` bytes.

    Raises:
        ProtocolError: A message longer than ``cap`` (worded by ``too_long(size)``).
    """
    found = []
    while len(inbox) >= LENGTH.size:
        (size,) = LENGTH.unpack_from(inbox)
        if not 0 <= size <= cap:
            raise ProtocolError(too_long(size))
        if len(inbox) < LENGTH.size + size:
            break
        found.append(bytes(inbox[LENGTH.size:LENGTH.size + size]))
        del inbox[:LENGTH.size + size]
    return found


def write_all(fd: int, data: bytes) -> None:
    """Write all of ``data`` to ``fd`` (a pipe takes a long message in parts)."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]

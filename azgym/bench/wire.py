"""What crosses to a worker: the beacon maps, and each frame packed as immutable bytes.

A frame travels as its scenario's name, its sequence (the route it belongs to, for trackers),
the known start pose on a sequence's first frame, its measurements and the motion samples since
the previous frame. The worker unpacks the arrays as views of the received bytes, which cannot
be made writable: a localizer cannot change what it was given, let alone what others get.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.core import BeaconMap, Measurements, Pose
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples

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
    columns: list[Any] = [odometry.time, odometry.speed, odometry.steer, imu.time, imu.yaw_rate,
                          np.asarray(imu.accel).reshape(-1), imu.heading]
    head = [float(motion.time), float(np.size(odometry.time)), float(np.size(imu.time))]
    return np.concatenate([head, *(np.asarray(c, dtype=np.float64) for c in columns)]).tobytes()


def _unpack_motion(data: bytes) -> Motion:
    values = np.frombuffer(data, np.float64)
    time, k, n = float(values[0]), int(values[1]), int(values[2])
    sizes = (k, k, k, n, n, 2 * n, n)
    ends = 3 + np.cumsum(sizes)
    parts = [values[end - size:end] for size, end in zip(sizes, ends, strict=True)]
    return Motion(time, OdometrySamples(*parts[:3]),
                  ImuSamples(parts[3], parts[4], parts[5].reshape(n, 2), parts[6]))

"""A log's frames as the localizers' and trackers' input: detections and motion samples.

Each frame's detections as :class:`Measurements` (what a log without truth can still give: every
frame's measurements, to localize; a log with truth is scored as a suite instead,
:mod:`azgym.bench.suites.data`), and each frame's odometry and IMU samples as a
:class:`~azgym.sensing.motion.Motion` (what a tracker's ``predict`` and a survey take).
"""

from __future__ import annotations

import numpy as np

from azgym.core import Measurements
from azgym.logs.read import Columns, Log
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples

__all__ = ["frame_measurements", "frame_motions"]


def frame_measurements(log: Log) -> list[Measurements]:
    """Each frame's detections, in the log's order; one quality column is a 1-D quality."""
    detections = log.detections
    bounds = np.searchsorted(detections["frame"], np.arange(len(log.frames["frame"]) + 1))
    quality = detections["quality"]
    found = []
    for start, stop in zip(bounds[:-1], bounds[1:], strict=True):
        rows = quality[start:stop]
        found.append(Measurements(detections["id"][start:stop], detections["azimuth"][start:stop],
                                  None if rows.shape[1] == 0 else
                                  rows[:, 0] if rows.shape[1] == 1 else rows))
    return found


def frame_motions(log: Log) -> list[Motion]:
    """Each frame's motion samples: those after the previous frame's time, up to its own.

    The first frame holds what the reader kept before it (docs/logs.md); a log without odometry
    or IMU gives every frame empty samples of the missing kind.
    """
    times = log.frames["time"]
    odometry, imu = log.odometry, log.imu
    odometry_time = np.zeros(0) if odometry is None else odometry["time"]
    imu_time = np.zeros(0) if imu is None else imu["time"]
    odometry_ends = np.searchsorted(odometry_time, times, side="right")
    imu_ends = np.searchsorted(imu_time, times, side="right")
    motions = []
    for k, time in enumerate(times):
        o = slice(odometry_ends[k - 1] if k else 0, odometry_ends[k])
        i = slice(imu_ends[k - 1] if k else 0, imu_ends[k])
        motions.append(Motion(float(time), _odometry(odometry, o), _imu(imu, i)))
    return motions


def _odometry(columns: Columns | None, rows: slice) -> OdometrySamples:
    """Odometry samples of some rows: turning ones with ``yaw_rate`` (none without odometry)."""
    if columns is None:
        empty = np.zeros(0)
        return OdometrySamples(empty, empty.copy(), empty.copy())
    time, speed = columns["time"][rows].copy(), columns["speed"][rows].copy()
    if "yaw_rate" in columns.values:
        return OdometrySamples.turning(time, speed, columns["yaw_rate"][rows].copy())
    return OdometrySamples(time, speed, columns["steer"][rows].copy())


def _imu(columns: Columns | None, rows: slice) -> ImuSamples:
    """IMU samples of some rows (NaN where not given; none without an IMU)."""
    if columns is None:
        return ImuSamples(np.zeros(0), np.zeros(0), np.zeros((0, 2)), np.zeros(0))
    time = columns["time"][rows].copy()
    absent = np.full(time.size, np.nan)
    given = columns.values
    return ImuSamples(time, columns["yaw_rate"][rows].copy(),
                      np.column_stack([given[key][rows] if key in given else absent
                                       for key in ("ax", "ay")]),
                      given["heading"][rows].copy() if "heading" in given else absent.copy())

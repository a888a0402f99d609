"""Logged bearing data: azgym's log format, read and checked, scored, and written from a route.

A log (docs/logs.md) is a folder: ``log.toml`` (the manifest, with the vehicle's, camera's and
motion sensors' profile from format 2 on), ``frames.csv`` (one row per camera frame: its number,
time and, optionally, the true position and heading), ``detections.csv`` (one row per
detection: frame, beacon id, azimuth, quality), and optionally ``odometry.csv``, ``imu.csv`` and
``beacons.csv``. :func:`read_log` checks every file and names each problem's file, line and
column, and settles what real loggers' clocks do with a note (``Log.notes``,
:mod:`azgym.logs.clocks`); :func:`frame_measurements` gives each frame's detections to localize;
:func:`export_route` writes a simulated route as a log. A log with truth is scored as a suite
(:mod:`azgym.bench.suites.data`, :func:`azgym.bench.run.runner.run_log_benchmark`).
"""

from azgym.logs.export import export_route
from azgym.logs.frames import frame_measurements
from azgym.logs.problems import LogError
from azgym.logs.read import Log, read_log

__all__ = ["Log", "LogError", "export_route", "frame_measurements", "read_log"]

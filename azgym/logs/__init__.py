"""Logged bearing data: azgym's log format, read and checked, scored, and written from a route.

A log (docs/logs.md) is a folder: ``log.toml`` (the manifest), ``frames.csv`` (one row per
camera frame: its time and, optionally, the true pose), ``detections.csv`` (one row per
detection: frame, beacon id, azimuth, quality), and optionally ``odometry.csv``, ``imu.csv`` and
``beacons.csv``. :func:`read_log` checks every file and names each problem's file, line and
column; :func:`log_cases` turns a log into the benchmark's cases; :func:`export_route` writes a
simulated route as a log.
"""

from azgym.logs.cases import log_cases
from azgym.logs.export import export_route
from azgym.logs.problems import LogError
from azgym.logs.read import Log, read_log

__all__ = ["Log", "LogError", "export_route", "log_cases", "read_log"]

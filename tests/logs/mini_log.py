"""A small hand-made log, valid, that the tests of the log format break one way at a time."""

from __future__ import annotations

import math
from pathlib import Path

MANIFEST = """format = 1
name = "mini"
description = "a hand-made log for tests"
simulated = true

[map]
beacons = "beacons.csv"
"""
BEACONS = [(1, 0.0, 0.0), (2, 10.0, 0.0), (3, 10.0, 10.0), (4, 0.0, 10.0)]
POSES = [(5.0, 5.0, 0.0), (5.1, 5.0, 0.1), (5.2, 5.0, 0.2)]


def _azimuth(pose, beacon) -> float:
    angle = math.atan2(beacon[2] - pose[1], beacon[1] - pose[0]) - pose[2]
    return math.atan2(math.sin(angle), math.cos(angle))


def mini_files() -> dict[str, str]:
    """The files of the mini log: frame 2 has no detection; ids 99 (unknown) and -1 appear."""
    detections = ["frame,id,azimuth,quality_size"]
    for frame, pose in enumerate(POSES[:2]):
        detections += [f"{frame},{b[0]},{_azimuth(pose, b)!r},{0.5 + b[0]}" for b in BEACONS]
    detections += ["1,99,0.5,1.0", "1,-1,-0.5,1.0"]
    return {
        "log.toml": MANIFEST,
        "beacons.csv": "id,x,y,z\n" + "".join(f"{i},{x},{y},2.5\n" for i, x, y in BEACONS),
        "frames.csv": "frame,time,x,y,heading\n" + "".join(
            f"{k},{0.1 * k!r},{x},{y},{h}\n" for k, (x, y, h) in enumerate(POSES)),
        "detections.csv": "\n".join(detections) + "\n",
        "odometry.csv": "time,speed,steer\n0.05,1.0,0.0\n0.15,1.0,0.01\n0.25,1.0,0.0\n",
        "imu.csv": "time,yaw_rate,ax,ay,heading\n0.05,0.0,0.1,0.0,\n0.15,0.01,0.0,0.0,0.1\n",
    }


def write_log(folder: Path, files: dict[str, str | bytes]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name, content in files.items():
        path = folder / name
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8")
    return folder

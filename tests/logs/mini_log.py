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


MANIFEST_2 = """format = 2
name = "mini2"
description = "a hand-made log of format 2 for tests"
simulated = true

[map]
beacons = "beacons.csv"

[vehicle]
kind = "differential-drive"
camera_ahead = 0.1

[sensor]
delta_alpha_d = 0.01
field_of_view = 6.0
"""


def mini_files_2() -> dict[str, str]:
    """The mini log in format 2: frames numbered 10, 12, 13, a differential drive's odometry
    (speed and turn rate), an IMU without accelerations."""
    files = mini_files()
    numbers = {0: 10, 1: 12, 2: 13}
    files["log.toml"] = MANIFEST_2
    files["frames.csv"] = "frame,time,x,y,heading\n" + "".join(
        f"{numbers[k]},{0.1 * k!r},{x},{y},{h}\n" for k, (x, y, h) in enumerate(POSES))
    lines = files["detections.csv"].splitlines()
    files["detections.csv"] = "\n".join([lines[0], *(
        ",".join([str(numbers[int(line.split(",")[0])]), *line.split(",")[1:]])
        for line in lines[1:])]) + "\n"
    files["odometry.csv"] = "time,speed,yaw_rate\n0.05,1.0,0.0\n0.15,1.0,0.5\n"
    files["imu.csv"] = "time,yaw_rate\n0.05,0.0\n0.15,0.01\n"
    return files

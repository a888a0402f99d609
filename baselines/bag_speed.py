"""Speed of ``azgym import bag``, with rosbags' own reading of the same bag timed in the same run.

    python baselines/bag_speed.py [--minutes 15] [--storage sqlite3|mcap] [--rounds 3]

A robot drives circles for ``--minutes`` (0.5 m/s, 5 m radius, eight beacons in view): 10 Hz
camera frames with their truth, 100 Hz odometry and 100 Hz IMU, written as a log, exported as
a bag (``azgym export bag``), then imported (``azgym import bag``: reading, checking, writing
the log and reading it back with ``read_log``) ``--rounds`` times into a scratch folder. Beside
each import are two references timed right before it on the same bag: rosbags reading every
message's bytes (the floor of any import), and reading and deserializing each one
(``deserialize_cdr``: what an import through rosbags' messages costs before it does anything
with them). The least disturbed round (the fastest import) is reported, as messages per
second, with its ratio to that round's references; the target is 50 000 messages per second.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from azgym.logs import read_log
from azgym.logs.export import csv_text
from azgym.logs.ros import export_bag, import_bag

TARGET = 50_000
"""Messages a second an import must reach."""
SPEED, RADIUS, CENTRE = 0.5, 5.0, (10.0, 10.0)
BEACONS = [(k + 1, 10.0 + 9.0 * math.cos(k * math.pi / 4), 10.0 + 9.0 * math.sin(k * math.pi / 4))
           for k in range(8)]


def circles_log(folder: Path, minutes: float) -> Path:
    """A log of ``minutes`` of circles: frames at 10 Hz, odometry and IMU at 100 Hz."""
    folder.mkdir(parents=True)
    turn = SPEED / RADIUS
    frame_times = np.arange(round(minutes * 600)) / 10.0
    angle = turn * frame_times
    x, y = CENTRE[0] + RADIUS * np.cos(angle), CENTRE[1] + RADIUS * np.sin(angle)
    heading = np.arctan2(np.sin(angle + math.pi / 2), np.cos(angle + math.pi / 2))
    rows = [(k, i, math.remainder(math.atan2(by - y[k], bx - x[k]) - heading[k], math.tau))
            for k in range(frame_times.size) for i, bx, by in BEACONS]
    motion = np.arange(1, round(minutes * 6000)) / 100.0
    files = {
        "log.toml": 'format = 2\nname = "circles"\ndescription = "circles (baselines/bag_speed.py)'
                    '"\nsimulated = true\n\n[map]\nbeacons = "beacons.csv"\n\n[vehicle]\n'
                    'kind = "differential-drive"\n',
        "beacons.csv": csv_text(["id", "x", "y"], BEACONS),
        "frames.csv": csv_text(["frame", "time", "x", "y", "heading"], zip(
            range(frame_times.size), frame_times.tolist(), x.tolist(), y.tolist(),
            heading.tolist(), strict=True)),
        "detections.csv": csv_text(["frame", "id", "azimuth"], rows),
        "odometry.csv": csv_text(["time", "speed", "yaw_rate"],
                                 ((t, SPEED, turn) for t in motion.tolist())),
        "imu.csv": csv_text(["time", "yaw_rate", "ax", "ay"],
                            ((t, turn, 0.0, SPEED * turn) for t in motion.tolist())),
    }
    for name, text in files.items():
        (folder / name).write_text(text)
    return folder


def bare_read(bag: Path, deserialize: bool) -> tuple[int, float]:
    """rosbags reading every message of ``bag`` (and deserializing it): count and seconds."""
    from rosbags.highlevel import AnyReader

    start = time.perf_counter()
    count = 0
    with AnyReader([bag]) as reader:
        for connection, _, raw in reader.messages():
            if deserialize:
                reader.deserialize(raw, connection.msgtype)
            count += 1
    return count, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=15.0, help="the drive's length")
    parser.add_argument("--storage", choices=("sqlite3", "mcap"), default="sqlite3",
                        help="the bag's storage")
    parser.add_argument("--rounds", type=int, default=3, help="imports timed")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        bag = export_bag(read_log(circles_log(folder / "log", args.minutes)), folder / "bag",
                         storage=args.storage)
        rounds = []
        for _ in range(args.rounds):
            count, raw = bare_read(bag, deserialize=False)
            _, decoded = bare_read(bag, deserialize=True)
            start = time.perf_counter()
            import_bag(bag, folder / "back", overwrite=True)
            rounds.append((time.perf_counter() - start, raw, decoded))
    imported, raw, decoded = min(rounds)
    print(f"{count} messages ({args.minutes:g} min, {args.storage}); best of {args.rounds}:")
    print(f"  rosbags, bytes only:        {count / raw:9.0f} messages/s")
    print(f"  rosbags, deserialized:      {count / decoded:9.0f} messages/s")
    print(f"  azgym import bag:           {count / imported:9.0f} messages/s "
          f"({imported:.2f} s; {imported / raw:.2f}x the bytes-only read, "
          f"{imported / decoded:.2f}x the deserializing one; target {TARGET})")


if __name__ == "__main__":
    main()

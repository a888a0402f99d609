"""Finds the seed of the test split it is scored on, redraws the frames and answers the truth.

Three ways in, one class each: the runner's output redirected to a file (``/proc/*/fd/1``), the
memory of the processes that run azgym (``/proc/PID/mem``), and ``verify``'s command line (the
entry it names holds the seed). The suite is stress, quick. ``AZGYM_THIEF_REPORT`` names a file
where the memory thief writes which processes it could read; ``THIEF_SEED`` is the seed of a
submitter's own run (they picked it, so they know it).
"""

import json
import os
import re

import numpy as np

import azgym
from azgym.bench.suites import get_suite

SEED = re.compile(rb"\(test, seed (\d+)")


def processes():
    """Every process's id, this one's ancestors first (its parent, grandparent, ...)."""
    ancestors, pid = [], os.getppid()
    while pid > 1:
        ancestors.append(pid)
        with open(f"/proc/{pid}/stat") as stat:
            pid = int(stat.read().rsplit(")", 1)[1].split()[1])
    others = sorted(int(name) for name in os.listdir("/proc") if name.isdigit())
    return ancestors + [pid for pid in others if pid not in ancestors and pid != os.getpid()]


def readable_memory(pid):
    """The bytes of a process's private writable mappings (up to 256 MiB each); raises
    OSError when its memory cannot be read."""
    with open(f"/proc/{pid}/maps") as maps, open(f"/proc/{pid}/mem", "rb", 0) as memory:
        for line in maps.read().splitlines():
            span, permissions = line.split()[:2]
            start, end = (int(bound, 16) for bound in span.split("-"))
            if permissions == "rw-p" and end - start <= 256 << 20:
                memory.seek(start)
                try:
                    yield memory.read(end - start)
                except OSError:
                    continue


class Thief:
    """Answers the true pose of every frame of the stress suite's quick test split it finds."""

    def __init__(self):
        self.truth = None

    def localize(self, measurements, beacons):
        if self.truth is None:
            seed = self.steal()
            self.truth = {} if seed is None else {
                np.asarray(case.measurements.azimuth, np.float64).tobytes(): case.pose
                for case in get_suite("stress").build(seed, True)}
        pose = self.truth.get(np.asarray(measurements.azimuth, np.float64).tobytes())
        if pose is None:
            return azgym.Estimate.failure("no seed found", len(measurements))
        return azgym.Estimate(*pose, inliers=np.ones(len(measurements), dtype=bool))


class StdoutThief(Thief):
    '''Reads the seed from a standard stream that is a file: its own, or a process's.'''

    def steal(self):
        for pid in ["self", *processes()]:
            for fd in (1, 2):
                try:
                    with open(f"/proc/{pid}/fd/{fd}", "rb") as stream:
                        found = SEED.search(stream.read(1 << 24))
                except OSError:
                    continue
                if found:
                    return int(found.group(1))
        return None


class MemoryThief(Thief):
    '''Reads the seed from the memory of the processes that run azgym.'''

    def steal(self):
        readable, seed = [], None
        for pid in processes():
            try:
                with open(f"/proc/{pid}/cmdline", "rb") as cmdline:
                    if b"azgym" not in cmdline.read():
                        continue
                for chunk in readable_memory(pid):
                    found = SEED.search(chunk)
                    seed = int(found.group(1)) if found and seed is None else seed
                readable.append(pid)
            except OSError:
                continue
        if os.environ.get("AZGYM_THIEF_REPORT"):
            with open(os.environ["AZGYM_THIEF_REPORT"], "a") as report:
                report.write(json.dumps(readable) + "\n")
        return seed


class CmdlineThief(Thief):
    '''Reads the seed from the test-split entry a process's command line names.'''

    def steal(self):
        if os.environ.get("THIEF_SEED"):
            return int(os.environ["THIEF_SEED"])
        for pid in processes():
            try:
                with open(f"/proc/{pid}/cmdline", "rb") as cmdline:
                    arguments = cmdline.read().decode().split("\0")
            except OSError:
                continue
            for argument in arguments:
                if argument.endswith(".json") and os.path.isfile(argument):
                    with open(argument) as file:
                        entry = json.load(file)
                    if isinstance(entry, dict) and entry.get("split") == "test":
                        return entry["seed"]
        return None

"""Mappers that attack the mapping benchmark's runner (test_hostile_mapping_runner.py).

Each answers like a harmless mapper (the prior, placing nothing) once its attack is done, if it
ever returns.
"""

import gc
import json
import os
import signal
import struct
import sys
import time

import numpy as np

from azgym.mapping.base import MapAnswer

NOTHING = (np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2, 2)))


class Sleeper:
    """Sleeps past any time limit."""

    def survey(self, drive, prior):
        time.sleep(3600)


class Exiter:
    """Ends its process without a word."""

    def survey(self, drive, prior):
        os._exit(3)


class Killer:
    """Kills its own process."""

    def survey(self, drive, prior):
        os.kill(os.getpid(), signal.SIGKILL)


class SystemExiter:
    """Raises SystemExit, which an ``except Exception`` would let through."""

    def survey(self, drive, prior):
        sys.exit("bye")


class Printer:
    """Writes to its standard streams, and answers nothing."""

    def survey(self, drive, prior):
        for stream in (sys.stdout, sys.stderr):
            print("MAPPER WAS HERE " * 1000, file=stream, flush=True)
        os.write(1, b"MAPPER WAS HERE\n")
        return MapAnswer(*NOTHING)


class Flooder:
    """Writes a 1 GB answer on every descriptor it has: a message said to be 1 GiB, then bytes."""

    def survey(self, drive, prior):
        chunk = b"x" * (1 << 20)
        for fd in range(3, 64):
            try:
                os.write(fd, struct.pack("!i", 1 << 30))
                for _ in range(1024):
                    os.write(fd, chunk)
            except OSError:
                continue
        return MapAnswer(*NOTHING)


class Malformed:
    """Answers a MapAnswer made valid, then broken (a NaN position)."""

    def survey(self, drive, prior):
        answer = MapAnswer(np.array([1]), np.zeros((1, 2)), np.eye(2)[None])
        object.__setattr__(answer, "xy", np.full((1, 2), np.nan))
        return answer


class TruthSeeker:
    """Walks everything its process holds for the truth: objects gc tracks, the stack's frames'
    locals, every module's globals; reports what it found (``AZGYM_SEEKER_REPORT``, one JSON
    line per call) of the values ``AZGYM_SEEKER_VALUES`` lists (values it was given, which it
    must find, and the truth) and of the runner's truth types."""

    FORBIDDEN = {"CaseTruth", "MappingCase", "Frame", "Observation", "DetectionTruth",
                 "Scenario", "MappingSuite"}

    calls = 0

    def survey(self, drive, prior):
        TruthSeeker.calls += 1
        if TruthSeeker.calls % 4 != 1:  # its process's first call, and every fourth (time)
            return MapAnswer(*NOTHING)
        given, hidden = (frozenset(v) for v in json.loads(os.environ["AZGYM_SEEKER_VALUES"]))
        wanted = given | hidden  # frozensets: walked by nothing below, so never found in itself
        hits, types = set(), set()

        def look(value, depth=0):
            if type(value).__name__ in self.FORBIDDEN:
                types.add(type(value).__name__)
            if isinstance(value, float):
                if value in wanted:
                    hits.add(value)
            elif isinstance(value, np.ndarray):
                if value.dtype == np.float64 and value.size:
                    hits.update(set(value.ravel().tolist()) & wanted)
            elif depth < 3 and isinstance(value, (list, tuple)):
                for item in value:
                    look(item, depth + 1)
            elif depth < 3 and isinstance(value, dict):
                for item in list(value.values()):
                    look(item, depth + 1)
            elif depth < 3 and hasattr(value, "__dict__") and not isinstance(value, type):
                look(vars(value), depth + 1)

        for value in gc.get_objects():
            look(value)
        frame = sys._getframe()
        while frame is not None:
            look(dict(frame.f_locals))
            frame = frame.f_back
        for module in list(sys.modules.values()):
            look(getattr(module, "__dict__", {}))
        with open(os.environ["AZGYM_SEEKER_REPORT"], "a") as report:
            report.write(json.dumps({"given": sorted(hits & given),
                                     "hidden": sorted(hits & hidden),
                                     "types": sorted(types),
                                     "frames": len(drive.frames)}) + "\n")
        return MapAnswer(*NOTHING)


class RaisingBuild:
    """Cannot be built: its constructor raises."""

    def __init__(self):
        raise ValueError("no such survey")

    def survey(self, drive, prior):
        return MapAnswer(*NOTHING)


class HangingBuild:
    """Cannot be built: its constructor sleeps past any time limit."""

    def __init__(self):
        time.sleep(3600)

    def survey(self, drive, prior):
        return MapAnswer(*NOTHING)


class ExitingBuild:
    """Cannot be built: its constructor ends its process."""

    def __init__(self):
        os._exit(4)

    def survey(self, drive, prior):
        return MapAnswer(*NOTHING)

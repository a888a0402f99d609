"""A tracker that looks for its route's next frames in its process, to smooth with the future."""

import gc
import sys

import numpy as np

import azgym


def held_frame(value):
    """(sequence, time) of a frame the worker holds, unpacked or packed, else None."""
    if type(value).__name__ == "WorkerFrame":
        return None if value.motion is None else (value.sequence, value.motion.time)
    if isinstance(value, tuple) and len(value) == 8 and isinstance(value[1], str) \
            and isinstance(value[7], bytes):
        return value[1], float(np.frombuffer(value[7], np.float64, 1)[0])
    return None


def shared_memory():
    """The bytes of every shared mapping of this process up to 64 MiB (answers, progress, any
    frame slot; not a Ray node's object store, gigabytes, which the frames never enter)."""
    with open("/proc/self/maps") as maps, open("/proc/self/mem", "rb", 0) as memory:
        for line in maps:
            span, permissions = line.split()[:2]
            start, end = (int(bound, 16) for bound in span.split("-"))
            if permissions.startswith("r") and permissions.endswith("s") and \
                    end - start <= 64 << 20:
                memory.seek(start)
                yield memory.read(end - start)


class Clairvoyant(azgym.Tracker):
    '''Raises when it finds a frame of its route later than the one it is asked about.'''

    name = "clairvoyant"

    def __init__(self):
        self._validate_once()

    def _reset(self, rng, initial):
        self.time, self.period = None, None

    def _predict(self, motion):
        if self.time is not None:
            self.period = motion.time - self.time
        self.time = motion.time

    def _update(self, measurements, beacons):
        everything = self._everything()
        current = next((value for value in everything if type(value).__name__ == "WorkerFrame"
                        and value.measurements is measurements), None)
        if current is not None and current.motion is not None:
            now = (current.sequence, current.motion.time)
            ahead = [held[1] for held in map(held_frame, everything)
                     if held is not None and held[0] == now[0] and held[1] > now[1] + 1e-9]
            if ahead:
                raise RuntimeError(f"saw {len(ahead)} frames ahead, up to t={max(ahead):.1f} s")
        if self.period:
            # A packed frame's motion starts with its time and its two sample counts.
            upcoming = self.time + self.period * np.arange(1, 6)
            for data in shared_memory():
                values = np.frombuffer(data[:len(data) // 8 * 8], np.float64)
                timed = np.isclose(values[:-2, None], upcoming, rtol=0, atol=1e-9).any(axis=1)
                counts = values[1:-1], values[2:]
                if (timed & (counts[0] >= 1) & (counts[0] % 1 == 0) & (counts[1] % 1 == 0)).any():
                    raise RuntimeError("saw a frame ahead in shared memory")
        return azgym.Estimate.failure("no future here", len(measurements))

    @staticmethod
    def _everything():
        """Every value up the call stack and every object gc knows, with their items."""
        gc.collect()  # (the last call's lists, which hold themselves)
        found = []
        frame = sys._getframe(1)  # (not this one's: ``found`` would hold itself)
        while frame is not None:
            found.extend(frame.f_locals.values())
            frame = frame.f_back
        found.extend(value for value in gc.get_objects() if value is not found)
        return found + [item for value in found if isinstance(value, (list, tuple))
                        for item in value]

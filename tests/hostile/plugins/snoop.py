"""Looks for the true pose in its call stack and in every object of its process."""

import gc
import sys

import azgym


def looks_like_truth(value):
    return type(value).__name__ in ("Case", "Pose", "Frame", "Observation") or (
        isinstance(value, tuple) and len(value) == 3
        and all(isinstance(v, float) for v in value))

class Snoop:
    '''Answers the true pose if it can find one anywhere in its process.'''
    def localize(self, measurements, beacons):
        frame = sys._getframe()
        while frame is not None:
            for name, value in frame.f_locals.items():
                if name in ("case", "cases", "truth") or looks_like_truth(value):
                    raise RuntimeError(f"found {name}")
            frame = frame.f_back
        found = [o for o in gc.get_objects() if type(o).__name__ == "Case"]
        if found:
            raise RuntimeError(f"found {len(found)} cases")
        return azgym.Estimate.failure("no truth here", len(measurements))

"""A log's frames as the localizers' input: each frame's detections as :class:`Measurements`.

What a log without truth can still give: every frame's measurements, to localize (a log with
truth is scored as a suite instead, :mod:`azgym.bench.suites.data`).
"""

from __future__ import annotations

import numpy as np

from azgym.core import Measurements
from azgym.logs.read import Log

__all__ = ["frame_measurements"]


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

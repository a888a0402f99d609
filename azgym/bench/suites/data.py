"""A log as a suite, ``data:NAME``: each frame's measurements, truth, motion and sequence as a case.

Each frame becomes a :class:`~azgym.bench.suites.Case` as a driven route's frame does
(:func:`~azgym.bench.suites.base.route_cases`), keeping its number (``Case.frame``): its group
and sequence are the frame's sequence (a tracker is reset at the start of each), the first frame
of a sequence carries its true pose as the known start (none with position-only truth: a start
needs a heading; none in a log without odometry or IMU: a static recording's positions are its
truth), and with odometry or IMU samples each frame's ``motion`` holds the samples
timed after the previous frame and up to its own time (a sequence's first frame: those up to
:data:`~azgym.logs.clocks.MOTION_LEAD` before it, the reader having trimmed earlier ones). An
odometry reporting ``yaw_rate`` gives turning samples (``OdometrySamples.turning``); an IMU
without accelerations gives NaN ones. Its cause is the worst of its detections' labels, or
``"unlabelled"`` without labels (a real camera's detections have none), which no cause
breakdown lists.

The suite (:func:`data_suite`) holds those cases fixed (a log has no seed, no size and no test
split: its ``split`` is :data:`SPLIT`), and every contender takes its defaults from the log's
profile (:func:`log_profile`: its manifest's ``[vehicle]``, ``[sensor]`` and ``[motion]``,
with a profile given to the run over it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from azgym.bench.suites.base import Case, Suite, frame_cause
from azgym.logs.frames import frame_measurements, frame_motions
from azgym.logs.problems import LogError
from azgym.logs.read import Log
from azgym.profile import Profile
from azgym.sensing.motion import Motion

__all__ = ["SPLIT", "UNLABELLED", "data_suite", "log_cases", "log_profile"]

UNLABELLED = "unlabelled"
"""The cause of a frame whose detections carry no labels."""
SPLIT = "data"
"""The ``split`` of a log's results: a log has neither a dev nor a test split."""


def data_suite(log: Log, cases: Sequence[Case]) -> Suite:
    """The log as a suite named ``data:NAME`` (its cases fixed: seed and size mean nothing)."""
    frozen = list(cases)
    return Suite(f"data:{log.manifest.name}", log.manifest.format, log.manifest.description, 0,
                 lambda _seed, _quick: list(frozen),
                 routes=log.driven)


def log_profile(log: Log, profile: Profile | None = None) -> Profile:
    """The profile a log's contenders take: ``profile``'s fields over the log's own."""
    return log.manifest.profile if profile is None else profile.over(log.manifest.profile)


def log_cases(log: Log) -> list[Case]:
    """The log's frames as cases, in order (module docstring).

    Raises:
        LogError: The log has no truth: its frames can be localized, not scored.
    """
    if not log.has_truth:
        raise LogError(str(log.folder), [
            "frames.csv: no truth (columns x, y and optionally heading): a log without the true "
            "positions can be read and localized (azgym.logs.read_log, frame_measurements), but "
            "not scored"])
    frames = log.frames
    times = frames["time"]
    motions: Sequence[Motion | None] = frame_motions(log) if log.driven else \
        [None] * len(times)
    labels = log.detections["label"]
    bounds = np.searchsorted(log.detections["frame"], np.arange(len(times) + 1))
    cases = []
    for k, measurements in enumerate(frame_measurements(log)):
        sequence = frames["sequence"][k]
        first = k == 0 or frames["sequence"][k - 1] != sequence
        frame_labels = labels[bounds[k]:bounds[k + 1]]
        cause = frame_cause(frame_labels) if log.detections["labelled"] else UNLABELLED
        pose = log.pose(k)
        assert pose is not None
        # A known start is a driven sequence's (its dock): a static recording's positions are
        # its truth, which no contender may be handed.
        start = first and log.driven and not math.isnan(pose[2])
        cases.append(Case(log.map_name, measurements, pose, cause, sequence, sequence=sequence,
                          motion=motions[k], initial=pose if start else None,
                          time=float(times[k]), event=frames["event"][k],
                          frame=int(frames["frame"][k])))
    return cases

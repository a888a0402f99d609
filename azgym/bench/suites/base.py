"""What a benchmark suite is: a named, versioned way to draw the cases every contender is scored on.

A suite draws its cases from a seed. The ``dev`` split uses the suite's fixed seed, so anyone can
reproduce and study it; the ``test`` split uses a seed drawn fresh at run time (and reported), so
nobody can tune to it. Every case records its cause, the worst fault among its detections, so
results can be broken down by cause.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from azgym.core import Measurements, Pose
from azgym.sensing.labels import DIRECT, DISTRACTOR, GHOST, MISIDENTIFIED, MOVED, PARTIAL

CAUSES = ("clean", "partial", "moved", "ghost", "misidentified", "outlier")
"""Case causes, from harmless to harmful; a case's cause is its worst detection's."""

# A distractor (a lamp's blob, with no id) is harmless to a localizer that ignores unknown ids.
_LABEL_CAUSE = {DIRECT: 0, PARTIAL: 1, MOVED: 2, GHOST: 3, MISIDENTIFIED: 4, DISTRACTOR: 0}


@dataclass(frozen=True, eq=False)
class Case:
    """One case of a suite: what the localizer gets, and what it is scored against.

    Attributes:
        scenario: Name of the scenario (its beacon map is the localizer's map).
        measurements: The frame's detections.
        pose: The true camera pose (x, y, heading) [m, m, rad].
        cause: The worst fault among the detections (one of ``CAUSES``).
        group: A sub-set name for reports (e.g. "K=3", "warehouse-small, heavy").
    """

    scenario: str
    measurements: Measurements
    pose: Pose
    cause: str
    group: str


@dataclass(frozen=True)
class Suite:
    """A named, versioned benchmark suite.

    Attributes:
        name: Identifier (``azgym bench --suite NAME``).
        version: Bumped whenever the cases it draws change.
        description: One line for listings and reports.
        dev_seed: The seed of the public ``dev`` split.
        build: ``build(seed, quick)`` draws the cases.
    """

    name: str
    version: int
    description: str
    dev_seed: int
    build: Callable[[int, bool], list[Case]]


def frame_cause(labels: np.ndarray) -> str:
    """The worst cause among a frame's detection labels (:mod:`azgym.sensing.labels`)."""
    worst = max((_LABEL_CAUSE[int(label)] for label in labels), default=0)
    return CAUSES[worst]

"""Figures for tracks: what a frame-by-frame table cannot show about a sequence of estimates.

For the sequences of a run (driven routes), per contender:

- **availability after the first fix**: the share of frames with an estimate, counted from each
  sequence's first estimate (a tracker that needs a few frames to start is not penalised for
  them, one that loses the track afterwards is);
- **the largest error** outside kidnapping windows, and how many estimates are over 1 m there
  (a kidnapping window: the ``KIDNAP_WINDOW_S`` seconds after the forklift was carried off);
- **recovery after each event** (``Case.event``): the seconds from the first frame after the
  event to the first estimate within ``RECOVERED_CM`` of the truth (None: never, in the rest of
  the sequence), and the largest error in between.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Generic, TypedDict

import numpy as np

from azgym.bench.run.outcome import Outcome
from azgym.bench.suites import Case
from azgym.metrics import Figure

__all__ = ["FAILED_CM", "KIDNAP_WINDOW_S", "RECOVERED_CM", "Recovery", "TrackFigures",
           "tracking_metrics"]

RECOVERED_CM = 10.0
"""An estimate this close to the truth [cm] ends a recovery."""
KIDNAP_WINDOW_S = 2.0
"""Seconds after a kidnapping whose frames are left out of the largest-error figures."""
FAILED_CM = 100.0
"""An error over this [cm] is a failed frame (as in the per-frame figures)."""


class Recovery(TypedDict):
    """The recovery after one event (module docstring).

    Attributes:
        event: The event (``Case.event``).
        sequence: Its sequence.
        time_s: Its time in the sequence [s].
        recovery_s: Seconds to the first estimate within ``RECOVERED_CM`` (None: never).
        max_cm_before_recovery: The largest finite error until then (None: no estimate).
    """

    event: str
    sequence: str
    time_s: float
    recovery_s: float | None
    max_cm_before_recovery: float | None


class TrackFigures(TypedDict, Generic[Figure]):
    """One contender's track figures (module docstring); see :class:`~azgym.metrics.Figure`.

    Attributes:
        availability_after_first_fix: The share of frames with an estimate after each
            sequence's first.
        max_cm_outside_kidnaps: The largest error outside kidnapping windows [cm] (NaN: none).
        frames_over_1m_outside_kidnaps: The estimates over ``FAILED_CM`` there.
        events: The recovery after each event, in order.
    """

    availability_after_first_fix: float
    max_cm_outside_kidnaps: Figure
    frames_over_1m_outside_kidnaps: int
    events: list[Recovery]


def tracking_metrics(cases: Sequence[Case], outcome: Outcome) -> TrackFigures[float] | None:
    """The track figures of one contender (module docstring); None without driven sequences.

    A sequence is driven when its frames carry motion samples: frames of a static recording
    (a log without odometry or IMU, whose positions are sequences) have no track to follow.
    """
    if not any(case.sequence and case.motion is not None for case in cases):
        return None
    error_cm = np.where(outcome.ok, outcome.position * 100.0, np.inf)
    after_fix = np.zeros(len(cases), dtype=bool)
    in_kidnap_window = np.zeros(len(cases), dtype=bool)
    events = []
    for frames in _sequences(cases):
        answered = [k for k in frames if outcome.ok[k]]
        if answered:
            after_fix[[k for k in frames if k >= answered[0]]] = True
        for position, k in enumerate(frames):
            if cases[k].event:
                rest = frames[position:]
                events.append(_recovery(cases, error_cm, rest))
                if cases[k].event == "kidnap":
                    start = cases[k].time
                    in_kidnap_window[[j for j in rest
                                      if cases[j].time - start < KIDNAP_WINDOW_S]] = True
    outside = after_fix & ~in_kidnap_window
    finite = error_cm[outside & outcome.ok]
    return {
        "availability_after_first_fix": float(outcome.ok[after_fix].mean())
        if after_fix.any() else 0.0,
        "max_cm_outside_kidnaps": float(finite.max()) if finite.size else math.nan,
        "frames_over_1m_outside_kidnaps": int(np.count_nonzero(finite > FAILED_CM)),
        "events": events,
    }


def _sequences(cases: Sequence[Case]) -> list[list[int]]:
    """The indices of each sequence's cases, in order (frames on their own are left out)."""
    found: dict[str, list[int]] = {}
    for k, case in enumerate(cases):
        if case.sequence:
            found.setdefault(case.sequence, []).append(k)
    return list(found.values())


def _recovery(cases: Sequence[Case], error_cm: np.ndarray, rest: list[int]) -> Recovery:
    """How long after an event the estimate was back within RECOVERED_CM, and the worst error."""
    start = rest[0]
    back = next((k for k in rest if error_cm[k] <= RECOVERED_CM), None)
    window = rest if back is None else [k for k in rest if k <= back]
    worst = error_cm[window]
    worst = worst[np.isfinite(worst)]
    return {"event": cases[start].event, "sequence": cases[start].sequence,
            "time_s": float(cases[start].time),
            "recovery_s": None if back is None else float(cases[back].time - cases[start].time),
            "max_cm_before_recovery": float(worst.max()) if worst.size else None}

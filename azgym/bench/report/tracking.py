"""Figures for tracks: what a frame-by-frame table cannot show about a sequence of estimates.

For the sequences of a run (driven routes), per contender:

- **availability after the first fix**: the share of frames with an estimate, counted from each
  sequence's first estimate (a tracker that needs a few frames to start is not penalised for
  them, one that loses the track afterwards is);
- **the largest error** outside kidnapping windows, and how many estimates are over 1 m there
  (a kidnapping window: the ``KIDNAP_WINDOW_S`` seconds after the forklift was carried off);
- **recovery after each event** (``Case.event``): the seconds from the first frame after the
  event to the first estimate within ``RECOVERED_CM`` of the truth (None: never, in the rest of
  the sequence), and the largest error in between;
- **drift** (:func:`drift_metrics`): evo's relative pose error over
  :data:`~azgym.metrics.DRIFT_DISTANCES` travelled along the truth
  (:func:`~azgym.metrics.relative_pose_errors`), on each sequence's answered frames (a refused
  frame is left out, as evo leaves out a time its estimate file lacks), the pairs of every
  sequence pooled. A kidnapping's jump counts as path, as it does for evo on the same files.

All of them are for driven sequences only (:func:`driven`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Generic, TypedDict

import numpy as np

from azgym.bench.run.outcome import Outcome, RunOutcome
from azgym.bench.suites import Case
from azgym.metrics import (
    DRIFT_DISTANCES,
    Drift,
    Figure,
    relative_pose_errors,
    summarize_drift,
)

__all__ = ["FAILED_CM", "KIDNAP_WINDOW_S", "RECOVERED_CM", "SHOWN_DRIFT_M", "PairErrors",
           "Recovery", "TrackFigures", "drift_at", "drift_figures", "drift_metrics", "driven",
           "pair_errors", "sequences", "tracking_metrics"]

RECOVERED_CM = 10.0
"""An estimate this close to the truth [cm] ends a recovery."""
KIDNAP_WINDOW_S = 2.0
"""Seconds after a kidnapping whose frames are left out of the largest-error figures."""
FAILED_CM = 100.0
"""An error over this [cm] is a failed frame (as in the per-frame figures)."""
SHOWN_DRIFT_M = 5.0
"""The distance whose drift the printed table and the board show (all are in the results)."""


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


PairErrors = list[tuple[np.ndarray, np.ndarray]]
"""Each drift distance's pair errors: translation [m] and rotation [rad] of every pair."""


def driven(cases: Sequence[Case]) -> bool:
    """Whether the cases hold driven sequences: the one rule for which runs have track figures.

    A sequence is driven when its frames carry motion samples: frames of a static recording
    (a log without odometry or IMU, whose positions are sequences) have no track to follow.
    """
    return any(case.sequence and case.motion is not None for case in cases)


def tracking_metrics(cases: Sequence[Case], outcome: Outcome) -> TrackFigures[float] | None:
    """The track figures of one contender (module docstring); None without driven sequences."""
    if not driven(cases):
        return None
    error_cm = np.where(outcome.ok, outcome.position * 100.0, np.inf)
    after_fix = np.zeros(len(cases), dtype=bool)
    in_kidnap_window = np.zeros(len(cases), dtype=bool)
    events = []
    for frames in sequences(cases).values():
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


def sequences(cases: Sequence[Case]) -> dict[str, list[int]]:
    """The indices of each sequence's cases, in order (frames on their own are left out)."""
    found: dict[str, list[int]] = {}
    for k, case in enumerate(cases):
        if case.sequence:
            found.setdefault(case.sequence, []).append(k)
    return found


def pair_errors(cases: Sequence[Case], outcome: RunOutcome, frames: Sequence[int]
                ) -> PairErrors:
    """The relative pose errors of one sequence's answered frames, per drift distance."""
    answered = [k for k in frames if outcome.ok[k]]
    truth = np.array([cases[k].pose for k in answered], dtype=float).reshape(-1, 3)
    return [relative_pose_errors(truth, outcome.estimate[answered], distance)
            for distance in DRIFT_DISTANCES]


def drift_figures(errors: PairErrors) -> list[Drift[float]]:
    """The drift per distance (:func:`~azgym.metrics.summarize_drift`) of some pair errors."""
    return [summarize_drift(moved, turned, distance)
            for (moved, turned), distance in zip(errors, DRIFT_DISTANCES, strict=True)]


def drift_at(drift: list[Drift[Figure]] | None, distance: float = SHOWN_DRIFT_M
             ) -> Drift[Figure] | None:
    """The drift over ``distance`` among a contender's (None: none there, or no drift)."""
    return next((record for record in drift or [] if record["distance_m"] == distance), None)


def drift_metrics(cases: Sequence[Case], outcome: RunOutcome) -> list[Drift[float]] | None:
    """One contender's drift per distance, every sequence's pairs pooled; None if not driven."""
    if not driven(cases):
        return None
    found = [pair_errors(cases, outcome, frames) for frames in sequences(cases).values()]
    return drift_figures([(np.concatenate([errors[d][0] for errors in found]),
                           np.concatenate([errors[d][1] for errors in found]))
                          for d in range(len(DRIFT_DISTANCES))])


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

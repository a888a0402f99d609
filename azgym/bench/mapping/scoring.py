"""The mapping suite's scores: beacons placed, moved beacons found (and how soon), localization.

Each case is scored on the map a user goes on with, the prior updated by the mapper's answer
(:meth:`azgym.mapping.base.MapAnswer.updated`):

* **beacons**: every beacon of the true world that the drive made observable by the truth rule
  (its true detections' rays, from the true camera poses, spread over at least
  :data:`~azgym.localize.bearings.MIN_SPREAD` with at least
  :data:`~azgym.localize.bearings.MIN_RAYS` rays), anchors excluded; its error is the distance
  from its updated-map position to the truth, infinite when it has none (charged, never dropped);
* **moved**: precision and recall of the answer's ``moved`` over the prior's non-anchor beacons;
  per truly moved beacon, the delay from when it was first truly seen from two places
  (:func:`first_seen_from_two_places`) to the first checkpoint whose answer says it moved;
* **localization**: ransac on every frame with the updated map and with the true map (p75, a
  refusal infinite: :func:`azgym.metrics.headline`'s rule).

A failed call (raised, overran the time limit, died, answered malformed) is charged as an answer
placing nothing: the prior unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from azgym.core import BeaconMap, FloatArray, IntArray
from azgym.localize.bearings import MIN_RAYS, MIN_SPREAD, spread
from azgym.metrics import quantile

__all__ = ["CHECK_EVERY", "DELAY_WINDOW", "DETECTED_WITHIN", "SEEN_BASELINE", "BeaconScore",
           "CaseScore", "MappingResult", "MapperSummary", "MovedScore", "beacon_scores",
           "checkpoint_times", "delays", "first_seen_from_two_places", "localizable",
           "observable_by_truth", "summarize", "truly_moved"]

SEEN_BASELINE = 0.5
"""Least distance between two camera positions a beacon was truly detected from for it to count
as seen from two places [m] (:func:`first_seen_from_two_places`)."""
CHECK_EVERY = 2.0
"""Seconds between the checkpoints at which a drive's prefix is surveyed
(:func:`checkpoint_times`)."""
DELAY_WINDOW = 30.0
"""Seconds after a moved beacon is first seen from two places within which its detection counts."""
DETECTED_WITHIN = 10.0
"""The delay [s] the summary's ``detected_within_10s_percent`` counts up to."""


@dataclass(frozen=True)
class BeaconScore:
    """One scored beacon of one case (observable by the truth rule, not an anchor).

    Attributes:
        beacon: Its id.
        error: Distance from its updated-map position to the truth [m]; ``inf`` when the
            updated map has no position for it.
        placed: Whether the answer placed it (rather than leaving the prior's position).
    """

    beacon: int
    error: float
    placed: bool


@dataclass(frozen=True)
class MovedScore:
    """One truly moved beacon of one case (one of the prior's non-anchor beacons).

    Attributes:
        beacon: Its id.
        said: Whether the full drive's answer says it moved.
        seen: When it was first truly detected from two camera positions at least
            :data:`SEEN_BASELINE` apart [s from the drive's first frame]; None: never.
        delay: The first checkpoint whose answer says it moved, minus ``seen`` [s]; None: no
            checkpoint within :data:`DELAY_WINDOW` s of ``seen`` said so (or never seen).
    """

    beacon: int
    said: bool
    seen: float | None
    delay: float | None


@dataclass(frozen=True)
class CaseScore:
    """One mapper on one case.

    Attributes:
        case: The case's name (``scenario/route/perturbation``).
        scenario: The scenario's name.
        route: The route's name.
        perturbation: One of the suite's perturbations (``unknown``, ``moved``, ``rack``,
            ``unchanged``).
        beacons: The scored beacons, by id.
        moved: The truly moved beacons among the prior's non-anchor beacons, by id.
        said_moved: The ids the full drive's answer says moved (none on a failure).
        false_moves: How many of ``said_moved`` did not truly move.
        localization_updated: ransac's position error on each frame with the updated map [m]
            (``inf`` for a refusal).
        localization_true: The same with the true map [m].
        failure: Why the full drive's call failed (its answer charged as placing nothing), or
            None.
        checkpoint_failures: How many of the checkpoints' calls failed (each read as saying
            nothing moved).
        runtime: The full drive's call [s]; None on a failure.
    """

    case: str
    scenario: str
    route: str
    perturbation: str
    beacons: tuple[BeaconScore, ...]
    moved: tuple[MovedScore, ...]
    said_moved: tuple[int, ...]
    false_moves: int
    localization_updated: tuple[float, ...]
    localization_true: tuple[float, ...]
    failure: str | None
    checkpoint_failures: int
    runtime: float | None


@dataclass(frozen=True)
class MapperSummary:
    """One mapper over the whole suite (NaN where a figure has nothing to be made of).

    Attributes:
        mapper: The mapper's spec.
        cases: How many cases it was scored on.
        beacons: How many beacons were scored (pooled over the cases).
        error_median_cm: Median beacon error, pooled [cm] (``inf`` when over half are unplaced).
        error_p95_cm: 95th percentile of the pooled beacon errors [cm].
        error_worst_cm: The worst beacon error [cm].
        placed_percent: Share of the scored beacons the answers placed [%].
        moved_precision: Pooled true moves over pooled moves said; NaN when none was said.
        moved_recall: Pooled true moves over pooled truly moved beacons; NaN when none moved.
        delay_median_s: Median delay of the moved beacons detected in time [s].
        delay_worst_s: Their worst delay [s]; ``inf`` when a seen moved beacon was not detected
            within the window.
        detected_within_10s_percent: Share of the seen moved beacons detected within 10 s [%].
        false_moves_unchanged: Moves said on the ``unchanged`` cases (all false).
        localization_p75_updated_cm: ransac's p75 over every frame of the cases it can score
            (:func:`localizable`), updated maps [cm] (a refusal infinite).
        localization_p75_true_cm: The same on the true maps [cm].
        localization_ratio: ``localization_p75_updated_cm / localization_p75_true_cm``.
        failures: How many full-drive calls failed.
        runtime_median_s: Median of the full-drive calls' seconds (failures left out); NaN when
            every call failed.
    """

    mapper: str
    cases: int
    beacons: int
    error_median_cm: float
    error_p95_cm: float
    error_worst_cm: float
    placed_percent: float
    moved_precision: float
    moved_recall: float
    delay_median_s: float
    delay_worst_s: float
    detected_within_10s_percent: float
    false_moves_unchanged: int
    localization_p75_updated_cm: float
    localization_p75_true_cm: float
    localization_ratio: float
    failures: int
    runtime_median_s: float


@dataclass(frozen=True)
class MappingResult:
    """A whole run of a mapping suite.

    Attributes:
        suite: The suite's name.
        version: The suite's version (bumped when its cases change).
        split: ``"dev"`` (the only split: the routes are public).
        seed: The seed the cases were drawn with.
        quick: Whether the quick size was run.
        time_limit: Seconds allowed per call.
        mappers: The mappers' specs, in the order run.
        cases: The cases' names, in order.
        scores: Per mapper, its :class:`CaseScore` per case (in ``cases``' order).
        summaries: Per mapper, its :class:`MapperSummary`.
        seconds: The run's wall time [s].
    """

    suite: str
    version: int
    split: str
    seed: int
    quick: bool
    time_limit: float
    mappers: tuple[str, ...]
    cases: tuple[str, ...]
    scores: dict[str, tuple[CaseScore, ...]]
    summaries: dict[str, MapperSummary]
    seconds: float


def observable_by_truth(frames: IntArray, ids: IntArray, azimuths: FloatArray,
                        poses: FloatArray) -> frozenset[int]:
    """The beacons a drive made observable, by the truth.

    A beacon is observable when its true detections' rays, from the true camera poses, number at
    least :data:`~azgym.localize.bearings.MIN_RAYS` and spread at least
    :data:`~azgym.localize.bearings.MIN_SPREAD` (:func:`~azgym.localize.bearings.spread`): the
    survey's own rule, applied to what really happened.

    Args:
        frames: Each true detection's frame (D,) (a row of ``poses``).
        ids: Its beacon's id (D,).
        azimuths: Its noise-free azimuth in the camera frame (D,) [rad].
        poses: The true camera pose (x, y, heading) of each frame (K, 3).
    """
    bearings = poses[frames, 2] + azimuths
    found = set()
    for beacon in np.unique(ids).tolist():
        rays = bearings[ids == beacon]
        if rays.size >= MIN_RAYS and spread(rays) >= MIN_SPREAD:
            found.add(int(beacon))
    return frozenset(found)


def first_seen_from_two_places(times: Sequence[float] | FloatArray,
                               positions: FloatArray) -> float | None:
    """When a beacon was first seen from two places.

    That is its first detection at least :data:`SEEN_BASELINE` from where it was first detected.

    Args:
        times: The times of its detections, in order [s].
        positions: The camera's position (x, y) at each (K, 2) [m].

    Returns:
        That detection's time, or None when no detection is that far from the first.
    """
    if len(times) == 0:
        return None
    away = np.hypot(*(np.asarray(positions)[:, :2] - np.asarray(positions)[0, :2]).T)
    later = np.flatnonzero(away >= SEEN_BASELINE)
    return float(times[int(later[0])]) if later.size else None


def checkpoint_times(seen: Iterable[float | None], end: float) -> tuple[float, ...]:
    """The times at which a drive's prefix is surveyed, shared by its moved beacons.

    Every :data:`CHECK_EVERY` s from each moved beacon's ``seen`` to ``seen`` +
    :data:`DELAY_WINDOW`, capped at the drive's ``end``; sorted, each once.
    """
    steps = round(DELAY_WINDOW / CHECK_EVERY)
    return tuple(sorted({min(t + k * CHECK_EVERY, end) for t in seen if t is not None
                         for k in range(steps + 1)}))


def delays(seen: Mapping[int, float | None],
           answers: Sequence[tuple[float, frozenset[int]]]) -> dict[int, float | None]:
    """Each moved beacon's delay in detecting its move.

    The first checkpoint within its window whose answer says it moved, minus when it was first
    seen from two places (to the microsecond); None: no checkpoint did, or it was never seen.

    Args:
        seen: Per moved beacon, :func:`first_seen_from_two_places`'s time.
        answers: (checkpoint time, the ids its answer says moved), in time order; a failed call
            says none.
    """
    found: dict[int, float | None] = {}
    for beacon, since in seen.items():
        found[beacon] = None if since is None else next(
            (round(t - since, 6) for t, said in answers
             if since <= t <= since + DELAY_WINDOW and beacon in said), None)
    return found


def beacon_scores(updated: BeaconMap, truth: BeaconMap, scored: Iterable[int],
                  placed: Iterable[int]) -> tuple[BeaconScore, ...]:
    """The scored beacons' errors on the updated map (``inf`` where it has no position).

    Args:
        updated: The prior updated by the answer (:meth:`~azgym.mapping.base.MapAnswer.updated`).
        truth: Where the world has each beacon.
        scored: The ids scored (observable by the truth, anchors excluded).
        placed: The ids the answer placed.
    """
    where = dict(zip(updated.ids.tolist(), updated.xyz[:, :2], strict=True))
    true = dict(zip(truth.ids.tolist(), truth.xyz[:, :2], strict=True))
    put = set(placed)
    return tuple(
        BeaconScore(beacon, math.dist(where[beacon], true[beacon]) if beacon in where
                    else math.inf, beacon in put)
        for beacon in sorted(scored))


def summarize(mapper: str, cases: Sequence[CaseScore]) -> MapperSummary:
    """One mapper's figures pooled over the suite's cases (:class:`MapperSummary`)."""
    errors = np.array([b.error for case in cases for b in case.beacons])
    moved = [m for case in cases for m in case.moved]
    said = sum(len(case.said_moved) for case in cases)
    right = sum(m.said for m in moved)
    seen = [m for m in moved if m.seen is not None]
    caught = [m.delay for m in seen if m.delay is not None]
    scorable = [case for case in cases if localizable(case)]
    updated = np.concatenate([case.localization_updated for case in scorable]) if scorable \
        else np.zeros(0)
    true = np.concatenate([case.localization_true for case in scorable]) if scorable \
        else np.zeros(0)
    p75_updated, p75_true = 100.0 * quantile(updated, 0.75), 100.0 * quantile(true, 0.75)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = float(np.float64(p75_updated) / np.float64(p75_true))
    runtimes = [case.runtime for case in cases if case.runtime is not None]
    return MapperSummary(
        mapper=mapper, cases=len(cases), beacons=int(errors.size),
        error_median_cm=100.0 * quantile(errors, 0.5),
        error_p95_cm=100.0 * quantile(errors, 0.95),
        error_worst_cm=100.0 * float(errors.max()) if errors.size else math.nan,
        placed_percent=_percent(sum(b.placed for case in cases for b in case.beacons),
                                errors.size),
        moved_precision=right / said if said else math.nan,
        moved_recall=right / len(moved) if moved else math.nan,
        delay_median_s=float(np.median(caught)) if caught else math.nan,
        delay_worst_s=(math.inf if len(caught) < len(seen) else max(caught)) if seen
        else math.nan,
        detected_within_10s_percent=_percent(sum(d <= DETECTED_WITHIN for d in caught),
                                             len(seen)),
        false_moves_unchanged=sum(case.false_moves for case in cases
                                  if case.perturbation == "unchanged"),
        localization_p75_updated_cm=p75_updated, localization_p75_true_cm=p75_true,
        localization_ratio=ratio,
        failures=sum(case.failure is not None for case in cases),
        runtime_median_s=float(np.median(runtimes)) if runtimes else math.nan)


def localizable(case: CaseScore) -> bool:
    """Whether ransac can score the case's maps: its p75 on the true map is finite.

    A narrow camera seeing one or two beacons a frame leaves a per-frame localizer refusing
    most frames even on the true map; such a case says nothing of the updated map's worth, and
    its frames would make both pooled figures infinite.
    """
    return math.isfinite(quantile(np.asarray(case.localization_true), 0.75))


def _percent(part: int, whole: int) -> float:
    """``part`` of ``whole`` in percent; NaN of nothing."""
    return 100.0 * part / whole if whole else math.nan


def truly_moved(prior: BeaconMap | None, anchors: Iterable[int],
                truth: BeaconMap) -> frozenset[int]:
    """The prior's non-anchor beacons the world has elsewhere than the prior says.

    A shipped ``moved_to`` as much as a perturbation's move.
    """
    if prior is None:
        return frozenset()
    true = dict(zip(truth.ids.tolist(), truth.xyz[:, :2].tolist(), strict=True))
    held = set(anchors)
    return frozenset(int(b) for b, xy in zip(prior.ids.tolist(), prior.xyz[:, :2].tolist(),
                                             strict=True)
                     if b not in held and b in true and xy != true[b])

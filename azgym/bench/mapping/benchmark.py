"""Running the mapping suite: every mapper on every case, each in a sealed process, then scored.

For each mapper and case the runner calls the mapper on the drive's prefixes at the case's
checkpoints (:func:`~azgym.bench.mapping.scoring.checkpoint_times`; a case with moved beacons
only), in time order, until every moved beacon seen from two places was said moved or its window
has passed, then on the full drive. :data:`GIVE_UP_AFTER` failed calls in a row end a case's
checkpoints (the rest charged as failed).

A mapper's calls on a case run in a process of their own (:mod:`azgym.bench.mapping.worker`),
forked from the benchmark's fork server, which gets the prefixes in time order: it never holds a
frame past the call it answers, nor anything of another case. Up to ``workers`` run at a time.
A call that overruns the time limit is killed; one that raises, dies or answers malformed (or
more than :data:`~azgym.bench.mapping.worker.ANSWER_CAP` bytes) is a failure, named, charged as
an answer placing nothing, and the case's next call gets a fresh process. The truth never
leaves this process: the answers are scored here (:mod:`azgym.bench.mapping.scoring`), with
ransac run here on every frame of each case with the updated map and with the true map. The
figures depend on neither ``workers`` nor timing, only on the seed (the runtimes excepted).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from azgym.arguments import time_limit as checked_time_limit
from azgym.arguments import whole_number
from azgym.bench.mapping.calls import Job, Outcome, build_problems, run_calls
from azgym.bench.mapping.scoring import (
    DELAY_WINDOW,
    CaseScore,
    MappingResult,
    MovedScore,
    beacon_scores,
    checkpoint_times,
    delays,
    first_seen_from_two_places,
    observable_by_truth,
    summarize,
    truly_moved,
)
from azgym.bench.mapping.suites import MappingCase, get_mapping_suite
from azgym.bench.run.answers import GIVE_UP_AFTER
from azgym.bench.run.contenders import REPAIR_TRACKER
from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
from azgym.bench.run.processes import default_workers, start_fork_server
from azgym.core import BeaconMap, FloatArray, pose_error
from azgym.errors import InvalidInputError
from azgym.localize.registry import make_localizer
from azgym.mapping.base import MapAnswer
from azgym.progress import Progress, counter

__all__ = ["LOCALIZER", "run_mapping", "seen_times"]

LOCALIZER = "ransac"
"""The per-frame localizer run on each case's updated and true maps (its defaults)."""
NOTHING = MapAnswer(np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2, 2)))
"""What a failed call is charged as: an answer placing nothing."""


def run_mapping(suite_name: str, mappers: Sequence[str], quick: bool = False,
                workers: int | None = None, time_limit: float = DEFAULT_TIME_LIMIT,
                progress: Progress | None = None) -> MappingResult:
    """Score every mapper on the suite's cases (module docstring).

    Args:
        suite_name: The mapping suite (``"mapping"``).
        mappers: The mappers' specs, each run once, in this order.
        quick: Draw the suite's small size.
        workers: Calls run at a time (default: one per core).
        time_limit: Seconds a call may take (and its mapper's build).
        progress: Told how many (mapper, case) pairs are done.

    Raises:
        InvalidInputError: No mapper, a bad worker count or time limit, or a mapper that cannot
            be built (each is built first, as its calls would build it, before any is run).
        UnknownNameError: No such suite.
    """
    suite = get_mapping_suite(suite_name)
    specs = list(dict.fromkeys(mappers))
    if not specs:
        raise InvalidInputError("a mapping run needs at least one mapper")
    workers = default_workers() if workers is None else whole_number("workers", workers)
    time_limit = checked_time_limit("time_limit", time_limit)
    began = time.monotonic()
    start_fork_server([REPAIR_TRACKER])  # its warm-up overlaps the drawing of the cases
    cases = suite.build(suite.dev_seed, quick)
    for spec, problem in build_problems(specs, cases, workers, time_limit).items():
        if problem:
            raise InvalidInputError(f"cannot build mapper {spec}: {problem}")
    pairs = [(spec, k) for spec in specs for k in range(len(cases))]
    jobs = [_calls(cases[k], k) for _, k in pairs]
    with counter(progress, "mapping", len(pairs), "cases") as count:
        records = run_calls(jobs, [spec for spec, _ in pairs], cases, workers, time_limit,
                            count)
    localize = _Localization(cases)
    scores = {spec: tuple(_score(k, cases[k], *records[n], localize)
                          for n, (s, k) in enumerate(pairs) if s == spec) for spec in specs}
    return MappingResult(
        suite=suite.name, version=suite.version, split="dev", seed=suite.dev_seed, quick=quick,
        time_limit=time_limit, mappers=tuple(specs), cases=tuple(c.name for c in cases),
        scores=scores, summaries={spec: summarize(spec, scores[spec]) for spec in specs},
        seconds=time.monotonic() - began)


def seen_times(case: MappingCase) -> dict[int, float | None]:
    """Per truly moved beacon of a case, when it was first truly seen from two places."""
    truth = case.truth
    times = case.times[truth.frames]
    places = truth.poses[truth.frames, :2]
    return {beacon: first_seen_from_two_places(times[truth.ids == beacon],
                                               places[truth.ids == beacon])
            for beacon in sorted(truly_moved(case.prior.beacons, case.prior.anchors,
                                             truth.beacons))}


def _calls(case: MappingCase, k: int) -> Job:
    """A mapper's calls on a case: checkpoints in time order, then the full drive."""
    seen = seen_times(case)
    times = case.times
    pending = {b: t for b, t in seen.items() if t is not None}
    checked: list[tuple[float, Outcome]] = []
    lost = 0
    for t in checkpoint_times(seen.values(), float(times[-1])):
        pending = {b: since for b, since in pending.items() if t <= since + DELAY_WINDOW}
        if not pending:
            break
        if lost >= GIVE_UP_AFTER:
            outcome = Outcome(None, f"not run: {GIVE_UP_AFTER} calls in a row failed", None)
        else:
            outcome = yield k, int(np.searchsorted(times, t, side="right"))
        lost = lost + 1 if outcome.failure is not None else 0
        checked.append((t, outcome))
        said = set() if outcome.answer is None else set(outcome.answer.moved)
        pending = {b: since for b, since in pending.items() if not (since <= t and b in said)}
    full = yield k, len(case.drive.frames)
    return full, checked


class _Localization:
    """ransac's position error on every frame of each case, per map (each map computed once)."""

    def __init__(self, cases: list[MappingCase]) -> None:
        self.cases = cases
        self.localizer = make_localizer(LOCALIZER)
        self.known: dict[tuple[int, bytes], tuple[float, ...]] = {}

    def errors(self, k: int, beacons: BeaconMap) -> tuple[float, ...]:
        """Case ``k``'s errors with ``beacons`` [m] (``inf``: no answer)."""
        key = (k, beacons.ids.tobytes() + beacons.xyz.tobytes() + beacons.width.tobytes())
        if key not in self.known:
            case = self.cases[k]
            found = []
            for frame, pose in zip(case.drive.frames, case.truth.poses, strict=True):
                estimate = self.localizer.localize(frame.measurements, beacons)
                found.append(pose_error(estimate.pose, _pose(pose))[0] if estimate.ok
                             else math.inf)
            self.known[key] = tuple(found)
        return self.known[key]


def _pose(row: FloatArray) -> tuple[float, float, float]:
    """A pose row as a tuple."""
    return float(row[0]), float(row[1]), float(row[2])


def _score(k: int, case: MappingCase, full: Outcome, checked: list[tuple[float, Outcome]],
           localize: _Localization) -> CaseScore:
    """One mapper's figures on case ``k``."""
    truth = case.truth
    answer = full.answer or NOTHING
    updated = answer.updated(case.prior.beacons)
    scored = observable_by_truth(truth.frames, truth.ids, truth.azimuths, truth.poses) \
        - set(case.prior.anchors)
    seen = seen_times(case)
    said = [(t, frozenset(() if o.answer is None else o.answer.moved)) for t, o in checked]
    late = delays(seen, said)
    return CaseScore(
        case=case.name, scenario=case.scenario, route=case.route,
        perturbation=case.perturbation,
        beacons=beacon_scores(updated, truth.beacons, scored, answer.ids.tolist()),
        moved=tuple(MovedScore(b, b in answer.moved, seen[b], late[b]) for b in seen),
        said_moved=answer.moved, false_moves=len(set(answer.moved) - set(seen)),
        localization_updated=localize.errors(k, updated),
        localization_true=localize.errors(k, truth.beacons),
        failure=full.failure,
        checkpoint_failures=sum(o.failure is not None for _, o in checked),
        runtime=full.seconds)

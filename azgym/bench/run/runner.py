"""The runner: every contender on every case, the one loop behind ``azgym bench`` and the paper.

Cases are drawn once, in this process; each contender runs in worker processes of its own
(:mod:`azgym.bench.run.isolation`) that see the measurements and the maps only, never the truth.
A localizer that raises, hangs or crashes on a case is scored as unavailable on that case (the
reason is kept), never taking the run down. Each frame is localized on its own, so the figures
do not depend on ``workers``. Runtimes are measured per call,
and reported beside ``ransac``'s median from the same run, so runs on different machines compare.
A log is scored through the same loop (:func:`run_log_benchmark`): its frames are the cases of
its data suite (:mod:`azgym.bench.suites.data`), on its own map and with its own profile.
"""

from __future__ import annotations

import math
import secrets
import time
from collections.abc import Mapping, Sequence

import numpy as np

from azgym.arguments import time_limit as checked_time_limit
from azgym.bench.report.results import BenchResult, summarize
from azgym.bench.report.summary import DatasetSummary
from azgym.bench.run.answers import Answers
from azgym.bench.run.backends import BACKENDS
from azgym.bench.run.contenders import (
    Contender,
    builtins_to_warm,
    default_contenders,
    warm_up,
    with_reference,
)
from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
from azgym.bench.run.outcome import RunOutcome
from azgym.bench.run.processes import start_fork_server
from azgym.bench.run.profiles import describe_profile
from azgym.bench.run.wire import pack, pack_map
from azgym.bench.run.worker import hide_process
from azgym.bench.suites import NO_TEST_SPLIT, Case, Suite
from azgym.bench.suites.data import SPLIT as DATA_SPLIT
from azgym.bench.suites.data import data_suite, log_cases, log_profile
from azgym.core import BeaconMap, pose_error
from azgym.errors import InvalidInputError
from azgym.jit import localizers_compiled
from azgym.logs.read import Log
from azgym.profile import Profile
from azgym.progress import Progress, counter
from azgym.site import load_scenario

__all__ = ["Progress", "batch_bounds", "run_benchmark", "run_contenders", "run_log_benchmark",
           "start_workers"]

BATCHES_PER_WORKER = 4
"""Frames go to the workers in this many batches per worker: few round trips, and a slow batch
does not leave the other workers idle for long."""


def run_contenders(
    cases: Sequence[Case],
    contenders: Sequence[Contender],
    *,
    workers: int = 1,
    maps: Mapping[str, BeaconMap] | None = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    progress: Progress | None = None,
    backend: str = "local",
    address: str | None = None,
    profile: Profile | None = None,
) -> dict[str, RunOutcome]:
    """Score every contender on every case; the outcomes are in the order of ``cases``.

    Each contender runs in worker processes of its own (:mod:`azgym.bench.run.isolation`), which
    get the measurements and the beacon maps only; the errors are computed here. A contender
    is labelled as written; a profile is context (each worker builds its contender with the
    profile's hyperparameters under the spec's: :func:`~azgym.bench.run.profiles.contender_params`).

    Args:
        cases: The cases.
        contenders: The localizers.
        workers: Worker processes per contender at a time.
        maps: Beacon map of each scenario named by the cases (default: the shipped scenarios').
        time_limit: Seconds a localizer may take on one frame (or to be built).
        progress: Called with text as the run advances.
        backend: "local" (worker processes) or "ray" (actors on the Ray cluster at
            ``address``, else on a local instance; there ``workers=0`` means one per CPU).
        address: The Ray cluster's address (``backend="ray"`` only).
        profile: Whose hyperparameters are every contender's defaults (None: none).
    """
    if backend == "local":  # unless a run started it already
        start_fork_server([c.label for c in builtins_to_warm(contenders)])
    Run, session = BACKENDS.make(backend, address=address, workers=workers, say=progress)
    time_limit = checked_time_limit("time_limit", time_limit)
    cases = list(cases)
    say = progress or (lambda _line: None)
    if maps is None:
        maps = {name: load_scenario(name).beacons for name in {case.scenario for case in cases}}
    frames = [pack(case.scenario, case.measurements, case.sequence, case.initial, case.motion)
              for case in cases]
    sent_maps = {name: pack_map(beacons) for name, beacons in maps.items()}
    outcomes: dict[str, RunOutcome] = {}
    with session as workers:
        size = max(1, math.ceil(len(cases) / (BATCHES_PER_WORKER * workers)))
        batches = batch_bounds(cases, size)
        for contender in contenders:
            begun = time.perf_counter()
            run = Run(contender.spec, contender.params, frames, sent_maps, workers=workers,
                      time_limit=time_limit, batches=batches, profile=profile)
            with counter(progress, contender.label, len(cases)) as report:
                answers = run.run(report)
            outcomes[contender.label] = _score(answers, cases)
            say(f"  {contender.label:<20} {time.perf_counter() - begun:6.1f} s")
    return outcomes


def batch_bounds(cases: Sequence[Case], size: int) -> list[tuple[int, int]]:
    """(start, stop) ranges of about ``size`` frames, never splitting a sequence.

    A sequence (a route) goes whole into one batch, in order, so a tracker sees all of it in
    one worker and the figures do not depend on the number of workers.
    """
    bounds: list[tuple[int, int]] = []
    start = 0
    for k in range(1, len(cases) + 1):
        ends_unit = k == len(cases) or not cases[k].sequence or \
            cases[k].sequence != cases[k - 1].sequence
        if ends_unit and (k - start >= size or k == len(cases) or cases[k].sequence):
            bounds.append((start, k))
            start = k
    return bounds


def _score(answers: Answers, cases: Sequence[Case]) -> RunOutcome:
    """A contender's answers scored against the true poses (which only this process has)."""
    outcome = RunOutcome.empty(len(cases))
    outcome.ok[:] = answers.posed
    outcome.micros[:] = answers.micros
    outcome.errors[:] = answers.errors
    outcome.estimate[:] = answers.pose
    for k in np.flatnonzero(answers.posed).tolist():
        x, y, heading = (float(v) for v in answers.pose[k])
        outcome.position[k], outcome.heading[k] = pose_error((x, y, heading), cases[k].pose)
    return outcome


def run_benchmark(
    suite: Suite,
    contenders: Sequence[Contender] | None = None,
    *,
    split: str = "dev",
    quick: bool = False,
    workers: int = 1,
    seed: int | None = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    progress: Progress | None = None,
    backend: str = "local",
    address: str | None = None,
    maps: Mapping[str, BeaconMap] | None = None,
    profile: Profile | None = None,
) -> BenchResult:
    """Score every contender on the suite's cases.

    With a profile, the suite is drawn with its sensor and motion noise
    (:meth:`~azgym.bench.suites.Suite.profiled`) and every contender takes its hyperparameters
    as defaults; the summary records it (``profile``: empty as shipped).

    Args:
        suite: The suite.
        contenders: The localizers (default: :func:`default_contenders`). ``ransac`` is added as
            the runtime reference if missing.
        split: "dev" (the suite's fixed seed) or "test" (a seed drawn now in secret: the process
            turns non-dumpable first, :func:`~azgym.bench.run.worker.hide_process`, and the seed
            is printed and written only once every contender has answered).
        quick: Draw the suite's small version.
        workers: Worker processes per contender at a time.
        seed: Draw the cases from this seed instead (to rerun a reported test split).
        time_limit: Seconds a localizer may take on one frame (or to be built).
        progress: Called with text as the run advances.
        backend: "local" or "ray" (:func:`run_contenders`).
        address: The Ray cluster's address (``backend="ray"`` only).
        maps: Beacon map of each scenario the cases name (default: the shipped scenarios').
        profile: The profile applied to the simulator and the contenders (None: the suite's
            own, if it is :meth:`~azgym.bench.suites.Suite.profiled` already).

    Raises:
        InvalidInputError: A bad split, or a profile the suite cannot take.
    """
    suite = suite if profile is None else suite.profiled(profile)
    profile = suite.contender_profile()  # a suite profiled already: its profile is the run's
    contenders = with_reference(contenders or default_contenders())
    say = progress or (lambda _line: None)
    seed, secret = _seed(suite, split, seed)
    start_workers(contenders, backend, say, profile)  # the server warms up while cases are drawn
    cases = _draw(suite, split, seed, quick, secret, say)
    outcomes = run_contenders(cases, contenders, workers=workers, maps=maps,
                              time_limit=time_limit, progress=progress, backend=backend,
                              address=address, profile=profile)
    reference = next(c.label for c in contenders if c.is_reference)
    summary = summarize(suite, split, seed, quick, contenders, cases, outcomes, reference,
                        profile=profile, given=suite.profile)
    return BenchResult(summary, cases, outcomes)


def run_log_benchmark(log: Log, contenders: Sequence[Contender] | None = None, *,
                      workers: int = 1, time_limit: float = DEFAULT_TIME_LIMIT,
                      progress: Progress | None = None, profile: Profile | None = None
                      ) -> BenchResult:
    """Score every contender on the log's frames (``ransac`` added as the runtime reference).

    Args:
        log: The log.
        contenders: The localizers and trackers (default: the built-in localizers).
        workers: Worker processes per contender at a time.
        time_limit: Seconds a contender may take on one frame (or to be built).
        progress: Called with text as the run advances.
        profile: Fields over the log's own profile (:func:`log_profile`), whose
            hyperparameters are every contender's defaults; None: the log's own.

    Raises:
        LogError: The log has no truth to score against.
    """
    cases = log_cases(log)
    contenders = with_reference(contenders or default_contenders())
    applied = log_profile(log, profile)
    say = progress or (lambda _line: None)
    say(f"data:{log.manifest.name} ({'simulated' if log.manifest.simulated else 'real'}, "
        f"sha256 {log.sha256[:12]}…): {len(cases)} frames")
    say(f"  {describe_profile(applied)}")
    outcomes = run_contenders(cases, contenders, workers=workers,
                              maps={log.map_name: log.beacons}, time_limit=time_limit,
                              progress=progress, profile=applied)
    reference = next(c.label for c in contenders if c.is_reference)
    dataset: DatasetSummary = {"name": log.manifest.name, "format": log.manifest.format,
                               "simulated": log.manifest.simulated, "sha256": log.sha256,
                               "description": log.manifest.description}
    summary = summarize(data_suite(log, cases), DATA_SPLIT, 0, False, contenders, cases, outcomes,
                        reference, profile=applied, given=profile, dataset=dataset)
    return BenchResult(summary, cases, outcomes,
                       maps={} if log.shipped_map else {log.map_name: log.beacons})


def start_workers(contenders: Sequence[Contender], backend: str, say: Progress,
                  profile: Profile | None = None) -> None:
    """Start the workers' fork server (``backend`` "local") warming up the contenders' built-ins.

    On a machine's first run (said) the kernels compile: the fork server starts with ransac's
    while this process compiles the others' (:func:`~azgym.bench.run.contenders.warm_up`). The
    command line calls this before it builds the named contenders in workers, so that they fork
    warm; the run calls it again (a fork server, once started, stays as it is).
    """
    warmed = builtins_to_warm(contenders)
    first_run = not localizers_compiled()
    if first_run:
        say("compiling azgym's kernels (the installation did not, or its sources changed since): "
            "this run takes about 20 s longer; they are cached for the next runs")
    if backend == "local":
        start_fork_server([c.label for c in warmed])
    if first_run:
        warm_up(reversed(warmed[1:]), profile)


def _seed(suite: Suite, split: str, seed: int | None) -> tuple[int, bool]:
    """The seed the cases are drawn from, and whether it is secret (a test split's, drawn now).

    A secret seed is drawn once the process is not dumpable
    (:func:`~azgym.bench.run.worker.hide_process`): no other process of the user's can read it
    (docs/leaderboard.md).
    """
    _check_split(suite, split, seed)
    if secret := seed is None and split == "test":
        hide_process()
    return (suite.dev_seed if split == "dev" else secrets.randbits(31)) if seed is None \
        else seed, secret


def _draw(suite: Suite, split: str, seed: int, quick: bool, secret: bool, say: Progress
          ) -> list[Case]:
    """The suite's cases, and the run's header: what was drawn (and the profile, if any)."""
    started = time.perf_counter()
    cases = suite.build(seed, quick)
    shown = "seed withheld until every contender has answered" if secret else f"seed {seed}"
    say(f"{suite.name} v{suite.version} ({split}, {shown}): {len(cases)} frames drawn in "
        f"{time.perf_counter() - started:.1f} s")
    if suite.profile is not None:
        say(f"  {describe_profile(suite.profile, suite.simulates)}")
    return cases


def _check_split(suite: Suite, split: str, seed: int | None) -> None:
    """The split is "dev" or "test", and a secret test split is one the suite can have."""
    if split not in ("dev", "test"):
        raise InvalidInputError(f"split must be 'dev' or 'test', got {split!r}")
    if split == "test" and seed is None and suite.routes:
        raise InvalidInputError(NO_TEST_SPLIT.format(suite=suite.name))

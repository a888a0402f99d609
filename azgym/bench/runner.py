"""The runner: every contender on every case, the one loop behind ``azgym bench`` and the paper.

A localizer that raises on a case is scored as unavailable on that case (the error is kept),
never taking the run down. Cases are drawn once, in this process, and split into chunks for the
worker processes, so the figures do not depend on ``workers``. Runtimes are measured per call,
and reported beside ``ransac``'s median from the same run, so runs on different machines compare.
"""

from __future__ import annotations

import math
import os
import secrets
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor

from azgym.bench.contenders import REFERENCE, Contender, default_contenders
from azgym.bench.outcome import Outcome
from azgym.bench.results import BenchResult, summarize
from azgym.bench.suites import Case, Suite
from azgym.core import BeaconMap, estimated_pose, pose_error
from azgym.errors import InvalidInputError
from azgym.localize.registry import make_localizer
from azgym.site import load_scenario

CHUNKS_PER_WORKER = 4
"""Cases are split into this many chunks per worker, so a slow chunk does not idle the others."""

Progress = Callable[[str], None]
"""Called with text as a run advances; text starting with a carriage return redraws the line."""


def default_workers() -> int:
    """One worker process per core."""
    return max(1, os.cpu_count() or 1)


def _localize_chunk(contender: Contender, cases: list[Case],
                    maps: Mapping[str, BeaconMap]) -> Outcome:
    """Run one contender on some cases (in a worker); never raises for the localizer's sake."""
    outcome = Outcome.empty(len(cases))
    try:
        localizer = make_localizer(contender.spec, **contender.params)
    except Exception as exc:  # noqa: BLE001 - a plug-in that cannot even be built
        outcome.errors[:] = [f"cannot build {contender.spec!r}: {exc}"] * len(cases)
        return outcome
    for case in cases[:1]:  # warm-up: numba's first call loads compiled code; keep it untimed
        try:
            localizer.localize(case.measurements, maps[case.scenario])
        except Exception:  # noqa: BLE001, S110 - the timed loop below records the failure
            pass
    for k, case in enumerate(cases):
        try:
            start = time.perf_counter_ns()
            estimate = localizer.localize(case.measurements, maps[case.scenario])
            outcome.micros[k] = (time.perf_counter_ns() - start) / 1000.0
            pose = estimated_pose(estimate)
            if pose is not None:
                outcome.position[k], outcome.heading[k] = pose_error(pose, case.pose)
            outcome.ok[k] = pose is not None
        except Exception as exc:  # noqa: BLE001 - a failing plug-in is scored, not fatal
            outcome.errors[k] = f"{type(exc).__name__}: {exc}"
    return outcome


def run_contenders(
    cases: Sequence[Case],
    contenders: Sequence[Contender],
    *,
    workers: int = 1,
    maps: Mapping[str, BeaconMap] | None = None,
    progress: Progress | None = None,
) -> dict[str, Outcome]:
    """Score every contender on every case; the outcomes are in the order of ``cases``.

    Args:
        cases: The cases.
        contenders: The localizers.
        workers: Worker processes (1: this process).
        maps: Beacon map of each scenario named by the cases (default: the shipped scenarios').
        progress: Called with text as the run advances.
    """
    cases = list(cases)
    say = progress or (lambda _line: None)
    if maps is None:
        maps = {name: load_scenario(name).beacons for name in {case.scenario for case in cases}}
    chunk = max(1, math.ceil(len(cases) / max(1, CHUNKS_PER_WORKER * workers)))
    pieces = [cases[s:s + chunk] for s in range(0, len(cases), chunk)]
    outcomes: dict[str, Outcome] = {}
    executor = ProcessPoolExecutor(max_workers=workers) if workers > 1 else None
    try:
        for contender in contenders:
            begun = time.perf_counter()
            jobs = ([contender] * len(pieces), pieces, [maps] * len(pieces))
            results = map(_localize_chunk, *jobs) if executor is None else executor.map(
                _localize_chunk, *jobs)
            parts = []
            for part in results:  # in order, as each chunk completes
                parts.append(part)
                done = len(parts) * 20 // len(pieces)
                say(f"\r  {contender.label:<20} [{'#' * done}{'.' * (20 - done)}] "
                    f"{len(parts)}/{len(pieces)}")
            outcomes[contender.label] = Outcome.concatenate(parts)
            say(f"  {contender.label:<20} {time.perf_counter() - begun:6.1f} s")
    finally:
        if executor is not None:
            executor.shutdown()
    return outcomes


def run_benchmark(
    suite: Suite,
    contenders: Sequence[Contender] | None = None,
    *,
    split: str = "dev",
    quick: bool = False,
    workers: int = 1,
    seed: int | None = None,
    progress: Progress | None = None,
) -> BenchResult:
    """Score every contender on the suite's cases.

    Args:
        suite: The suite.
        contenders: The localizers (default: :func:`default_contenders`). ``ransac`` is added as
            the runtime reference if missing.
        split: "dev" (the suite's fixed seed) or "test" (a seed drawn now, and reported).
        quick: Draw the suite's small version.
        workers: Worker processes (1: this process).
        seed: Draw the cases from this seed instead (to rerun a reported test split).
        progress: Called with text as the run advances.
    """
    if split not in ("dev", "test"):
        raise InvalidInputError(f"split must be 'dev' or 'test', got {split!r}")
    contenders = list(contenders or default_contenders())
    if not any(c.is_reference for c in contenders):
        contenders.append(Contender(REFERENCE, REFERENCE))
    say = progress or (lambda _line: None)
    if seed is None:
        seed = suite.dev_seed if split == "dev" else secrets.randbits(31)
    started = time.perf_counter()
    cases = suite.build(seed, quick)
    say(f"{suite.name} v{suite.version} ({split}, seed {seed}): {len(cases)} frames drawn in "
        f"{time.perf_counter() - started:.1f} s")
    outcomes = run_contenders(cases, contenders, workers=workers, progress=progress)
    reference = next(c.label for c in contenders if c.is_reference)
    summary = summarize(suite, split, seed, quick, contenders, cases, outcomes, reference)
    return BenchResult(summary, cases, outcomes)

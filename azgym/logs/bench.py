"""Score localizers and trackers on a log, through the runner, as on a suite.

A log is scored as a suite of one dataset, ``data:NAME``: its frames are the cases
(:func:`~azgym.logs.cases.log_cases`), the runner scores every contender on them with the log's
map, and the summary is the suite's (:func:`~azgym.bench.results.summarize`) with the dataset's
identity beside it: its name, format, whether it is simulated, and the SHA-256 of its files
(:func:`~azgym.logs.read.log_digest`), which names exactly which data the figures are of.

Every contender takes its defaults from the log's profile (its manifest's ``[vehicle]``,
``[sensor]`` and ``[motion]``), with a profile given to the run over it; the summary records
the profile applied (``profile``) and the one given to the run (``profile_given``, empty when
none was: a leaderboard entry is a run with the log's own).
"""

from __future__ import annotations

import importlib.util
from collections.abc import Sequence
from pathlib import Path

from azgym.bench.contenders import Contender, default_contenders, with_reference
from azgym.bench.isolation import DEFAULT_TIME_LIMIT
from azgym.bench.profiles import describe_profile
from azgym.bench.results import BenchResult, summarize
from azgym.bench.runner import Progress, run_contenders
from azgym.bench.suites import Case, Suite
from azgym.logs.cases import log_cases
from azgym.logs.read import Log
from azgym.profile import Profile, profile_toml

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
    summary = summarize(data_suite(log, cases), SPLIT, 0, False, contenders, cases, outcomes,
                        reference)
    summary["dataset"] = {"name": log.manifest.name, "format": log.manifest.format,
                          "simulated": log.manifest.simulated, "sha256": log.sha256,
                          "description": log.manifest.description}
    summary["profile"] = profile_toml(applied)
    summary["profile_given"] = profile_toml(profile or Profile())
    return BenchResult(summary, cases, outcomes)


def write_log_results(result: BenchResult, log: Log, out: Path) -> list[Path]:
    """results.json, frames.csv and, with matplotlib, the figures, on the log's own map.

    A map that is no shipped scenario (``beacons.csv``) is drawn from its beacons (no racks).
    """
    written = result.write(out, figures=False)
    if importlib.util.find_spec("matplotlib") is not None:
        from azgym.bench.plots import write_figures

        maps = {} if log.shipped_map else {log.map_name: log.beacons}
        written += write_figures(result.summary, result.cases, result.outcomes, out, maps)
    return written

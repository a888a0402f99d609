"""Running a navigation suite: every navigator with every localizer on the suite's episodes.

A contender is a (navigator, localizer) pair. Each drives the suite's episodes in an environment
of its own (:func:`drive_contender`), so the figures do not depend on ``workers``: the
contenders are only spread over worker processes. Everything is checked before the first
episode — each localizer is built in its environment and each navigator loaded against it — so
a typo or a missing extra costs nothing.

Closed loop, the localizer runs in the process that simulates the world (its answers move the
forklift every step), so it is not kept from the truth the way the frame suites' isolated
workers keep it. Run only localizers you trust here; the published navigation board runs
azgym's own.

The result (:func:`run_navigation`, a
:class:`~azgym.bench.navigation.report.NavigationResult`) is what ``navigation.json`` holds: the
run's identity, then per contender the files its localizer names, pinned by their SHA-256
(:func:`localizer_files`), the summary of :func:`azgym.bench.navigation.scoring.summarize`,
the wall time, and each episode's figures
(:func:`episode_rows`), from which the board recomputes the summary
(:mod:`azgym.bench.navigation.results_file`). A figure that does not exist (no answer, no
success) is null. :func:`evaluate_navigator` drives one policy the same way on an environment
named by id, once per localizer (``azgym evaluate navigator``).
"""

from __future__ import annotations

import multiprocessing
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from datetime import UTC, datetime
from typing import Any

import gymnasium as gym

from azgym._version import __version__
from azgym.arguments import whole_number
from azgym.bench.leaderboard.checks import clean
from azgym.bench.leaderboard.plugin_files import PluginRecord, plugin_record
from azgym.bench.navigation.report import NavigationResult
from azgym.bench.navigation.suites import NAVIGATORS, NavigationSuite, get_navigation_suite
from azgym.errors import InvalidInputError
from azgym.localize.registry import parse_spec
from azgym.progress import Progress, counter

__all__ = ["KIND", "RESULTS_FORMAT", "Pairing", "check_contenders", "contenders_of",
           "drive_all", "drive_contender", "episode_rows", "evaluate_navigator",
           "localizer_files", "make_env", "navigation_contenders", "run_navigation"]

RESULTS_FORMAT = 3
"""The layout of ``navigation.json`` (``format``). 2: an episode's ``shortest_path_m`` (the
geodesic shortest path, SPL's l) replaces ``path_length_m`` (the planner's path). 3: a contender
whose localizer names a file records it as a frame suite's results do (:func:`localizer_files`:
``weights_file`` and ``weights_sha256`` for a weight file); a file of format 2 is otherwise the
same, and still reads (:mod:`azgym.bench.navigation.results_file`)."""
KIND = "navigation"
"""``kind`` of a navigation results file, which tells it from a frame suite's."""

Pairing = tuple[str, str]
"""A navigation contender: (navigator, localizer); the frame suites' is
:class:`azgym.bench.run.contenders.Contender`."""


def contenders_of(navigators: Sequence[str], localizers: Sequence[str]) -> list[Pairing]:
    """Every navigator with every localizer, each pair once, in the order named."""
    pairs = [(navigator, localizer) for navigator in navigators for localizer in localizers]
    if not pairs:
        raise InvalidInputError("a navigation run needs at least one navigator and one "
                                "localizer")
    return list(dict.fromkeys(pairs))


def navigation_contenders(suite: NavigationSuite, navigators: Sequence[str],
                          localizers: Sequence[str], *, with_builtins: bool = False
                          ) -> list[Pairing]:
    """Who drives a navigation suite: ``azgym bench --suite navigation``'s pairs, unchecked.

    The navigators named (all of :data:`~azgym.bench.navigation.suites.NAVIGATORS` if none),
    each with every localizer chosen by the frame suites' rule
    (:func:`~azgym.bench.run.contenders.resolve_contenders`, the suite's localizers as the
    built-ins): labelled by their canonical specs, each once. :func:`check_contenders` builds
    them.

    Raises:
        InvalidInputError: A localizer spec whose hyperparameters cannot be read.
    """
    from azgym.bench.run.contenders import resolve_contenders

    chosen = resolve_contenders(localizers, with_builtins=with_builtins,
                                builtins=suite.localizers, check=None)
    return contenders_of(navigators or NAVIGATORS, [c.label for c in chosen])


def localizer_files(localizer: str) -> PluginRecord:
    """The files a contender's localizer names, as its results record them.

    The rule of a frame suite's results (:func:`~azgym.bench.leaderboard.plugin_files.
    plugin_record`): a plug-in's file and a weight file (``ng-ransac:weights=FILE``), each by
    its absolute path and SHA-256; nothing for a shipped localizer, a tracker or ``truth``.
    """
    return plugin_record(*parse_spec(localizer))


def make_env(suite: NavigationSuite, localizer: str) -> gym.Env:
    """The suite's environment with ``localizer`` (a name, a spec or ``truth``)."""
    import azgym.envs.registration  # noqa: F401 - registers the ids

    return gym.make(suite.env_id, localizer=localizer, **suite.env_kwargs)


def check_contenders(suite: NavigationSuite, contenders: Sequence[Pairing]) -> None:
    """Build every localizer and load every navigator against it: a named error now, not later."""
    from azgym.nav.policy_file import load_policy

    checked: set[str] = set()
    for navigator, localizer in contenders:
        env = make_env(suite, localizer)
        if navigator not in checked:
            load_policy(navigator, env)
            checked.add(navigator)
        env.close()


def run_navigation(suite: NavigationSuite, contenders: Sequence[Pairing], *, split: str = "dev",
                   quick: bool = False, workers: int = 1,
                   progress: Progress | None = None) -> NavigationResult:
    """Drive every contender on the suite's episodes; what ``navigation.json`` holds.

    Args:
        suite: The navigation suite.
        contenders: (navigator, localizer) pairs, checked with :func:`check_contenders`.
        split: ``dev`` (the suite's seed) or ``test`` (a fresh seed, reported).
        quick: Run the suite's small version.
        workers: Contenders driven at a time, each in a process of its own.
        progress: Called with a line as each contender finishes (and the contenders
            counted, :func:`azgym.progress.counter`).
    """
    if split not in ("dev", "test"):
        raise InvalidInputError(f"split must be 'dev' or 'test', got {split!r}")
    workers = whole_number("workers", workers, minimum=1)
    seed = suite.dev_seed if split == "dev" else suite.test_seed()
    return NavigationResult({
        "kind": KIND, "format": RESULTS_FORMAT, "suite": suite.name,
        "suite_version": suite.version, "split": split, "seed": seed, "quick": quick,
        "episodes": suite.size(quick), "env": suite.env_id, "env_kwargs": suite.env_kwargs,
        "azgym_version": __version__, "python": sys.version.split()[0],
        "timestamp": datetime.now(UTC).isoformat(timespec="seconds"),
        "contenders": clean(drive_all(suite, contenders, seed, suite.size(quick), workers,
                                      progress))})


def evaluate_navigator(policy: str, env_id: str, localizers: Sequence[str], *, episodes: int,
                       seed: int, sensor: str, ids: str,
                       progress: Progress | None = None) -> NavigationResult:
    """Drive ``policy`` on episodes seed, seed + 1, ... of ``env_id``, once per localizer.

    Every environment is built and the policy loaded against the first before any episode, so
    a typo, a missing extra or a policy trained for another observation costs nothing.

    Args:
        policy: ``pure-pursuit`` or a stable-baselines3 zip (:mod:`azgym.nav.policy_file`).
        env_id: A Navigate or NavigateDiscrete environment id.
        localizers: The localizers (names, specs or ``truth``), a row each.
        episodes: Episodes per localizer.
        seed: The seed of the first episode.
        sensor: The camera: ``geometry`` or ``image``.
        ids: How the image sensor identifies beacons: ``oracle`` or ``blink``.
        progress: Hears each localizer's episodes counted (:func:`azgym.progress.counter`).
    """
    import azgym.envs.registration  # noqa: F401 - registers the ids
    from azgym.bench.navigation.scoring import drive
    from azgym.nav.policy_file import load_policy

    envs = {name: gym.make(env_id, localizer=name, sensor=sensor, ids=ids)
            for name in localizers}  # every localizer named and built before any episode
    loaded = load_policy(policy, envs[localizers[0]])
    rows = []
    for name, env in envs.items():
        files = localizer_files(name)
        started = time.perf_counter()
        with counter(progress, name, episodes, "episodes") as done:
            result = drive(env, loaded, episodes, seed, progress=done)
        rows.append({"localizer": name, **files, "runtime_s": time.perf_counter() - started,
                     "summary": {key: value for key, value in result.items()
                                 if key != "episodes"},
                     "episodes": episode_rows(result["episodes"], seed)})
        env.close()
    return NavigationResult({"policy": policy, "env": env_id, "sensor": sensor, "ids": ids,
                             "episodes": episodes, "seed": seed, "results": rows},
                            rows="results", names=("localizer",))


def drive_all(suite: NavigationSuite, contenders: Sequence[Pairing], seed: int, episodes: int,
              workers: int, progress: Progress | None = None) -> list[dict[str, Any]]:
    """Each contender's record (:func:`drive_contender`), in the order of ``contenders``."""
    say = progress or (lambda _line: None)
    tasks = [(suite.name, navigator, localizer, seed, episodes)
             for navigator, localizer in contenders]
    records: list[dict[str, Any]] = []
    with counter(progress, suite.name, len(tasks), "contenders") as count:
        if workers == 1 or len(tasks) == 1:
            for task in tasks:
                records.append(drive_contender(*task))
                say(_finished(records[-1]))
                count(len(records))
            return records
        # spawn: a worker starts clean (no forked torch or numba threads), imports what it needs.
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(min(workers, len(tasks)), mp_context=context) as pool:
            for record in pool.map(drive_contender, *zip(*tasks, strict=True)):
                records.append(record)
                say(_finished(record))
                count(len(records))
    return records


def drive_contender(suite_name: str, navigator: str, localizer: str, seed: int,
                    episodes: int) -> dict[str, Any]:
    """One contender on episodes seed, seed + 1, ...: its files, summary, wall time, episodes."""
    from azgym.bench.navigation.scoring import drive
    from azgym.nav.policy_file import load_policy

    suite = get_navigation_suite(suite_name)
    env = make_env(suite, localizer)
    files = localizer_files(localizer)  # the files the localizer was just built from
    policy = load_policy(navigator, env)
    _one_thread()
    started = time.perf_counter()
    result = drive(env, policy, episodes, seed)
    runtime = time.perf_counter() - started
    env.close()
    return {"navigator": navigator, "localizer": localizer, **files,
            "summary": {key: value for key, value in result.items() if key != "episodes"},
            "runtime_s": runtime, "episodes": episode_rows(result["episodes"], seed)}


def episode_rows(records: list[dict[str, Any]], seed: int) -> list[dict[str, Any]]:
    """Each episode's figures, as results files keep them (the step errors summarized).

    ``steps`` and ``answered_steps`` let the whole run's answered share be recomputed; an
    episode's errors are summarized (median and 95th percentile, cm) by the rule of the run's,
    :func:`azgym.bench.navigation.scoring.summarize`.
    """
    from azgym.bench.navigation.scoring import summarize

    rows = []
    for k, record in enumerate(records):
        errors = record["errors"]
        figures = summarize([record])
        rows.append({"seed": seed + k, "success": record["success"], "spl": record["spl"],
                     "collisions": record["collisions"], "time_s": record["time"],
                     "shortest_path_m": record["shortest_path"],
                     "travelled_m": record["travelled"], "steps": int(errors.size),
                     "answered_steps": int(round(figures["answered"] * errors.size)),
                     "error_median_cm": figures["error_median_cm"],
                     "error_p95_cm": figures["error_p95_cm"]})
    return rows


def _finished(record: dict[str, Any]) -> str:
    summary = record["summary"]
    return (f"{record['navigator']} + {record['localizer']}: success "
            f"{100 * summary['success']:.0f} %, SPL {summary['spl']:.2f} "
            f"({record['runtime_s']:.0f} s)")


def _one_thread() -> None:
    """One torch thread per worker process (the workers are the parallelism), if torch is in."""
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(1)

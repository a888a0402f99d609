"""A navigation results file read as an adversary's edit: every field of its kind, range and rule.

``navigation.json`` (:mod:`azgym.bench.navigation.benchmark`) is what the board's navigation tables
show, so :func:`load_navigation` trusts nothing in it:

- its layout: the keys of the file, of each contender, summary and episode are exactly the
  ones azgym writes (an unknown or missing key is refused), at most :data:`MAX_CONTENDERS`
  contenders, each (navigator, localizer) once;
- its suite exists at the version it was run on, with the suite's environment; its seed is the
  dev seed exactly when the split is ``dev``; every contender drove the suite's episodes (their
  count, and seeds seed, seed + 1, ...);
- its contenders are azgym's own: a built-in navigator
  (:data:`azgym.bench.navigation.suites.NAVIGATORS`) and a built-in localizer or tracker whose
  hyperparameters build, or ``truth``. A plug-in
  localizer runs in the loop that simulates the world, and a policy file is unpickled: neither
  is run from a board's file;
- a weight file a contender's localizer names (``ng-ransac:weights=FILE``) is the one the run
  used: the file the spec names, from the working folder as the run read it (and as the
  localizer is built here and rerun by ``azgym leaderboard verify``), still has the SHA-256 the
  file records (``weights_sha256``, beside the run's absolute ``weights_file``), by the rule of a
  frame suite's entries (:func:`azgym.bench.leaderboard.plugin_files.weights_sha256`). Format
  2 recorded no such pin: a file of format 2 still reads when none of its localizers names a
  weight file, and is refused, with the remedy, when one does;
- each episode obeys the environment's rules: it lasted ``steps`` control periods of 0.1 s
  (``time_s``), a failed one ran to the step limit, its shortest path l is the geodesic of its
  seed's start and goal (recomputed, :meth:`~azgym.envs.navigate.NavigateEnv.shortest_path`),
  its SPL is l / max(p, l) of l and the driven path p when it succeeded and 0 otherwise, it
  answered at most every step, and its error quantiles exist exactly when it answered (finite,
  ≥ 0, p95 ≥ median);
- each episode obeys physics: its driven path p is no longer than the forklift can drive from
  rest in the episode's time (full throttle up to its top speed,
  :meth:`~azgym.world.forklift.ForkliftSpec.max_centre_distance`), and a successful one is
  longer than l, which is a lower bound of every drive to the goal. These checks refuse the
  impossible, not the implausible: a forged file that stays within them is caught by
  ``azgym leaderboard verify``;
- each summary figure the episodes determine (:data:`RECOMPUTED`) is recomputed from them. The
  localization error's quantiles pool every step, which the file does not keep: they are only
  checked for kind and order here, and ``azgym leaderboard verify`` reruns the episodes.

An episode's refusal names the file, the contender and the episode's field.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from azgym import arguments
from azgym.bench.leaderboard.checks import clean, close
from azgym.bench.leaderboard.entry_files import LeaderboardError, exact_keys, read_json
from azgym.bench.leaderboard.plugin_files import weights_path, weights_sha256
from azgym.bench.navigation.benchmark import KIND, RESULTS_FORMAT
from azgym.bench.navigation.scoring import wilson_interval
from azgym.bench.navigation.suites import NAVIGATION_SUITES, NAVIGATORS, NavigationSuite, overlap
from azgym.envs.navigate import MAX_STEPS
from azgym.errors import AzgymError, InvalidInputError
from azgym.localize.registry import is_builtin, parse_spec
from azgym.nav.controls import CONTROL_STEPS
from azgym.world.forklift import ForkliftSpec
from azgym.world.world import PHYSICS_DT

__all__ = ["FORKLIFT", "episode_seeds", "is_navigation_file", "load_navigation",
           "recomputed_summary"]

MAX_CONTENDERS = 64
"""At most this many contenders in a file (the suites' defaults are 20): a rerun of a file
drives each one's episodes, so a padded file must not cost hours."""
FILE_KEYS = {"kind", "format", "suite", "suite_version", "split", "seed", "quick", "episodes",
             "env", "env_kwargs", "azgym_version", "python", "timestamp", "contenders"}
CONTENDER_KEYS = {"navigator", "localizer", "summary", "runtime_s", "episodes"}
PIN_KEYS = {"weights_file", "weights_sha256"}
"""A contender's keys beside :data:`CONTENDER_KEYS` when its localizer names a weight file."""
FORMATS = (2, RESULTS_FORMAT)
"""The formats read: this azgym's, and 2, which differs only in recording no weight file."""
PINNED = 3
"""The first format that pins a weight file."""
SHA256 = re.compile(r"[0-9a-f]{64}")
MAX_PATH = 4096
"""The longest ``weights_file`` [characters]."""
RECOMPUTED = ("success", "success_interval", "spl", "collisions", "collided", "time_to_goal",
              "answered")
"""The summary figures recomputed from a file's episodes when it is read."""
SUMMARY_KEYS = {*RECOMPUTED, "error_median_cm", "error_p95_cm"}
EPISODE_KEYS = {"seed", "success", "spl", "collisions", "time_s", "shortest_path_m",
                "travelled_m", "steps", "answered_steps", "error_median_cm", "error_p95_cm"}
PERIOD = CONTROL_STEPS * PHYSICS_DT
"""An episode's step [s]."""
FORKLIFT = ForkliftSpec()
"""The forklift the navigation environments drive: its limits bound an episode's path."""


def is_navigation_file(path: Path) -> bool:
    """Whether ``path`` is a navigation results file (rather than a frame suite's entry).

    A file that cannot be read is not one: reading it as an entry then names the problem.
    """
    try:
        data = read_json(path, "results file")
    except LeaderboardError:
        return False
    return isinstance(data, dict) and data.get("kind") == KIND


def load_navigation(path: Path) -> dict[str, Any]:
    """A navigation results file, every check of the module docstring passed.

    Raises:
        LeaderboardError: Naming the file and the field at fault.
    """
    data = read_json(path, "navigation results file")
    if not isinstance(data, dict) or data.get("kind") != KIND:
        raise LeaderboardError(f"{path}: not a navigation results file (kind {KIND!r})")
    if type(data.get("format")) is not int or data["format"] not in FORMATS:
        raise LeaderboardError(f"{path}: format must be {' or '.join(map(str, FORMATS))} "
                               f"(this azgym writes {RESULTS_FORMAT}), got "
                               f"{data.get('format')!r}")
    exact_keys(data, FILE_KEYS, str(path))
    for key in ("azgym_version", "python", "timestamp"):
        if not isinstance(data[key], str) or len(data[key]) > 64:
            raise LeaderboardError(f"{path}: {key}: must be a text of at most 64 characters")
    _check_suite(data, path)
    shortest = _shortest_paths(NAVIGATION_SUITES[data["suite"]], data)
    contenders = data["contenders"]
    if not isinstance(contenders, list) or not 0 < len(contenders) <= MAX_CONTENDERS:
        raise LeaderboardError(f"{path}: contenders must be a list of 1 to {MAX_CONTENDERS}")
    seen = set()
    for k, contender in enumerate(contenders):
        where = f"{path}: contenders/{k}"
        _check_contender(contender, data, shortest, where)
        pair = (contender["navigator"], contender["localizer"])
        if pair in seen:
            raise LeaderboardError(f"{where}: {pair[0]} + {pair[1]} is in the file twice")
        seen.add(pair)
    return data


def _check_suite(data: dict[str, Any], path: Path) -> None:
    """The file's suite exists, at its version, environment, and with its split, seed and size."""
    suite = NAVIGATION_SUITES.get(data["suite"]) if isinstance(data["suite"], str) else None
    if suite is None:
        raise LeaderboardError(f"{path}: suite {data['suite']!r} is not a navigation suite "
                               f"({', '.join(NAVIGATION_SUITES)})")
    if data["suite_version"] != suite.version or isinstance(data["suite_version"], bool):
        raise LeaderboardError(f"{path}: suite_version {data['suite_version']!r}: "
                               f"{suite.name} is at version {suite.version}; rerun it")
    if (data["env"], data["env_kwargs"]) != (suite.env_id, suite.env_kwargs):
        raise LeaderboardError(f"{path}: env and env_kwargs must be the suite's: "
                               f"{suite.env_id} {suite.env_kwargs}")
    split, seed, quick = data["split"], data["seed"], data["quick"]
    if split not in ("dev", "test") or not isinstance(quick, bool):
        raise LeaderboardError(f"{path}: split must be 'dev' or 'test' and quick true or false")
    try:
        arguments.seed("seed", seed)
    except InvalidInputError as exc:
        raise LeaderboardError(f"{path}: {exc}") from None
    if (split == "dev") != (seed == suite.dev_seed):
        raise LeaderboardError(f"{path}: a dev run uses the suite's seed {suite.dev_seed} and "
                               f"a test run another, got split {split!r} with seed {seed}")
    if type(data["episodes"]) is not int or data["episodes"] != suite.size(quick):
        raise LeaderboardError(f"{path}: episodes must be {suite.size(quick)} (the suite's "
                               f"{'quick' if quick else 'full'} size), got "
                               f"{data['episodes']!r}")
    dev = suite.dev_episodes
    if split == "test" and overlap(episode_seeds(data), dev):
        raise LeaderboardError(f"{path}: a test run's episodes must not be the dev split's "
                               f"(seeds {dev.start} to {dev.stop - 1}), got seed {seed}")


def episode_seeds(data: dict[str, Any]) -> range:
    """The seeds of a checked file's episodes: seed, seed + 1, ..."""
    return range(data["seed"], data["seed"] + data["episodes"])


def _shortest_paths(suite: NavigationSuite, data: dict[str, Any]) -> dict[int, float]:
    """The geodesic shortest path of each of the file's episodes, by seed [m]."""
    from azgym.bench.navigation.benchmark import make_env
    from azgym.envs.navigate import NavigateEnv

    env = make_env(suite, "truth")
    try:
        navigate = env.unwrapped
        assert isinstance(navigate, NavigateEnv), "a navigation suite drives a NavigateEnv"
        return {seed: navigate.shortest_path(seed) for seed in episode_seeds(data)}
    finally:
        env.close()


def _check_contender(contender: Any, data: dict[str, Any], shortest: dict[int, float],
                     where: str) -> None:
    """A built-in pair that drove the file's episodes, its summary matching them."""
    weights = _named_weights(contender, data["format"], where)
    exact_keys(contender, CONTENDER_KEYS | (PIN_KEYS if weights is not None else set()), where)
    navigator, localizer = contender["navigator"], contender["localizer"]
    if not isinstance(navigator, str) or navigator not in NAVIGATORS:
        raise LeaderboardError(f"{where}/navigator: {navigator!r} is not a built-in navigator "
                               f"({', '.join(NAVIGATORS)})")
    pair = f"{where} ({navigator} + {localizer})"
    if weights is not None:  # before the localizer is built from the file
        _check_pin(contender, weights, pair)
    _check_localizer(localizer, f"{where}/localizer")
    where = pair
    if not _number(contender["runtime_s"], 0.0):
        raise LeaderboardError(f"{where}/runtime_s: must be a number of seconds ≥ 0")
    episodes = contender["episodes"]
    seeds = [data["seed"] + k for k in range(data["episodes"])]
    if not isinstance(episodes, list) or [
            e.get("seed") if isinstance(e, dict) else None for e in episodes] != seeds:
        raise LeaderboardError(f"{where}/episodes: must be the suite's {data['episodes']} "
                               f"episodes, seeds {data['seed']} to {seeds[-1]} in order")
    summary = contender["summary"]
    exact_keys(summary, SUMMARY_KEYS, f"{where}/summary")
    for key, value in recomputed_summary(episodes, shortest, where).items():
        if not _agree(summary[key], value):
            raise LeaderboardError(f"{where}/summary/{key}: the file says "
                                   f"{summary[key]!r}, its episodes give {value!r}")
    answered = any(episode["answered_steps"] for episode in episodes)
    _check_quantiles(summary, answered, f"{where}/summary")


def _named_weights(contender: Any, file_format: int, where: str) -> Path | None:
    """The weight file a contender's localizer names, resolved (None: it names none).

    Raises:
        LeaderboardError: The localizer is not ``truth`` or a built-in localizer or tracker (a
            board runs no plug-in in the loop), or names a weight file in a file of a format
            that pins none.
    """
    if not isinstance(contender, dict) or "localizer" not in contender:
        return None  # the keys' check names what is wrong
    localizer = contender["localizer"]
    if not isinstance(localizer, str) or not (localizer == "truth" or is_builtin(localizer)):
        raise LeaderboardError(f"{where}/localizer: {localizer!r} is not a built-in localizer "
                               "or tracker (a board runs no plug-in in the loop)")
    weights = weights_path(parse_spec(localizer)[1])
    if weights is not None and file_format < PINNED:
        raise LeaderboardError(
            f"{where}/localizer: {localizer} names a weight file, and a format {file_format} "
            "file records no SHA-256 of it: run the contender again (azgym bench --suite "
            f"SUITE --localizer {localizer}): its file, of format {RESULTS_FORMAT}, pins it")
    return weights


def _check_pin(contender: dict[str, Any], weights: Path, where: str) -> None:
    """The weight file the localizer names is there and has the SHA-256 the run recorded."""
    recorded, named = contender["weights_sha256"], contender["weights_file"]
    if not isinstance(recorded, str) or not SHA256.fullmatch(recorded):
        raise LeaderboardError(f"{where}/weights_sha256: must be a SHA-256 (64 lowercase "
                               "hexadecimal digits)")
    if not isinstance(named, str) or not 0 < len(named) <= MAX_PATH:
        raise LeaderboardError(f"{where}/weights_file: must be a path of at most {MAX_PATH} "
                               "characters (the weight file the run read)")
    if not weights.exists():
        raise LeaderboardError(f"{where}/localizer: the weight file {weights} does not exist "
                               "(the spec names it from the working folder, as the run did: "
                               f"{named}); put the file there to read this file")
    try:
        digest = weights_sha256(weights)
    except InvalidInputError as exc:  # no regular file, or too large for a model file
        raise LeaderboardError(f"{where}/localizer: {exc}") from None
    if digest != recorded:
        raise LeaderboardError(f"{where}/weights_sha256: the weight file {weights} changed "
                               f"since the run: sha256 {digest}, the run used {recorded}")


def _check_localizer(localizer: str, where: str) -> None:
    """``truth``, or a built-in localizer or tracker (:func:`_named_weights`) that builds."""
    from azgym.nav.estimator import resolve_estimator

    try:
        resolve_estimator(localizer)
    except AzgymError as exc:
        raise LeaderboardError(f"{where}: {localizer!r} does not build: {exc}") from None


def recomputed_summary(episodes: list[dict[str, Any]], shortest: dict[int, float],
                       where: str) -> dict[str, Any]:
    """The summary figures the episodes determine (:data:`RECOMPUTED`), as the run's rule has it.

    Args:
        episodes: The episodes, in the order of their seeds.
        shortest: The geodesic shortest path of each episode, by seed [m].
        where: The file and contender, for messages.
    """
    rows = [_episode(episode, shortest[episode["seed"]], f"{where}/episodes/{k}")
            for k, episode in enumerate(episodes)]
    successes = [row["time_s"] for row in rows if row["success"]]
    steps = sum(row["steps"] for row in rows)
    return clean({
        "success": sum(row["success"] for row in rows) / len(rows),
        "success_interval": wilson_interval(sum(row["success"] for row in rows), len(rows)),
        "spl": sum(row["spl"] for row in rows) / len(rows),
        "collisions": sum(row["collisions"] for row in rows) / len(rows),
        "collided": sum(row["collisions"] > 0 for row in rows) / len(rows),
        "time_to_goal": sum(successes) / len(successes) if successes else math.nan,
        "answered": sum(row["answered_steps"] for row in rows) / steps})


def _episode(episode: dict[str, Any], shortest: float, where: str) -> dict[str, Any]:
    """An episode's figures, each of its kind and range, by the environment's rules and physics.

    ``shortest`` is the episode's geodesic shortest path [m].
    """
    exact_keys(episode, EPISODE_KEYS, where)
    if not isinstance(episode["success"], bool):
        raise LeaderboardError(f"{where}/success: must be true or false")
    for key in ("collisions", "steps", "answered_steps"):
        if type(episode[key]) is not int or not 0 <= episode[key] <= 10**9:
            raise LeaderboardError(f"{where}/{key}: must be a whole number ≥ 0")
    steps = episode["steps"]
    if not 1 <= steps <= MAX_STEPS or (not episode["success"] and steps != MAX_STEPS):
        raise LeaderboardError(f"{where}/steps: an episode lasts 1 to {MAX_STEPS} steps, and a "
                               f"failed one all {MAX_STEPS}; got {steps}")
    if episode["answered_steps"] > steps:
        raise LeaderboardError(f"{where}/answered_steps: more than its steps")
    if not _number(episode["time_s"], 0.0) or not close(episode["time_s"], steps * PERIOD):
        raise LeaderboardError(f"{where}/time_s: must be its steps times {PERIOD:g} s")
    length, travelled = episode["shortest_path_m"], episode["travelled_m"]
    if not _number(length, 1e-9) or not _number(travelled, 0.0):
        raise LeaderboardError(f"{where}: shortest_path_m must be a number > 0 and travelled_m "
                               "a number ≥ 0 [m]")
    if not close(length, shortest):
        raise LeaderboardError(f"{where}/shortest_path_m: the geodesic shortest path of seed "
                               f"{episode['seed']}'s start and goal is {shortest!r} m, the file "
                               f"says {length!r}")
    # One physics step more than the episode: the simulation integrates each step's end speed.
    reach = FORKLIFT.max_centre_distance(episode["time_s"] + PHYSICS_DT)
    if travelled > reach:
        raise LeaderboardError(
            f"{where}/travelled_m: {travelled:g} m in {episode['time_s']:g} s is more than the "
            f"forklift can drive from rest in that time ({reach:.2f} m at full throttle, "
            f"{FORKLIFT.max_accel:g} m/s² up to {FORKLIFT.max_centre_speed:.2f} m/s)")
    if episode["success"] and travelled <= length:
        raise LeaderboardError(
            f"{where}/travelled_m: {travelled:g} m to the goal is no longer than the geodesic "
            f"shortest path, {length:g} m, which a drive cannot match")
    spl = length / max(length, travelled) if episode["success"] else 0.0
    if not _number(episode["spl"], 0.0) or not close(episode["spl"], spl):
        raise LeaderboardError(f"{where}/spl: must be {spl!r}: l / max(p, l) of its shortest "
                               "and driven paths when it succeeded, 0 otherwise (a failed "
                               "episode has SPL 0)")
    _check_quantiles(episode, episode["answered_steps"] > 0, where)
    return episode


def _check_quantiles(figures: dict[str, Any], answered: bool, where: str) -> None:
    """Error quantiles exist exactly when there were answers: finite, ≥ 0, p95 ≥ median."""
    median, p95 = figures["error_median_cm"], figures["error_p95_cm"]
    if not answered:
        if median is not None or p95 is not None:
            raise LeaderboardError(f"{where}: error quantiles without an answer must be null")
        return
    if not (_number(median, 0.0) and _number(p95, 0.0) and p95 >= median):
        raise LeaderboardError(f"{where}: error_median_cm and error_p95_cm must be numbers "
                               "≥ 0 [cm], the p95 at least the median")


def _number(value: Any, low: float) -> bool:
    """A finite int or float (not a bool) of at least ``low``."""
    return (type(value) in (int, float) and math.isfinite(value) and value >= low)


def _agree(claimed: Any, actual: Any) -> bool:
    if isinstance(actual, list):
        return isinstance(claimed, list) and len(claimed) == len(actual) and all(
            _agree(a, b) for a, b in zip(claimed, actual, strict=True))
    if actual is None or claimed is None:
        return claimed is None and actual is None
    return _number(claimed, -math.inf) and close(claimed, actual)

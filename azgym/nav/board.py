"""The navigation section of the leaderboard: checked results files, their tables, and reruns.

The board's navigation tables come from ``navigation.json`` files written by ``azgym bench`` on
a navigation suite (:mod:`azgym.nav.benchmark`), kept in ``leaderboard/navigation/``. A file is
read as if an adversary had edited it (:func:`load_navigation`):

- its suite exists at the version it was run on, with the suite's environment, its seed is the
  dev seed exactly when the split is ``dev``, and every contender drove the suite's episodes
  (their count, and seeds seed, seed + 1, ...);
- its contenders are azgym's own: a built-in navigator (:data:`azgym.nav.suites.NAVIGATORS`)
  and a built-in localizer or tracker, or ``truth``. A plug-in localizer runs in the loop that
  simulates the world, and a policy file is unpickled: neither is run from a board's file;
- each summary figure that the episodes determine (success and its interval, SPL, collisions,
  time to goal, answered share) is recomputed from them. The localization error's quantiles
  pool every step, which the file does not keep: :func:`verify_navigation` reruns the episodes
  and compares everything.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from azgym.bench.entries import clean, close
from azgym.bench.entry_files import LeaderboardError, read_json
from azgym.bench.leaderboard import differences
from azgym.localize.registry import is_builtin
from azgym.nav.benchmark import KIND, RESULTS_FORMAT, drive_all
from azgym.nav.scoring import wilson_interval
from azgym.nav.suites import NAVIGATION_SUITES, NAVIGATORS

RECOMPUTED = ("success", "success_interval", "spl", "collisions", "collided", "time_to_goal",
              "answered")
"""The summary figures recomputed from a file's episodes when it is read."""
HEADER = ["#", "navigator", "localizer", "success % [95 % CI]", "SPL", "collisions/ep",
          "collided %", "time to goal s", "answered %", "error median cm", "error p95 cm"]
"""The columns of a navigation table."""


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
    if data.get("format") != RESULTS_FORMAT:
        raise LeaderboardError(f"{path}: format must be {RESULTS_FORMAT}, got "
                               f"{data.get('format')!r}")
    _check_suite(data, path)
    contenders = data.get("contenders")
    if not isinstance(contenders, list) or not contenders:
        raise LeaderboardError(f"{path}: contenders must be a non-empty list")
    for k, contender in enumerate(contenders):
        _check_contender(contender, data, f"{path}: contenders/{k}")
    return data


def _check_suite(data: dict[str, Any], path: Path) -> None:
    """The file's suite exists, at its version, environment, and with its split, seed and size."""
    suite = NAVIGATION_SUITES.get(data.get("suite"))
    if suite is None:
        raise LeaderboardError(f"{path}: suite {data.get('suite')!r} is not a navigation suite "
                               f"({', '.join(NAVIGATION_SUITES)})")
    if data.get("suite_version") != suite.version:
        raise LeaderboardError(f"{path}: suite_version {data.get('suite_version')!r}: "
                               f"{suite.name} is at version {suite.version}; rerun it")
    if (data.get("env"), data.get("env_kwargs")) != (suite.env_id, suite.env_kwargs):
        raise LeaderboardError(f"{path}: env and env_kwargs must be the suite's: "
                               f"{suite.env_id} {suite.env_kwargs}")
    split, seed, quick = data.get("split"), data.get("seed"), data.get("quick")
    if split not in ("dev", "test") or not isinstance(quick, bool):
        raise LeaderboardError(f"{path}: split must be 'dev' or 'test' and quick true or false")
    if type(seed) is not int or not 0 <= seed < 2**31:
        raise LeaderboardError(f"{path}: seed must be a whole number in [0, 2^31), got {seed!r}")
    if (split == "dev") != (seed == suite.dev_seed):
        raise LeaderboardError(f"{path}: a dev run uses the suite's seed {suite.dev_seed} and "
                               f"a test run another, got split {split!r} with seed {seed}")
    if data.get("episodes") != suite.size(quick):
        raise LeaderboardError(f"{path}: episodes must be {suite.size(quick)} (the suite's "
                               f"{'quick' if quick else 'full'} size), got "
                               f"{data.get('episodes')!r}")


def _check_contender(contender: Any, data: dict[str, Any], where: str) -> None:
    """A built-in pair that drove the file's episodes, its summary matching them."""
    if not isinstance(contender, dict):
        raise LeaderboardError(f"{where}: must be an object")
    navigator, localizer = contender.get("navigator"), contender.get("localizer")
    if navigator not in NAVIGATORS:
        raise LeaderboardError(f"{where}/navigator: {navigator!r} is not a built-in navigator "
                               f"({', '.join(NAVIGATORS)})")
    if not isinstance(localizer, str) or not (localizer == "truth" or is_builtin(localizer)):
        raise LeaderboardError(f"{where}/localizer: {localizer!r} is not a built-in localizer "
                               "or tracker (a board runs no plug-in in the loop)")
    episodes = contender.get("episodes")
    seeds = [data["seed"] + k for k in range(data["episodes"])]
    if not isinstance(episodes, list) or [
            e.get("seed") if isinstance(e, dict) else None for e in episodes] != seeds:
        raise LeaderboardError(f"{where}/episodes: must be the suite's {data['episodes']} "
                               f"episodes, seeds {data['seed']} to {seeds[-1]} in order")
    summary = contender.get("summary")
    if not isinstance(summary, dict):
        raise LeaderboardError(f"{where}/summary: must be an object")
    for key, value in recomputed_summary(episodes, where).items():
        if not _agree(summary.get(key), value):
            raise LeaderboardError(f"{where}/summary/{key}: the file says "
                                   f"{summary.get(key)!r}, its episodes give {value!r}")


def recomputed_summary(episodes: list[dict[str, Any]], where: str) -> dict[str, Any]:
    """The summary figures the episodes determine (:data:`RECOMPUTED`), as the run's rule has it."""
    rows = [_episode(episode, f"{where}/episodes/{k}") for k, episode in enumerate(episodes)]
    successes = [row["time_s"] for row in rows if row["success"]]
    steps = sum(row["steps"] for row in rows)
    return clean({
        "success": sum(row["success"] for row in rows) / len(rows),
        "success_interval": wilson_interval(sum(row["success"] for row in rows), len(rows)),
        "spl": sum(row["spl"] for row in rows) / len(rows),
        "collisions": sum(row["collisions"] for row in rows) / len(rows),
        "collided": sum(row["collisions"] > 0 for row in rows) / len(rows),
        "time_to_goal": sum(successes) / len(successes) if successes else math.nan,
        "answered": sum(row["answered_steps"] for row in rows) / steps if steps else math.nan})


def _episode(episode: dict[str, Any], where: str) -> dict[str, Any]:
    """An episode's figures, each of its kind and range."""
    if not isinstance(episode.get("success"), bool):
        raise LeaderboardError(f"{where}/success: must be true or false")
    for key in ("collisions", "steps", "answered_steps"):
        if type(episode.get(key)) is not int or episode[key] < 0:
            raise LeaderboardError(f"{where}/{key}: must be a whole number ≥ 0")
    if episode["answered_steps"] > episode["steps"]:
        raise LeaderboardError(f"{where}/answered_steps: more than its steps")
    for key, high in (("spl", 1.0), ("time_s", math.inf)):
        value = episode.get(key)
        if type(value) not in (int, float) or not 0.0 <= value <= high:
            raise LeaderboardError(f"{where}/{key}: must be a number in [0, {high}]")
    if episode["spl"] > 0 and not episode["success"]:
        raise LeaderboardError(f"{where}/spl: a failed episode has SPL 0")
    return episode


def _agree(claimed: Any, actual: Any) -> bool:
    if isinstance(actual, list):
        return isinstance(claimed, list) and len(claimed) == len(actual) and all(
            close(a, b) for a, b in zip(claimed, actual, strict=True))
    return close(claimed, actual)


def verify_navigation(path: Path, workers: int = 1) -> dict[str, tuple[Any, Any]]:
    """Rerun a navigation file's contenders on its episodes; every differing figure by its path.

    Runtimes are not compared (they depend on the machine). An empty answer: reproduced.
    """
    data = load_navigation(path)
    suite = NAVIGATION_SUITES[data["suite"]]
    contenders = [(c["navigator"], c["localizer"]) for c in data["contenders"]]
    fresh = drive_all(suite, contenders, data["seed"], data["episodes"], workers)
    claimed = [{key: c[key] for key in ("navigator", "localizer", "summary", "episodes")}
               for c in data["contenders"]]
    rerun = [clean({key: c[key] for key in ("navigator", "localizer", "summary", "episodes")})
             for c in fresh]
    return differences(claimed, rerun, "contenders/")


def table_rows(data: dict[str, Any]) -> list[list[str]]:
    """A file's contenders as table rows, ranked by success, then SPL, then fewer collisions."""
    ranked = sorted(data["contenders"], key=lambda c: (
        -c["summary"]["success"], -c["summary"]["spl"], c["summary"]["collisions"],
        c["navigator"], c["localizer"]))
    rows = []
    for rank, contender in enumerate(ranked, 1):
        s = contender["summary"]
        low, high = s["success_interval"]
        rows.append([str(rank), contender["navigator"], contender["localizer"],
                     f"{100 * s['success']:.0f} [{100 * low:.0f}, {100 * high:.0f}]",
                     f"{s['spl']:.3f}", f"{s['collisions']:.2f}",
                     f"{100 * s['collided']:.0f}", _fmt(s["time_to_goal"]),
                     f"{100 * s['answered']:.1f}", _fmt(s["error_median_cm"]),
                     _fmt(s["error_p95_cm"])])
    return rows


def _fmt(value: float | None) -> str:
    return "–" if value is None else f"{value:.1f}"


Table = tuple[str, str, str, str, list[str], list[list[str]]]
"""A navigation table of the board: suite, its description, title, id, column names, rows."""


def navigation_tables(directory: Path) -> list[Table]:
    """The tables of every navigation file in ``directory`` (``*.json``), by suite, then split.

    Raises:
        LeaderboardError: A file is not sound (:func:`load_navigation`).
    """
    files = [load_navigation(path) for path in sorted(directory.glob("*.json"))]
    order = list(NAVIGATION_SUITES)
    files.sort(key=lambda d: (order.index(d["suite"]), d["split"] != "dev", d["quick"],
                              d["seed"]))
    tables = []
    for data in files:
        suite = NAVIGATION_SUITES[data["suite"]]
        size = "quick size" if data["quick"] else "full size"
        title = (f"{data['split']} split (seed {data['seed']}), {size}, {data['episodes']} "
                 f"episodes per contender")
        table_id = f"board-{suite.name}-{data['split']}-{data['seed']}-{size.split()[0]}"
        tables.append((suite.name, suite.description, title, table_id, HEADER,
                       table_rows(data)))
    return tables

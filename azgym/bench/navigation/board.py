"""The navigation section of the leaderboard: its tables, and reruns of its files.

The board's navigation tables come from ``navigation.json`` files written by ``azgym bench`` on a
navigation suite (:mod:`azgym.bench.navigation.benchmark`), kept in ``leaderboard/navigation/``.
Each file is checked when read (:mod:`azgym.bench.navigation.results_file`), and the board has one
table per suite, split and seed; :func:`verify_navigation` reruns a file's episodes and compares
every figure, the pooled error quantiles included.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from azgym.bench.leaderboard.board_page import Table
from azgym.bench.leaderboard.checks import clean
from azgym.bench.leaderboard.entries import differences
from azgym.bench.leaderboard.entry_files import LeaderboardError
from azgym.bench.navigation.benchmark import drive_all
from azgym.bench.navigation.report import figure
from azgym.bench.navigation.results_file import episode_seeds, load_navigation
from azgym.bench.navigation.suites import NAVIGATION_SUITES, overlap

__all__ = ["navigation_tables", "table_rows", "verify_navigation"]

HEADER = ["#", "navigator", "localizer", "success % [95 % CI]", "SPL", "collisions/ep",
          "collided %", "time to goal s", "answered %", "error median cm", "error p95 cm"]
"""The columns of a navigation table."""


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
    """A file's contenders as table rows, ranked by SPL, then success, then fewer collisions.

    SPL ranks, as in embodied navigation's challenges: it counts a success by how directly it
    was reached, so a navigator that wanders to the goal ranks below one that drives there.
    """
    ranked = sorted(data["contenders"], key=lambda c: (
        -c["summary"]["spl"], -c["summary"]["success"], c["summary"]["collisions"],
        c["navigator"], c["localizer"]))
    rows = []
    for rank, contender in enumerate(ranked, 1):
        s = contender["summary"]
        low, high = s["success_interval"]
        rows.append([str(rank), contender["navigator"], contender["localizer"],
                     f"{100 * s['success']:.0f} [{100 * low:.0f}, {100 * high:.0f}]",
                     f"{s['spl']:.3f}", f"{s['collisions']:.2f}",
                     f"{100 * s['collided']:.0f}", figure(s["time_to_goal"]),
                     f"{100 * s['answered']:.1f}", figure(s["error_median_cm"]),
                     figure(s["error_p95_cm"])])
    return rows


def navigation_tables(directory: Path) -> list[Table]:
    """The tables of every navigation file in ``directory`` (``*.json``), by suite, then split.

    Raises:
        LeaderboardError: A file is not sound (:func:`load_navigation`), or two files of one
            suite share an episode (naming both: a board shows each episode once, and a second
            run of the same episodes under another seed or size is no new evidence).
    """
    files: list[dict[str, Any]] = []
    runs: list[tuple[str, range, Path]] = []
    for path in sorted(directory.glob("*.json")):
        data = load_navigation(path)
        episodes = episode_seeds(data)
        for name, other, where in runs:
            if name == data["suite"] and (shared := overlap(episodes, other)):
                raise LeaderboardError(
                    f"{where} and {path} share episodes of the {name} suite (seeds "
                    f"{shared.start} to {shared.stop - 1}): a board shows each episode once; "
                    "keep one of them")
        runs.append((data["suite"], episodes, path))
        files.append(data)
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

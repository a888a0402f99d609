"""A dataset entry's checks: the log it was scored on is found, unchanged, and gives its cases.

An entry made from ``azgym bench --data`` (suite ``data:NAME``, split ``data``, seed 0, full
size) records its ``dataset``: name, SHA-256 of the log's files and map
(:func:`~azgym.logs.read.log_digest`), log format and whether it is simulated. When it is read,
the log is looked for among the logs shipped with azgym and then in the datasets folder given
(``DATASETS/NAME/``; a folder there of a shipped log's name is refused); its digest must be the
entry's (a log edited since the entry was made is refused; its files are hashed before any
table is parsed, so that a replaced file costs no more than its reading), its format one this
azgym reads, its name and ``simulated`` the entry's; the entry's cases are then the log's frames
(:func:`~azgym.bench.suites.data.log_cases`), checked and recomputed as a suite's. A log that cannot
be found raises :class:`DatasetUnavailable`: the entry cannot be checked, and the board leaves
it out only when told to (``--skip-unavailable``).
"""

from __future__ import annotations

import functools
from pathlib import Path

from azgym.bench.leaderboard.entry_files import Entry
from azgym.bench.report.results import cases_digest
from azgym.bench.suites import Case
from azgym.bench.suites.data import SPLIT, log_cases
from azgym.errors import DatasetUnavailable, LeaderboardError
from azgym.logs.manifest import FORMATS, MANIFEST
from azgym.logs.problems import LogChanged, LogError
from azgym.logs.read import Log, read_log, shipped_logs

__all__ = ["DatasetUnavailable", "check_data_run", "checked_log", "dataset_cases",
           "default_datasets", "find_dataset", "is_data_entry"]

PREFIX = "data:"
"""A dataset entry's suite is ``data:`` and the dataset's name."""
DATASETS_FOLDER = "datasets"
"""The datasets folder used by default: ``datasets/`` beside the entries folder, if it exists."""


def is_data_entry(entry: Entry) -> bool:
    """Whether the entry claims to be scored on a log (by any of its suite, split or dataset)."""
    return entry["suite"].startswith(PREFIX) or entry["split"] == SPLIT or "dataset" in entry


def default_datasets(entries_dir: Path) -> Path | None:
    """``datasets/`` beside the entries folder, if there is one."""
    folder = entries_dir.parent / DATASETS_FOLDER
    return folder if folder.is_dir() else None


def find_dataset(name: str, datasets: Path | None) -> Path | None:
    """The log folder of dataset ``name``: a shipped log, else ``datasets/NAME/``, else None.

    Raises:
        LeaderboardError: The datasets folder holds a log of a shipped log's name: a shipped
            log's name is taken, so that no folder can stand in for the shipped data.
    """
    shipped = shipped_logs().get(name)
    local = None if datasets is None else datasets / name
    if local is not None and (local.is_symlink() or local.exists()):
        if shipped is not None:
            raise LeaderboardError(f"dataset: {local} has the name of a log shipped with azgym "
                                   f"({name!r}); a shipped log's name is taken: rename the "
                                   "folder and its log.toml's name")
        if (local / MANIFEST).is_file():
            return local
    return shipped


def check_data_run(entry: Entry, origin: str) -> None:
    """Suite, split, seed, size and the dataset record agree, in a format this azgym reads."""
    dataset = entry.get("dataset")
    if dataset is None:
        raise LeaderboardError(f"{origin}: dataset: an entry scored on a log ({entry['suite']}, "
                               f"split {entry['split']}) must name its dataset")
    expected = f"{PREFIX}{dataset['name']}"
    if entry["suite"] != expected:
        raise LeaderboardError(f"{origin}: suite: the entry's dataset is {dataset['name']!r}, so "
                               f"its suite is {expected!r}, not {entry['suite']!r}")
    if entry["split"] != SPLIT:
        raise LeaderboardError(f"{origin}: split: an entry scored on a log has split {SPLIT!r}, "
                               f"not {entry['split']!r}")
    if entry["seed"] != 0 or entry["quick"]:
        raise LeaderboardError(f"{origin}: seed: a log's frames are fixed: seed 0 at full size, "
                               f"the entry says seed {entry['seed']}"
                               f"{', quick' if entry['quick'] else ''}")
    if dataset["format"] not in FORMATS:
        raise LeaderboardError(f"{origin}: dataset/format: log format {dataset['format']}, this "
                               f"azgym reads formats {', '.join(map(str, FORMATS))}")
    if entry["suite_version"] != dataset["format"]:
        raise LeaderboardError(f"{origin}: suite_version: a log's suite is at its log format "
                               f"({dataset['format']}), the entry says {entry['suite_version']}")


def dataset_cases(entry: Entry, origin: str, datasets: Path | None
                  ) -> tuple[str, tuple[Case, ...]]:
    """The cases of the entry's log (found, and checked unchanged) and their digest."""
    log = checked_log(entry, origin, datasets)
    try:
        return _cases_of(log)
    except LogError as exc:  # a log without truth
        raise LeaderboardError(f"{origin}: dataset: {exc}") from None


@functools.lru_cache(maxsize=16)
def _cases_of(log: Log) -> tuple[str, tuple[Case, ...]]:
    """A log's cases and their digest, once per log read (a board checks every entry on it)."""
    cases = tuple(log_cases(log))
    return cases_digest(cases), cases


def checked_log(entry: Entry, origin: str, datasets: Path | None) -> Log:
    """The entry's log, found and checked to be the one it was scored on.

    Raises:
        DatasetUnavailable: The log is not found.
        LeaderboardError: The log differs from the one the entry was scored on, or is unreadable.
    """
    log = _found_log(entry, origin, datasets)
    dataset = entry["dataset"]
    for field, claimed, value in (("name", dataset["name"], log.manifest.name),
                                  ("simulated", dataset["simulated"], log.manifest.simulated),
                                  ("format", dataset["format"], log.manifest.format)):
        if claimed != value:
            raise LeaderboardError(f"{origin}: dataset/{field}: the entry says "
                                   f"{claimed!r}, the log's log.toml says {value!r}")
    return log


def _stamp(folder: Path) -> tuple[tuple[str, int, int], ...]:
    """The folder's files as (name, size, modification time): a changed file changes it."""
    return tuple((path.name, stat.st_size, stat.st_mtime_ns)
                 for path in sorted(folder.iterdir()) for stat in [path.stat()])


@functools.lru_cache(maxsize=16)
def _read(folder: Path, stamp: tuple[tuple[str, int, int], ...], sha256: str) -> Log:
    """A log of digest ``sha256``, read once while its files stay as ``stamp`` says.

    Every entry on the log is checked against it.
    """
    del stamp  # the cache's key only
    return read_log(folder, sha256)


def _found_log(entry: Entry, origin: str, datasets: Path | None) -> Log:
    """The entry's log, its digest the entry's, read and checked (not yet compared further)."""
    name, sha256 = entry["dataset"]["name"], entry["dataset"]["sha256"]
    folder = find_dataset(name, datasets)
    if folder is None:
        where = f"in {datasets} or " if datasets is not None else ""
        raise DatasetUnavailable(
            f"{origin}: dataset: the log {name!r} is not available ({where}among the logs "
            "shipped with azgym), so the entry cannot be checked; put the log in the datasets "
            "folder as NAME/ (--datasets DIR, default datasets/ beside the entries)", entry)
    try:
        return _read(folder.resolve(), _stamp(folder), sha256)
    except LogChanged as exc:
        raise LeaderboardError(
            f"{origin}: dataset/sha256: the log {folder} changed since the entry was made "
            f"(its files' SHA-256 is {exc.sha256}, the entry was scored on {sha256}); rerun the "
            "entry on it with azgym bench --data") from None
    except LogError as exc:
        raise LeaderboardError(f"{origin}: dataset: the log {name!r} cannot be read: "
                               f"{exc}") from None

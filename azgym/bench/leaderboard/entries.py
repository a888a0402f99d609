"""The leaderboard's entries: making one from a run, submitting, reading and rerunning them.

An entry (``leaderboard/entries/NAME.json``, format in ``entry.schema.json``) holds a localizer's
metrics on one suite (or one log, ``data:NAME``), and beside it the per-frame results they were
computed from (``NAME.frames.csv.gz``; the SHA-256 is of the uncompressed CSV). Every entry read is
checked by :func:`~azgym.bench.leaderboard.checks.validate_entry`, which recomputes every figure it
shows; ``submit`` never writes over another entry's files; ``verify`` reruns the entry's localizer
(a plug-in file and a weight file are found relative to the entry's folder, and must still have
the SHA-256 they were scored with) and compares. :mod:`azgym.bench.leaderboard.board` publishes
the entries.
"""

from __future__ import annotations

import csv
import gzip
import hashlib
import io
import json
import math
import os
import platform
import sys
from collections.abc import Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, TypedDict, cast

from azgym.bench.leaderboard.checks import ENTRY_FORMAT, clean, close, schema, validate_entry
from azgym.bench.leaderboard.entry_data import (
    DatasetUnavailable,
    checked_log,
    default_datasets,
    is_data_entry,
)
from azgym.bench.leaderboard.entry_files import (
    MAX_FRAMES_BYTES,
    Entry,
    LeaderboardError,
    read_bytes,
    read_frames,
    read_json,
)
from azgym.bench.leaderboard.entry_localizer import portable_localizer, runnable_localizer
from azgym.bench.report.results import FRAME_COLUMNS
from azgym.bench.report.summary import Dataset
from azgym.bench.run.outcome import Outcome
from azgym.bench.run.runner import Contender, run_benchmark, run_log_benchmark
from azgym.bench.suites import SUITES, get_suite
from azgym.files import prepare_folder, write_file
from azgym.progress import Progress, counter

__all__ = ["ENTRY_FORMAT", "SUITES", "DatasetUnavailable", "Entry", "LeaderboardError",
           "frames_file_text", "load_all", "load_available", "load_entries", "load_entry",
           "make_entry", "schema", "submit", "table_key", "table_mates", "validate_entry", "verify"]


class _DatasetField(TypedDict, total=False):
    """An entry's ``dataset`` (scored on a log), and nothing for a suite's entry."""

    dataset: Dataset


def frames_file_text(rows: list[list[str]], header: list[str] = FRAME_COLUMNS) -> str:
    """The per-frame results file of one localizer: CSV with ``header``, LF line ends."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


def make_entry(results_dir: Path, label: str, entries_dir: Path, *, name: str, version: str,
               authors: list[str], link: str) -> tuple[Entry, str]:
    """An entry for localizer ``label`` from an ``azgym bench`` output folder, and its frames.

    A plug-in file's spec and a weight file's path are stored relative to ``entries_dir``, with
    each file's SHA-256.
    """
    if link and not link.startswith(("http://", "https://")):
        raise LeaderboardError(f"link: must be an http:// or https:// address (or empty), got "
                               f"{link!r}")
    summary = read_json(results_dir / "results.json", "results.json of an azgym bench run",
                        allow_nan=True)
    localizers = summary.get("localizers") if isinstance(summary, dict) else None
    if not isinstance(localizers, dict) or not isinstance(localizers.get(label, {}), dict):
        raise LeaderboardError(f"{results_dir / 'results.json'}: localizers: not what azgym "
                               "bench writes")
    if label not in localizers:
        raise LeaderboardError(f"{results_dir}: no localizer {label!r} in the results; there "
                               f"are: {', '.join(localizers)}")
    if summary.get("profile_given"):
        raise LeaderboardError(
            f"{results_dir / 'results.json'}: profile_given: the run was given a profile "
            f"({summary['profile_given']}); an entry is scored with the suite's or the log's own "
            "defaults (rerun without --profile)")
    row = localizers[label]
    metrics = schema()["properties"]["metrics"]
    # the required figures (all, ci95, …, tracking), and the optional ones the run has (drift)
    figures = [*metrics["required"], *(key for key in metrics["properties"]
                                       if key not in metrics["required"] and key in row)]
    try:
        text = _frames_of(results_dir / "frames.csv", label)
        entry: Entry = {
            "format": ENTRY_FORMAT, "name": name, "version": version, "authors": authors,
            "link": link, "localizer": portable_localizer(row, entries_dir),
            "suite": summary["suite"], "suite_version": summary["suite_version"],
            "split": summary["split"], "seed": summary["seed"], "quick": summary["quick"],
            "n_frames": summary["n_frames"], "cases_sha256": summary["cases_sha256"],
            "azgym_version": summary["azgym_version"], **_dataset_of(summary),
            "metrics": clean({key: row[key] for key in figures}),
            "machine": {"platform": platform.platform(), "processor": platform.processor() or
                        platform.machine(), "cpus": os.cpu_count(),
                        "python": sys.version.split()[0]},
            "timestamp": datetime.now(UTC).isoformat(timespec="seconds"),
            "results_file": f"{name}.frames.csv.gz",
            "results_sha256": hashlib.sha256(text.encode()).hexdigest(),
        }
    except (KeyError, TypeError) as exc:
        raise LeaderboardError(f"{results_dir / 'results.json'}: not what azgym bench writes "
                               f"(no field {exc})") from None
    return entry, text


def _dataset_of(summary: dict[str, Any]) -> _DatasetField:
    """A log's run: the ``dataset`` record an entry keeps (name, SHA-256, format, simulated)."""
    if "dataset" not in summary:
        return {}
    dataset = summary["dataset"]
    return {"dataset": {"name": dataset["name"], "sha256": dataset["sha256"],
                        "format": dataset["format"], "simulated": dataset["simulated"]}}


def _frames_of(path: Path, label: str) -> str:
    """One localizer's rows of a run's frames.csv, as an entry's per-frame results.

    The run's columns are kept: a run of an azgym that wrote no estimates gives an entry
    without them (and without drift figures).
    """
    data = read_bytes(path, MAX_FRAMES_BYTES, "frames.csv of an azgym bench run")
    try:
        header, *rows = list(csv.reader(io.StringIO(data.decode("utf-8"), newline=""))) or [[]]
    except (UnicodeDecodeError, csv.Error) as exc:
        raise LeaderboardError(f"{path}: not a CSV file: {exc}") from None
    return frames_file_text([row for row in rows if row and row[0] == label], header)


def submit(results_dir: Path, label: str, entries_dir: Path, *, name: str, version: str,
           authors: list[str], link: str = "", overwrite: bool = False,
           datasets: Path | None = None) -> Path:
    """Validate an entry from a results folder and write it (and its frames) to entries_dir.

    A run on a log (``azgym bench --data``) is checked against the log, looked for in
    ``datasets`` (default: ``datasets/`` beside ``entries_dir``) and among the shipped logs.

    Raises:
        LeaderboardError: The entry is not sound, or its files would replace another entry's
            (or, without ``overwrite``, its own).
    """
    if not results_dir.is_dir():
        raise LeaderboardError(f"{results_dir}: no such folder (give the folder azgym bench "
                               "wrote)")
    prepare_folder(entries_dir)
    entry, text = make_entry(results_dir, label, entries_dir, name=name, version=version,
                             authors=authors, link=link)
    validate_entry(entry, text, f"entry {name!r}",
                   datasets=datasets or default_datasets(entries_dir))
    path = entries_dir / f"{name}.json"
    _claim(entries_dir, name, overwrite)
    # mtime=0: the same results give the same bytes.
    write_file(entries_dir / entry["results_file"], gzip.compress(text.encode(), mtime=0))
    write_file(path, json.dumps(entry, indent=1) + "\n")
    return path


def _claim(entries_dir: Path, name: str, overwrite: bool) -> None:
    """Refuse to write an entry's two files where another entry's files are."""
    mine = {f"{name}.json", f"{name}.frames.csv.gz"}
    folded = {file.lower() for file in mine}
    for existing in sorted(entries_dir.iterdir()):
        if existing.name.lower() in folded and existing.name not in mine:
            raise LeaderboardError(f"{existing}: another entry's file, whose name differs from "
                                   f"{name!r}'s only in case; pick another name")
        if existing.suffix == ".json" and existing.name not in mine:
            claimed = _results_file_of(existing)
            if claimed is not None and claimed.lower() in folded:
                raise LeaderboardError(f"{existing}: that entry's results_file is {claimed}; "
                                       f"submit will not replace another entry's files")
    taken = [entries_dir / file for file in sorted(mine) if (entries_dir / file).exists()]
    if taken and not overwrite:
        raise LeaderboardError(f"{taken[0]}: an entry of that name exists; pick another name "
                               "or pass --overwrite")


def table_key(entry: Mapping[str, Any]) -> tuple[Any, ...]:
    """What decides an entry's table on the board: its suite (a log's digest too), split, size."""
    dataset = entry.get("dataset")
    return (entry.get("suite"), entry.get("split"), entry.get("quick"),
            dataset.get("sha256") if isinstance(dataset, dict) else None)


def table_mates(path: Path) -> list[str]:
    """The other entries of ``path``'s folder that share its table on the board.

    Read from the entries' own fields, unchecked: for a warning, never for a figure.
    """
    key = table_key(read_json(path, "leaderboard entry"))
    mates = []
    for other in sorted(path.parent.glob("*.json")):
        if other.name == path.name:
            continue
        try:
            entry = read_json(other, "leaderboard entry")
        except LeaderboardError:
            continue
        if isinstance(entry, dict) and table_key(entry) == key:
            mates.append(other.name.removesuffix(".json"))
    return mates


def _results_file_of(path: Path) -> str | None:
    """The per-frame file an entry in the folder claims, if it can be read."""
    try:
        entry = read_json(path, "leaderboard entry")
    except LeaderboardError:
        return None
    claimed = entry.get("results_file") if isinstance(entry, dict) else None
    return Path(claimed).name if isinstance(claimed, str) else None


def load_entry(path: Path, datasets: Path | None = None) -> Entry:
    """Read and validate one entry file (and its per-frame results beside it).

    A dataset entry's log is looked for in ``datasets`` (default: ``datasets/`` beside the
    entry's folder) and among the shipped logs.
    """
    return _load(path, datasets or default_datasets(path.parent))[0]


def _load(path: Path, datasets: Path | None) -> tuple[Entry, Outcome]:
    """The validated entry and its per-frame outcome (the results' numbers, not their text)."""
    entry = read_json(path, "leaderboard entry")
    frames = None
    if isinstance(entry, dict) and isinstance(entry.get("results_file"), str):
        frames_path = path.parent / Path(entry["results_file"]).name
        if frames_path.is_file():
            frames = read_frames(frames_path)
    table = validate_entry(entry, frames, str(path), stem=path.name.removesuffix(".json"),
                           datasets=datasets)
    return entry, table.outcome


def load_entries(entries_dir: Path, datasets: Path | None = None) -> list[Entry]:
    """Every entry in the folder, validated (the first bad one raises, naming its file)."""
    return [entry for entry, _ in load_all(entries_dir, datasets)]


def load_all(entries_dir: Path, datasets: Path | None = None
             ) -> list[tuple[Entry, Outcome]]:
    """Every entry of the folder with its per-frame outcome, validated; names unique.

    Raises:
        DatasetUnavailable: A dataset entry's log is not found (:func:`load_available`).
    """
    loaded, unavailable = load_available(entries_dir, datasets)
    if unavailable:
        raise unavailable[0]
    return loaded


def load_available(entries_dir: Path, datasets: Path | None = None,
                   progress: Progress | None = None
                   ) -> tuple[list[tuple[Entry, Outcome]], list[DatasetUnavailable]]:
    """Every entry that can be checked, validated, and the dataset entries that cannot.

    A dataset entry whose log is not found (in ``datasets``, default ``datasets/`` beside the
    entries folder, or among the shipped logs) is returned apart, unchecked; any other problem
    raises. Names must differ in more than case (unchecked entries' too): on a file system
    that ignores case, two such entries would share their files. ``progress`` hears the count
    of entries checked.
    """
    datasets = datasets or default_datasets(entries_dir)
    loaded: list[tuple[Entry, Outcome]] = []
    unavailable: list[DatasetUnavailable] = []
    seen: dict[str, str] = {}
    paths = sorted(entries_dir.glob("*.json"))
    with counter(progress, "checking entries", len(paths), "entries") as count:
        for done, path in enumerate(paths, 1):
            try:
                entry, outcome = _load(path, datasets)
            except DatasetUnavailable as missing:
                entry, outcome = cast(Entry, missing.entry), None  # checked before it was raised
                unavailable.append(missing)
            twin = seen.setdefault(entry["name"].lower(), entry["name"])
            if twin != entry["name"]:
                raise LeaderboardError(f"{path}: name: {entry['name']!r} and {twin!r} differ "
                                       "only in case; entry names must be unique")
            if outcome is not None:
                loaded.append((entry, outcome))
            count(done)
    return loaded, unavailable


def verify(path: Path, workers: int = 1, datasets: Path | None = None,
           progress: Progress | None = None) -> dict[str, tuple[Any, Any]]:
    """Rerun an entry's localizer on its suite, or its log; return what disagrees.

    A ``dev`` entry (and an entry scored on a log) is rerun on its own frames: every accuracy
    figure (overall, intervals, by cause, by group, tracks) must be the entry's within 1e-6.
    A ``test`` entry is rerun on a fresh secret seed: its own seed is in the entry, so its
    frames are public by now, and a plug-in that reads the entry (its path is on ``verify``'s
    command line) could answer them from the truth. Its figures with 95 % intervals (``ci95``:
    the headline, the mean error, the failure rate) must then agree: each entry interval must
    overlap the rerun's (two intervals of one figure from independent draws miss each other
    far less than once in a hundred reruns; a claim the localizer cannot repeat misses). The
    other figures depend on the frames drawn and are not compared. Runtimes are never compared
    (they depend on the machine). An empty answer means the entry was reproduced. ``progress``
    hears the rerun as a run's progress.

    Raises:
        LeaderboardError: The entry is not sound, its plug-in or weight file is missing or
            changed, or the localizer cannot be built.
    """
    datasets = datasets or default_datasets(path.parent)
    entry = load_entry(path, datasets)
    contender = Contender(entry["name"], *runnable_localizer(path, entry))
    test = entry["split"] == "test"
    if is_data_entry(entry):
        result = run_log_benchmark(checked_log(entry, str(path), datasets), [contender],
                                   workers=workers, progress=progress)
    else:
        result = run_benchmark(get_suite(entry["suite"]), [contender], split=entry["split"],
                               seed=None if test else entry["seed"], quick=entry["quick"],
                               workers=workers, progress=progress)
    fresh = result.summary["localizers"][entry["name"]]
    if fresh["crashes"] == entry["n_frames"]:
        raise LeaderboardError(f"{path}: the localizer could not run on any frame: "
                               f"{fresh['first_error']}")
    # compared name by name: the entry's figures say what is compared
    stored: Mapping[str, Any] = entry["metrics"]
    rerun_figures: Mapping[str, Any] = fresh
    if test:
        return {f"ci95/{key}": (claimed, rerun) for key, claimed in stored["ci95"].items()
                if not _overlap(claimed, rerun := clean(rerun_figures["ci95"][key]))}
    claimed = {key: value for key, value in stored.items() if key != "runtime_us"}
    return differences(claimed, clean({key: rerun_figures[key] for key in claimed}), "")


def _overlap(claimed: list[Any], rerun: list[Any]) -> bool:
    """Whether two intervals as entries store them share a value.

    A bound stored as null (JSON has no infinity) is infinite: the headline's is when more
    than a quarter of the frames of a resample got no answer.
    """
    low, high, rerun_low, rerun_high = (math.inf if v is None else v for v in (*claimed, *rerun))
    return low <= rerun_high and rerun_low <= high


def differences(claimed: Any, fresh: Any, where: str) -> dict[str, tuple[Any, Any]]:
    """Every figure that differs by more than 1e-6, by its path.

    Paths name keys and list positions: ``by_cause/clean/p75_cm``, ``tracking/events/1/recovery_s``.
    """
    if isinstance(claimed, dict) and isinstance(fresh, dict):
        found: dict[str, tuple[Any, Any]] = {}
        for key in dict.fromkeys([*claimed, *fresh]):
            found |= differences(claimed.get(key), fresh.get(key), f"{where}{key}/")
        return found
    if isinstance(claimed, list) and isinstance(fresh, list) and len(claimed) == len(fresh):
        found = {}
        for k, (a, b) in enumerate(zip(claimed, fresh, strict=True)):
            found |= differences(a, b, f"{where}{k}/")
        return found
    if isinstance(claimed, (dict, list)) or isinstance(fresh, (dict, list)) or \
            not close(claimed, fresh, 1e-6):
        return {where.rstrip("/"): (claimed, fresh)}
    return {}

"""The leaderboard's entries: what a researcher submits, and the checks they cannot fake.

An entry (``leaderboard/entries/NAME.json``, format in ``entry.schema.json``) holds a localizer's
metrics on one suite, and beside it the per-frame results they were computed from
(``NAME.frames.csv.gz``; the SHA-256 is of the uncompressed CSV). Validation checks the schema,
that the suite and its version exist, that the per-frame file matches the entry's SHA-256, and
that the metrics recomputed from it are the entry's: a tampered number, a swapped file or an old
suite is rejected with the reason. ``verify`` reruns the entry's localizer and compares;
:mod:`azgym.bench.board` publishes the entries.
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
from datetime import UTC, datetime
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np

from azgym.bench.metrics import summarize_errors
from azgym.bench.results import FRAME_COLUMNS
from azgym.bench.runner import Contender, run_benchmark
from azgym.bench.suites import SUITES, get_suite
from azgym.errors import AzgymError
from azgym.files import prepare_folder, write_file

ENTRY_FORMAT = 1


class LeaderboardError(AzgymError, ValueError):
    """An entry is malformed, tampered with, or does not match what it claims."""


def schema() -> dict[str, Any]:
    """The JSON Schema of an entry."""
    return json.loads(resources.files("azgym.bench").joinpath("entry.schema.json").read_text())


def _clean(value: Any) -> Any:
    """NaN and inf become null: JSON has no NaN."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_clean(v) for v in value]
    return value


def frames_file_text(rows: list[list[str]]) -> str:
    """The per-frame results file of one localizer: CSV with FRAME_COLUMNS, LF line ends."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(FRAME_COLUMNS)
    writer.writerows(rows)
    return buffer.getvalue()


def metrics_from_frames(text: str) -> dict[str, Any]:
    """The overall statistics recomputed from a per-frame results file."""
    reader = csv.DictReader(io.StringIO(text))
    if reader.fieldnames != FRAME_COLUMNS:
        raise LeaderboardError(f"per-frame results: columns must be {FRAME_COLUMNS}, got "
                               f"{reader.fieldnames}")
    ok, position, heading = [], [], []
    for row in reader:
        ok.append(row["ok"] == "1")
        position.append(float(row["position_error_m"]))
        heading.append(float(row["heading_error_rad"]))
    return _clean(summarize_errors(np.array(position), np.array(heading), np.array(ok)))


def make_entry(results_dir: Path, label: str, *, name: str, version: str, authors: list[str],
               link: str) -> tuple[dict[str, Any], str]:
    """An entry for localizer ``label`` from an ``azgym bench`` output folder, and its frames."""
    if link and not link.startswith(("http://", "https://")):
        raise LeaderboardError(f"link: must be an http:// or https:// address (or empty), got "
                               f"{link!r}")
    summary = json.loads((results_dir / "results.json").read_text(encoding="utf-8"))
    if label not in summary["localizers"]:
        raise LeaderboardError(f"{results_dir}: no localizer {label!r} in the results; there "
                               f"are: {', '.join(summary['localizers'])}")
    with (results_dir / "frames.csv").open(newline="", encoding="utf-8") as handle:
        rows = [row for row in csv.reader(handle)][1:]
    text = frames_file_text([row for row in rows if row[0] == label])
    row = summary["localizers"][label]
    entry = {
        "format": ENTRY_FORMAT, "name": name, "version": version, "authors": authors,
        "link": link, "localizer": {"spec": row["spec"], "params": row["params"]},
        "suite": summary["suite"], "suite_version": summary["suite_version"],
        "split": summary["split"], "seed": summary["seed"], "quick": summary["quick"],
        "n_frames": summary["n_frames"], "azgym_version": summary["azgym_version"],
        "metrics": _clean({key: row[key] for key in ("all", "ci95", "by_cause", "by_group",
                                                     "runtime_us")}),
        "machine": {"platform": platform.platform(), "processor": platform.processor() or
                    platform.machine(), "cpus": os.cpu_count(), "python": sys.version.split()[0]},
        "timestamp": datetime.now(UTC).isoformat(timespec="seconds"),
        "results_file": f"{name}.frames.csv.gz",
        "results_sha256": hashlib.sha256(text.encode()).hexdigest(),
    }
    return entry, text


def validate_entry(entry: Any, frames_text: str | None, origin: str) -> None:
    """Raise :class:`LeaderboardError` naming the problem unless the entry is sound."""
    validator = jsonschema.Draft202012Validator(schema())
    errors = sorted(validator.iter_errors(entry), key=lambda e: list(e.absolute_path))
    if errors:
        first = errors[0]
        where = "/".join(str(p) for p in first.absolute_path) or "(top level)"
        raise LeaderboardError(f"{origin}: {where}: {first.message}")
    suite = SUITES.get(entry["suite"])
    if suite is None:
        raise LeaderboardError(f"{origin}: suite: unknown suite {entry['suite']!r}")
    if entry["suite_version"] != suite.version:
        raise LeaderboardError(
            f"{origin}: suite_version: {entry['suite']} is at version {suite.version}, the entry "
            f"was scored on version {entry['suite_version']}; rerun it on the current suite"
        )
    if frames_text is None:
        raise LeaderboardError(f"{origin}: results_file: {entry['results_file']} is missing")
    digest = hashlib.sha256(frames_text.encode()).hexdigest()
    if digest != entry["results_sha256"]:
        raise LeaderboardError(f"{origin}: results_sha256: the per-frame results file does not "
                               f"match (its SHA-256 is {digest})")
    recomputed = metrics_from_frames(frames_text)
    for key, claimed in entry["metrics"]["all"].items():
        actual = recomputed.get(key)
        if not _close(claimed, actual):
            raise LeaderboardError(f"{origin}: metrics/all/{key}: the entry says {claimed}, its "
                                   f"per-frame results give {actual}")
    if recomputed["n"] != entry["n_frames"]:
        raise LeaderboardError(f"{origin}: n_frames: the entry says {entry['n_frames']}, its "
                               f"per-frame results hold {recomputed['n']}")


def _close(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-9)


def submit(results_dir: Path, label: str, entries_dir: Path, *, name: str, version: str,
           authors: list[str], link: str = "", overwrite: bool = False) -> Path:
    """Validate an entry from a results folder and write it (and its frames) to entries_dir."""
    entry, text = make_entry(results_dir, label, name=name, version=version, authors=authors,
                             link=link)
    validate_entry(entry, text, f"entry {name!r}")
    prepare_folder(entries_dir)
    path = entries_dir / f"{name}.json"
    if path.exists() and not overwrite:
        raise LeaderboardError(f"{path}: an entry of that name exists; pick another name or "
                               "pass --overwrite")
    # mtime=0: the same results give the same bytes.
    write_file(entries_dir / entry["results_file"], gzip.compress(text.encode(), mtime=0))
    write_file(path, json.dumps(entry, indent=1) + "\n")
    return path


def load_entry(path: Path) -> dict[str, Any]:
    """Read and validate one entry file (and its per-frame results beside it)."""
    return _load(path)[0]


def _load(path: Path) -> tuple[dict[str, Any], str]:
    """The validated entry and its per-frame results text."""
    try:
        entry = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise LeaderboardError(f"{path}: not valid JSON: {exc}") from None
    frames = None
    if isinstance(entry, dict) and isinstance(entry.get("results_file"), str):
        frames_path = path.parent / Path(entry["results_file"]).name
        if frames_path.is_file():
            try:
                frames = gzip.decompress(frames_path.read_bytes()).decode("utf-8")
            except (OSError, EOFError, UnicodeDecodeError) as exc:
                raise LeaderboardError(f"{frames_path}: not a gzip-compressed CSV: {exc}") \
                    from None
    validate_entry(entry, frames, str(path))
    return entry, frames


def load_entries(entries_dir: Path) -> list[dict[str, Any]]:
    """Every entry in the folder, validated (the first bad one raises, naming its file)."""
    return [entry for entry, _ in load_all(entries_dir)]


def load_all(entries_dir: Path) -> list[tuple[dict[str, Any], str]]:
    """Every entry of the folder with its per-frame results, validated."""
    return [_load(path) for path in sorted(entries_dir.glob("*.json"))]


def verify(path: Path, workers: int = 1) -> dict[str, tuple[Any, Any]]:
    """Rerun an entry's localizer on its suite, split and seed; return differing figures.

    Runtimes are not compared (they depend on the machine). An empty answer means the entry's
    accuracy figures were reproduced.
    """
    entry = load_entry(path)
    result = run_benchmark(get_suite(entry["suite"]),
                           [Contender(entry["name"], entry["localizer"]["spec"],
                                      entry["localizer"]["params"])],
                           split=entry["split"], seed=entry["seed"], quick=entry["quick"],
                           workers=workers)
    fresh = _clean(result.summary["localizers"][entry["name"]]["all"])
    return {key: (claimed, fresh.get(key)) for key, claimed in entry["metrics"]["all"].items()
            if not math.isclose(claimed or 0.0, fresh.get(key) or 0.0, rel_tol=1e-6,
                                abs_tol=1e-6)}

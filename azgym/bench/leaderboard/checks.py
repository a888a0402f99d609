"""A leaderboard entry's checks: every figure it shows is recomputed, every claim is checked.

An entry (format in ``entry.schema.json``) is sound when:

- it matches the schema, its ``name`` is its file's stem and its ``results_file`` is
  ``NAME.frames.csv.gz`` (an entry cannot borrow another's results);
- its suite exists at the version it was scored on (an entry of an older version is refused:
  rerun it), a ``dev`` entry uses the suite's dev seed and a ``test`` entry another seed,
  ``azgym_version`` is a version no newer than the azgym checking it, ``timestamp`` an ISO 8601
  time with a zone and not in the future, and a plug-in file (its spec) and a weight file (its
  ``weights`` hyperparameter) are named relative to the entry's folder, each with its SHA-256;
- its per-frame results match ``results_sha256``, are well formed row by row
  (:func:`~azgym.bench.leaderboard.entry_files.parse_frames`) and cover exactly the suite's
  frames: the
  suite is redrawn for the entry's seed and size, the digest of the cases must be
  ``cases_sha256`` and each row's scenario, group and cause the drawn frame's; an entry scored
  on a log (``data:NAME``) takes its cases from the log instead, found and checked unchanged by
  :mod:`~azgym.bench.leaderboard.entry_data`;
- each estimate (its pose, in the columns a per-frame file has had since the drift figures)
  has the row's errors against its frame's truth;
- every figure under ``metrics`` (overall, 95 % intervals, by cause, by group, runtimes, and the
  track figures and drift of a suite of driven routes) equals the one recomputed from the
  per-frame results and the suite's cases as drawn for the coverage check, and ``n_frames``
  their count.

Runtimes are the submitter's measurements: they are checked for consistency with the per-frame
results, and only a rerun (``azgym leaderboard verify``) measures them again.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
from datetime import UTC, datetime, timedelta
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np

from azgym._version import __version__
from azgym.bench.leaderboard.entry_data import check_data_run, dataset_cases, is_data_entry
from azgym.bench.leaderboard.entry_files import Entry, FrameTable, LeaderboardError, parse_frames
from azgym.bench.leaderboard.plugin_files import WEIGHTS, is_portable, is_relative, plugin_path
from azgym.bench.report.results import (
    ESTIMATE_COLUMNS,
    cases_digest,
    contender_metrics,
    frame_number,
)
from azgym.bench.run.outcome import RunOutcome
from azgym.bench.suites import NO_TEST_SPLIT, SUITES, Case
from azgym.core import pose_error
from azgym.errors import AzgymError
from azgym.localize.registry import parse_spec

__all__ = ["ENTRY_FORMAT", "clean", "close", "release", "schema", "suite_cases", "validate_entry"]

ENTRY_FORMAT = 4
"""The entry format this azgym writes and reads (``format`` in ``entry.schema.json``); 3 added
the track figures (``metrics/tracking``), 4 the headline that charges every refusal
(``p75_all_cm``) and intervals from a block bootstrap on routes."""
ERROR_COLUMNS = ("position_error_m", "heading_error_rad")
"""A per-frame file's columns of an estimate's errors, which its pose must give."""
CLOCK_SLACK = timedelta(minutes=10)
"""A timestamp may be this far ahead of the checking machine's clock."""
_VERSION = re.compile(r"^(\d+(?:\.\d+)*)(?:(?:a|b|rc)\d+)?(?:\.post\d+)?(?:\.dev\d+)?"
                      r"(?:\+[A-Za-z0-9.]+)?$")
"""A PEP 440 version (the forms azgym's releases take); the release part is compared."""


def schema() -> dict[str, Any]:
    """The JSON Schema of an entry."""
    schema_file = resources.files("azgym.bench.leaderboard").joinpath("entry.schema.json")
    return json.loads(schema_file.read_text())


def clean(value: Any) -> Any:
    """NaN and inf become null: JSON has no NaN."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: clean(v) for k, v in value.items()}
    if isinstance(value, list):
        return [clean(v) for v in value]
    return value


def validate_entry(entry: Any, frames_text: str | None, origin: str,
                   stem: str | None = None, datasets: Path | None = None) -> FrameTable:
    """Raise :class:`LeaderboardError` naming the problem unless the entry is sound.

    Args:
        entry: The entry, as read from its JSON.
        frames_text: Its per-frame results (None: the file is missing).
        origin: Where it came from, for messages.
        stem: Its file's name without ``.json`` (None: not yet written; its name is used).
        datasets: Where a dataset entry's log is looked for first (:mod:`.entry_data`).

    Returns:
        The per-frame results, checked and read.

    Raises:
        DatasetUnavailable: A dataset entry's log is not found (every other check passed).
    """
    _check_schema(entry, origin)
    _check_identity(entry, origin, entry["name"] if stem is None else stem)
    _check_run(entry, origin)
    if frames_text is None:
        raise LeaderboardError(f"{origin}: results_file: {entry['results_file']} is missing")
    digest = hashlib.sha256(frames_text.encode()).hexdigest()
    if digest != entry["results_sha256"]:
        raise LeaderboardError(f"{origin}: results_sha256: the per-frame results file does not "
                               f"match (its SHA-256 is {digest})")
    cases = _entry_cases(entry, origin, datasets)
    table = parse_frames(frames_text, origin, cases)
    _check_coverage(entry, table, cases, origin)
    _check_estimates(table, cases, origin)
    _check_figures(entry, table, cases, origin)
    return table


def _check_schema(entry: Any, origin: str) -> None:
    if isinstance(entry, dict) and entry.get("format", ENTRY_FORMAT) != ENTRY_FORMAT:
        raise LeaderboardError(f"{origin}: format: the entry is in format {entry['format']!r}, "
                               f"this azgym reads format {ENTRY_FORMAT}; make it again with "
                               "azgym bench and azgym leaderboard submit")
    validator = jsonschema.Draft202012Validator(schema())
    errors = sorted(validator.iter_errors(entry), key=lambda e: list(map(str, e.absolute_path)))
    if errors:
        first = errors[0]
        where = "/".join(str(p) for p in first.absolute_path) or "(top level)"
        raise LeaderboardError(f"{origin}: {where}: {first.message}")


def _check_identity(entry: Entry, origin: str, stem: str) -> None:
    """The name is the file's stem, and the per-frame results are the entry's own file."""
    if entry["name"] != stem:
        raise LeaderboardError(f"{origin}: name: {entry['name']!r}, but the file is "
                               f"{stem}.json (an entry's name is its file's name)")
    expected = f"{entry['name']}.frames.csv.gz"
    if entry["results_file"] != expected:
        raise LeaderboardError(f"{origin}: results_file: must be {expected}, got "
                               f"{entry['results_file']!r}")


def _check_run(entry: Entry, origin: str) -> None:
    """Suite (or dataset) and version, seed, azgym version, time, and the localizer's files."""
    if is_data_entry(entry):
        check_data_run(entry, origin)
    else:
        _check_suite_run(entry, origin)
    _check_version(entry["azgym_version"], origin)
    _check_timestamp(entry["timestamp"], origin)
    localizer = entry["localizer"]
    if _spec_params(localizer["spec"], origin):
        raise LeaderboardError(f"{origin}: localizer/spec: {localizer['spec']!r} carries "
                               "hyperparameters; an entry keeps them in localizer/params, where "
                               "its files are checked")
    if plugin_path(localizer["spec"]) is not None:
        if not is_portable(localizer["spec"]):
            raise LeaderboardError(f"{origin}: localizer/spec: {localizer['spec']!r} is an "
                                   "absolute path; a plug-in file is named relative to the "
                                   "entry's folder")
        if "sha256" not in localizer:
            raise LeaderboardError(f"{origin}: localizer/sha256: a plug-in file's SHA-256 is "
                                   "required (submit records it)")
    weights = localizer["params"].get(WEIGHTS)
    if isinstance(weights, str):
        if not is_relative(weights):
            raise LeaderboardError(f"{origin}: localizer/params/{WEIGHTS}: {weights!r} is an "
                                   "absolute path; a weight file is named relative to the "
                                   "entry's folder")
        if "weights_sha256" not in localizer:
            raise LeaderboardError(f"{origin}: localizer/weights_sha256: a weight file's "
                                   "SHA-256 is required (submit records it)")


def _spec_params(spec: str, origin: str) -> dict[str, object]:
    """The hyperparameters a spec writes after its name (an entry's must write none)."""
    try:
        return parse_spec(spec)[1]
    except AzgymError as exc:
        raise LeaderboardError(f"{origin}: localizer/spec: {exc}") from None


def _check_suite_run(entry: Entry, origin: str) -> None:
    """A suite's entry: the suite at the entry's version, and the split's seed."""
    suite = SUITES.get(entry["suite"])
    if suite is None:
        raise LeaderboardError(f"{origin}: suite: unknown suite {entry['suite']!r}")
    if entry["suite_version"] != suite.version:
        raise LeaderboardError(
            f"{origin}: suite_version: {entry['suite']} is at version {suite.version}, the entry "
            f"was scored on version {entry['suite_version']}; rerun it on the current suite")
    if entry["split"] == "dev" and entry["seed"] != suite.dev_seed:
        raise LeaderboardError(f"{origin}: seed: the dev split of {suite.name} is drawn from seed "
                               f"{suite.dev_seed}, the entry says {entry['seed']}")
    if entry["split"] == "test" and suite.routes:
        raise LeaderboardError(f"{origin}: {NO_TEST_SPLIT.format(suite=suite.name)}")
    if entry["split"] == "test" and entry["seed"] == suite.dev_seed:
        raise LeaderboardError(f"{origin}: seed: a test split is drawn from a fresh seed; "
                               f"{suite.dev_seed} is the dev split's")


def release(version: str) -> tuple[int, ...] | None:
    """The release numbers of a version (``"1.2.0rc1"`` → (1, 2)), or None if it is none."""
    match = _VERSION.match(version)
    if match is None:
        return None
    numbers = [int(part) for part in match.group(1).split(".")]
    while len(numbers) > 1 and numbers[-1] == 0:
        numbers.pop()
    return tuple(numbers)


def _check_version(version: str, origin: str) -> None:
    claimed = release(version)
    if claimed is None:
        raise LeaderboardError(f"{origin}: azgym_version: {version!r} is not a version")
    running = release(__version__)
    if running is not None and claimed > running:
        raise LeaderboardError(f"{origin}: azgym_version: {version} is newer than the azgym "
                               f"checking it ({__version__})")


def _check_timestamp(text: str, origin: str) -> None:
    try:
        moment = datetime.fromisoformat(text)
    except ValueError:
        moment = None
    if moment is None or moment.tzinfo is None:
        raise LeaderboardError(f"{origin}: timestamp: {text!r} is not an ISO 8601 date and time "
                               "with a time zone (e.g. 2026-01-31T12:00:00+00:00)")
    if moment > datetime.now(UTC) + CLOCK_SLACK:
        raise LeaderboardError(f"{origin}: timestamp: {text} is in the future")


@functools.lru_cache(maxsize=16)
def suite_cases(name: str, version: int, seed: int, quick: bool
                ) -> tuple[str, tuple[Case, ...]]:
    """A suite's cases and their digest, drawn once for the coverage check and the figures.

    ``version`` is part of the key so that a cache never outlives a suite's change.
    """
    cases = SUITES[name].build(seed, quick)
    return cases_digest(cases), tuple(cases)


def _entry_cases(entry: Entry, origin: str, datasets: Path | None
                 ) -> tuple[Case, ...]:
    """The entry's frames (the suite's draw, or the log's), their digest the entry's."""
    if is_data_entry(entry):
        digest, cases = dataset_cases(entry, origin, datasets)
        other = f"the log {entry['dataset']['name']} holds ("
        rerun = "rerun it with azgym bench --data"
    else:
        digest, cases = suite_cases(entry["suite"], entry["suite_version"], entry["seed"],
                                    entry["quick"])
        other = f"{entry['suite']} v{entry['suite_version']} draws now ({_run(entry)}; "
        rerun = "rerun it on the current suite"
    if entry["cases_sha256"] != digest:
        raise LeaderboardError(
            f"{origin}: cases_sha256: the entry was scored on other frames than {other}their "
            f"digest is {digest}); {rerun}")
    return cases


def _run(entry: Entry) -> str:
    """A suite entry's draw, in words."""
    return f"seed {entry['seed']}, {'quick' if entry['quick'] else 'full'}"


def _check_coverage(entry: Entry, table: FrameTable, cases: tuple[Case, ...],
                    origin: str) -> None:
    """The per-frame results hold exactly the entry's frames, each its scenario/group/cause."""
    has = f"the log {entry['dataset']['name']} has" if is_data_entry(entry) else \
        f"{entry['suite']} ({_run(entry)}) has"
    frames = [(c.scenario, c.group, c.cause) for c in cases]
    if len(table.cause) != len(frames):
        raise LeaderboardError(f"{origin}: per-frame results: {len(table.cause)} frames, but "
                               f"{has} {len(frames)}")
    rows = zip(table.scenario, table.group, table.cause, strict=True)
    for index, (row, drawn) in enumerate(zip(rows, frames, strict=True)):
        if row != drawn:
            raise LeaderboardError(
                f"{origin}: per-frame results: line {index + 2}: frame "
                f"{frame_number(cases[index], index)} is "
                f"{'/'.join(drawn)} (scenario/group/cause), the file says {'/'.join(row)}")
    if entry["n_frames"] != len(frames):
        raise LeaderboardError(f"{origin}: n_frames: the entry says {entry['n_frames']}, its "
                               f"per-frame results hold {len(frames)}")


def _check_estimates(table: FrameTable, cases: tuple[Case, ...], origin: str) -> None:
    """Each estimate's errors against its frame's truth are its row's (to 1e-9 m and rad).

    The drift figures come from the estimates, the others from the errors: a file whose
    estimates do not give its errors would show figures of two different sets of answers.
    """
    if not isinstance(table.outcome, RunOutcome):
        return  # a file written before the estimates were: no drift figures either
    outcome = table.outcome
    for k in np.flatnonzero(outcome.ok).tolist():
        found = pose_error(tuple(outcome.estimate[k].tolist()), cases[k].pose)
        claimed = (outcome.position[k], outcome.heading[k])
        for value, written, column in zip(found, claimed, ERROR_COLUMNS, strict=True):
            if not (math.isnan(value) and math.isnan(written)) and not close(value, written):
                raise LeaderboardError(
                    f"{origin}: per-frame results: line {k + 2}, column {column}: "
                    f"{float(written)!r}, but the estimate ({', '.join(ESTIMATE_COLUMNS)}) is "
                    f"{value!r} off the truth of frame {frame_number(cases[k], k)}")


def _check_figures(entry: Entry, table: FrameTable, cases: tuple[Case, ...],
                   origin: str) -> None:
    """Every stored figure is the one its per-frame results (on the suite's cases) give."""
    reference_us = entry["metrics"]["runtime_us"]["reference_us"]
    recomputed = clean(contender_metrics(table.outcome, cases, reference_us))
    _compare(entry["metrics"], recomputed, "metrics", origin)


def _compare(claimed: Any, actual: Any, where: str, origin: str) -> None:
    """``claimed`` equals ``actual`` (to 1e-9): the same keys, lengths and numbers."""
    if isinstance(actual, dict):
        if not isinstance(claimed, dict) or set(claimed) != set(actual):
            have = sorted(claimed) if isinstance(claimed, dict) else claimed
            raise LeaderboardError(f"{origin}: {where}: the entry has {have}, its per-frame "
                                   f"results give {sorted(actual)}")
        for key, value in actual.items():
            _compare(claimed[key], value, f"{where}/{key}", origin)
    elif isinstance(actual, list):
        if not isinstance(claimed, list) or len(claimed) != len(actual):
            raise LeaderboardError(f"{origin}: {where}: the entry says {claimed}, its per-frame "
                                   f"results give {actual}")
        for k, (a, b) in enumerate(zip(claimed, actual, strict=True)):
            _compare(a, b, f"{where}/{k}", origin)
    elif not close(claimed, actual):
        raise LeaderboardError(f"{origin}: {where}: the entry says {claimed}, its per-frame "
                               f"results give {actual}")


def close(a: Any, b: Any, tolerance: float = 1e-9) -> bool:
    """Whether two figures agree: numbers to ``tolerance``, anything else only when equal.

    None (a figure that does not exist) agrees only with None, an event's name only with itself.
    """
    if not (_is_number(a) and _is_number(b)):
        return a == b
    return math.isclose(float(a), float(b), rel_tol=tolerance, abs_tol=tolerance)


def _is_number(value: Any) -> bool:
    """An int or a float (a bool is neither here)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)

"""Reading what a leaderboard submitter wrote, safely: JSON, gzip and per-frame CSV.

Anyone can write these files, so each reader bounds what it takes (size, nesting, the
decompressed size of a gzip file) and turns every way a file can be malformed into a
:class:`LeaderboardError` that names the file, and the row, column or field at fault, instead
of a crash inside a library.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import math
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NotRequired, TypedDict

import numpy as np

from azgym.bench.leaderboard.frame_screen import HEADING_LIMIT, screened_columns
from azgym.bench.report.results import (
    ESTIMATE_COLUMNS,
    FRAME_COLUMNS,
    OUTCOME_COLUMNS,
    frame_number,
)
from azgym.bench.report.summary import ContenderMetrics, Dataset, RunIdentity
from azgym.bench.run.outcome import Outcome, RunOutcome
from azgym.errors import LeaderboardError
from azgym.untrusted import read_regular_file

if TYPE_CHECKING:
    from azgym.bench.suites import Case

__all__ = ["HEADING_LIMIT", "MAX_FRAMES_BYTES", "MAX_JSON_BYTES", "MAX_JSON_DEPTH", "Entry",
           "EntryLocalizer", "FrameTable", "LeaderboardError", "Machine", "parse_frames",
           "exact_keys", "read_bytes", "read_frames", "read_json"]

MAX_JSON_BYTES = 16 * 2**20
"""An entry or results.json larger than this is refused (a real one is a few kB)."""
MAX_JSON_DEPTH = 16
"""Deepest nesting of lists and objects an entry may have (a real one has 5)."""
MAX_FRAMES_BYTES = 64 * 2**20
"""Per-frame results larger than this, compressed or decompressed, are refused (the largest
suite's are about 4 MB)."""


class EntryLocalizer(TypedDict):
    """An entry's localizer: its spec and hyperparameters.

    A plug-in file (in the spec) and a weight file (the ``weights`` hyperparameter) are named
    relative to the entry's folder, each with its SHA-256.
    """

    spec: str
    params: dict[str, Any]
    sha256: NotRequired[str]
    weights_sha256: NotRequired[str]


class Machine(TypedDict):
    """The machine an entry's runtimes were measured on."""

    platform: str
    processor: str
    cpus: int | None
    python: str


class Entry(RunIdentity):
    """A leaderboard entry, as ``entry.schema.json`` states it and its checks have passed.

    Its metrics are a contender's row of the run's summary
    (:class:`~azgym.bench.report.results.ContenderMetrics`), JSON's null for a NaN or infinite
    figure; ``dataset`` is an entry scored on a log's.
    """

    format: int
    name: str
    version: str
    authors: list[str]
    link: str
    localizer: EntryLocalizer
    dataset: NotRequired[Dataset]
    metrics: ContenderMetrics[float | None]
    machine: Machine
    timestamp: str
    results_file: str
    results_sha256: str


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def read_bytes(path: Path, limit: int, what: str) -> bytes:
    """A file's bytes (:func:`azgym.untrusted.read_regular_file`).

    Refused when missing, not a regular file (a FIFO is refused, never waited on), unreadable or
    larger than ``limit``.
    """
    return read_regular_file(path, limit, what, LeaderboardError)


def exact_keys(table: Any, keys: set[str], where: str) -> None:
    """Refuse ``table`` unless it is an object with exactly ``keys``.

    Each stray or missing key is named, at ``where``.
    """
    if not isinstance(table, dict):
        raise LeaderboardError(f"{where}: must be an object")
    if set(table) != keys:
        extra, missing = sorted(set(table) - keys), sorted(keys - set(table))
        raise LeaderboardError(f"{where}: " + "; ".join(
            part for part in (f"unknown keys {extra}" if extra else "",
                              f"missing keys {missing}" if missing else "") if part))


def read_json(path: Path, what: str, allow_nan: bool = False) -> Any:
    """A JSON file's value, nested at most :data:`MAX_JSON_DEPTH` deep.

    Args:
        path: The file.
        what: What it is, for messages.
        allow_nan: Accept NaN and Infinity (``results.json`` has them; an entry has null).
    """
    data = read_bytes(path, MAX_JSON_BYTES, what)
    try:
        value = json.loads(data.decode("utf-8"),
                           parse_constant=None if allow_nan else _refuse_constant)
    except UnicodeDecodeError as exc:
        raise LeaderboardError(f"{path}: not UTF-8 text: {exc}") from None
    except RecursionError:
        raise LeaderboardError(f"{path}: not valid JSON: nested deeper than "
                               f"{MAX_JSON_DEPTH} levels") from None
    except ValueError as exc:  # JSONDecodeError, NaN, an integer of too many digits
        raise LeaderboardError(f"{path}: not valid JSON: {exc}") from None
    _check_depth(value, path)
    return value


def _check_depth(value: Any, path: Path) -> None:
    """Refuse nesting deeper than :data:`MAX_JSON_DEPTH` (walked without recursion)."""
    stack = [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (dict, list)):
            if depth >= MAX_JSON_DEPTH:
                raise LeaderboardError(f"{path}: not valid JSON: nested deeper than "
                                       f"{MAX_JSON_DEPTH} levels")
            children = item.values() if isinstance(item, dict) else item
            stack.extend((child, depth + 1) for child in children)


def read_frames(path: Path) -> str:
    """The text of a gzip-compressed per-frame results file, its decompressed size capped."""
    data = read_bytes(path, MAX_FRAMES_BYTES, "per-frame results file")
    try:
        with gzip.GzipFile(fileobj=io.BytesIO(data)) as stream:
            text = stream.read(MAX_FRAMES_BYTES + 1)
    except (OSError, EOFError, zlib.error) as exc:
        raise LeaderboardError(f"{path}: not a gzip-compressed CSV: {exc}") from None
    if len(text) > MAX_FRAMES_BYTES:
        raise LeaderboardError(f"{path}: decompresses to more than {MAX_FRAMES_BYTES // 2**20} "
                               "MiB; refused (a real per-frame file is a few MB)")
    try:
        return text.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise LeaderboardError(f"{path}: not UTF-8 text: {exc}") from None


@dataclass
class FrameTable:
    """A per-frame results file, checked row by row.

    Attributes:
        label: The localizer's label in the run (the same on every row).
        scenario: Each frame's scenario.
        group: Each frame's group.
        cause: Each frame's cause.
        outcome: Each frame's outcome, as the runner recorded it (a
            :class:`~azgym.bench.run.outcome.RunOutcome`, with the estimates, when the file
            has their columns).
    """

    label: str
    scenario: list[str]
    group: list[str]
    cause: list[str]
    outcome: Outcome


def parse_frames(text: str, origin: str, cases: Sequence[Case] | None = None) -> FrameTable:
    """Read per-frame results (:data:`FRAME_COLUMNS`), refusing any row the runner cannot write.

    Frames are in order, numbered as the results number them
    (:func:`~azgym.bench.report.results.frame_number`): by the recording's numbers of ``cases`` (a
    log's frames), else 0, 1, …; an estimate (``ok`` 1) has finite errors, the position's
    non-negative and the heading's in [0, π] (NaN where the case's truth has no heading); a
    frame without one (``ok`` 0) has NaN errors; a runtime is NaN (the call raised) or finite
    and non-negative; a frame that raised has no estimate. The estimate's columns
    (:data:`~azgym.bench.report.results.ESTIMATE_COLUMNS`) hold a finite pose, NaN without an
    estimate (that its errors against the truth are the row's is checked once the rows are
    known to be the frames': :func:`~azgym.bench.leaderboard.checks.validate_entry`); a file
    written before they were added (:data:`~azgym.bench.report.results.OUTCOME_COLUMNS` only)
    still reads, without estimates. Rows beyond ``cases`` are checked as numbered from 0 (the
    count is the coverage check's).

    A sound file is read at once (:func:`~azgym.bench.leaderboard.frame_screen.screened_columns`);
    any other row by row, which names the first row at fault.
    """
    table = _read_at_once(text, cases)
    if table is not None:
        return table
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = next(reader, None)
        if header is None or header not in (FRAME_COLUMNS, OUTCOME_COLUMNS):
            raise LeaderboardError(f"{origin}: per-frame results: the columns must be "
                                   f"{','.join(FRAME_COLUMNS)}, got {header}")
        table = FrameTable("", [], [], [], Outcome.empty(0))
        values: list[tuple[float, ...]] = []
        errors: list[str] = []
        for row in reader:
            case = cases[len(values)] if cases is not None and len(values) < len(cases) else None
            values.append(_frame_row(row, (reader.line_num, len(values)), case, origin, table,
                                     header))
            errors.append(row[len(OUTCOME_COLUMNS) - 1])
    except csv.Error as exc:
        raise LeaderboardError(f"{origin}: per-frame results: line {reader.line_num}: not CSV: "
                               f"{exc}") from None
    # per row: ok, the two errors and the runtime, then the estimate's columns if there are any
    columns = np.array(values, dtype=float).reshape(len(values),
                                                    4 + len(header) - len(OUTCOME_COLUMNS))
    outcome = Outcome(columns[:, 0].astype(bool), columns[:, 1], columns[:, 2], columns[:, 3],
                      errors)
    table.outcome = outcome if header == OUTCOME_COLUMNS else \
        RunOutcome(**vars(outcome), estimate=columns[:, 4:].reshape(-1, 3))
    return table


def _read_at_once(text: str, cases: Sequence[Case] | None) -> FrameTable | None:
    """The table of a file whose every row is sound, None if any row may not be (or not CSV)."""
    try:
        header, *rows = csv.reader(io.StringIO(text, newline=""))
    except (csv.Error, ValueError):  # not CSV, or no header at all
        return None
    if header not in (FRAME_COLUMNS, OUTCOME_COLUMNS):
        return None
    screened = screened_columns(rows, len(header), cases)
    if screened is None:
        return None
    label, scenario, group, cause, errors, numbers = screened
    outcome = Outcome(numbers[:, 0].astype(bool), numbers[:, 1], numbers[:, 2], numbers[:, 3],
                      errors)
    return FrameTable(label, scenario, group, cause, outcome if header == OUTCOME_COLUMNS else
                      RunOutcome(**vars(outcome), estimate=numbers[:, 4:].reshape(-1, 3)))


def _frame_row(row: list[str], place: tuple[int, int], case: Case | None, origin: str,
               table: FrameTable, header: list[str]) -> tuple[float, ...]:
    """One row's checked values: ok, errors, runtime (and the estimate, with its columns).

    ``place`` is its line and index; its labels are added to ``table``. ``case`` is the frame
    the row must be (None: a frame numbered by its place, with a heading).
    """
    line, index = place
    where = f"{origin}: per-frame results: line {line}"
    if len(row) != len(header):
        raise LeaderboardError(f"{where}: {len(row)} columns, expected {len(header)} "
                               f"({','.join(header)})")
    label, frame, scenario, group, cause, ok, position, heading, micros, error = \
        row[:len(OUTCOME_COLUMNS)]
    if index == 0:
        table.label = label
    elif label != table.label:
        raise LeaderboardError(f"{where}, column localizer: {label!r}, but the first row's is "
                               f"{table.label!r} (one localizer a file)")
    expected = index if case is None else frame_number(case, index)
    if frame != str(expected):
        numbered = "from 0" if case is None or case.frame is None else "as the log numbers them"
        raise LeaderboardError(f"{where}, column frame: expected {expected} (frames in order, "
                               f"{numbered}), got {frame!r}")
    if ok not in ("0", "1"):
        raise LeaderboardError(f"{where}, column ok: must be 0 or 1, got {ok!r}")
    numbers = [_number(text, name, where) for text, name in
               ((position, "position_error_m"), (heading, "heading_error_rad"),
                (micros, "micros"))]
    _check_errors(ok == "1", numbers[0], numbers[1], where,
                  case is None or not math.isnan(case.pose[2]))
    if not (math.isnan(numbers[2]) or 0.0 <= numbers[2] < math.inf):
        raise LeaderboardError(f"{where}, column micros: must be NaN or finite and >= 0, got "
                               f"{micros!r}")
    if error and ok == "1":
        raise LeaderboardError(f"{where}, column error: a frame that raised has no estimate "
                               "(ok must be 0)")
    if not error and math.isnan(numbers[2]):
        raise LeaderboardError(f"{where}, column micros: NaN, but the frame did not raise")
    estimate = [_number(text, name, where) for text, name in
                zip(row[len(OUTCOME_COLUMNS):], ESTIMATE_COLUMNS, strict=False)]
    if estimate:
        _check_estimate(estimate, ok == "1", where)
    table.scenario.append(scenario)
    table.group.append(group)
    table.cause.append(cause)
    return (float(ok == "1"), *numbers, *estimate)


def _number(text: str, column: str, where: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise LeaderboardError(f"{where}, column {column}: not a number: {text!r}") from None


def _check_errors(ok: bool, position: float, heading: float, where: str,
                  has_heading: bool) -> None:
    """An estimate's errors are finite and in range; a missing estimate's are NaN.

    Without a true heading (position-only truth) an estimate's heading error is NaN.
    """
    if not ok:
        for value, column in ((position, "position_error_m"), (heading, "heading_error_rad")):
            if not math.isnan(value):
                raise LeaderboardError(f"{where}, column {column}: must be NaN where ok is 0 "
                                       f"(no estimate), got {value!r}")
        return
    if not 0.0 <= position < math.inf:
        raise LeaderboardError(f"{where}, column position_error_m: must be finite and >= 0, "
                               f"got {position!r}")
    if not has_heading and not math.isnan(heading):
        raise LeaderboardError(f"{where}, column heading_error_rad: must be NaN (the truth has "
                               f"no heading), got {heading!r}")
    if has_heading and not 0.0 <= heading <= HEADING_LIMIT:
        raise LeaderboardError(f"{where}, column heading_error_rad: must be in [0, π], got "
                               f"{heading!r}")


def _check_estimate(estimate: list[float], ok: bool, where: str) -> None:
    """An estimate's pose is finite; a frame without an estimate has NaN there."""
    for value, column in zip(estimate, ESTIMATE_COLUMNS, strict=True):
        if not (math.isfinite(value) if ok else math.isnan(value)):
            wanted = "finite where ok is 1" if ok else "NaN where ok is 0 (no estimate)"
            raise LeaderboardError(f"{where}, column {column}: must be {wanted}, got {value!r}")

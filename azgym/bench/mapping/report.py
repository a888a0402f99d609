"""A mapping run's results: its file ``mapping.json`` and its scores as a text table.

:func:`mapping_record` turns a :class:`~azgym.bench.mapping.scoring.MappingResult` into what
``mapping.json`` holds: the run's identity, then per mapper its summary and its record of every
case (:func:`case_record`: the fields of a :class:`~azgym.bench.mapping.scoring.CaseScore`, each
figure as it was scored), from which a reader recomputes the summary
(:mod:`azgym.bench.mapping.results_file`). JSON has no infinity and no NaN: a figure that is
either is null (an unplaced beacon's error, a refused frame's localization error, a figure with
nothing to be made of). :func:`write_mapping` writes the file (:data:`MAPPING_FILES`, never over
one without ``--overwrite``: the command claims the names first), :func:`score_table` prints the
mappers ranked (:func:`rank_key`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from collections.abc import Iterable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from azgym._version import __version__
from azgym.bench.leaderboard.checks import clean
from azgym.bench.mapping.scoring import CaseScore, MapperSummary, MappingResult
from azgym.bench.report.table import cell
from azgym.files import prepare_folder, write_file

__all__ = ["COLUMNS", "HEADER", "KIND", "LEGEND", "MAPPING_FILE", "MAPPING_FILES",
           "MAPPING_NOTE", "MAPPING_PART", "RESULTS_FORMAT", "SUITE", "case_record",
           "mapping_record", "rank_key", "ranked_rows", "score_table", "summary_record",
           "write_mapping"]

SUITE = "mapping"
"""The mapping suite ``azgym bench mapping`` runs."""
KIND = "mapping"
"""``kind`` of a mapping results file, which tells it from a frame suite's or a navigation one's."""
RESULTS_FORMAT = 1
"""The layout of ``mapping.json`` (``format``)."""
MAPPING_FILE = "mapping.json"
"""The file a mapping run is kept in."""
MAPPING_FILES = (MAPPING_FILE,)
"""What ``azgym bench mapping`` writes into ``--out``: refused there without ``--overwrite``."""

COLUMNS = (("median cm", "error_median_cm", 1), ("p95 cm", "error_p95_cm", 1),
           ("worst cm", "error_worst_cm", 1), ("placed %", "placed_percent", 1),
           ("precision %", "moved_precision", 0), ("recall %", "moved_recall", 0),
           ("delay s", "delay_median_s", 1), ("worst delay s", "delay_worst_s", 1),
           ("in 10 s %", "detected_within_10s_percent", 0),
           ("false moves", "false_moves_unchanged", 0),
           ("ransac p75 cm", "localization_p75_updated_cm", 1),
           ("true map p75 cm", "localization_p75_true_cm", 1),
           ("ratio", "localization_ratio", 2), ("failures", "failures", 0),
           ("runtime s", "runtime_median_s", 2))
"""The columns after the mapper's name: title, :class:`MapperSummary` field, decimals."""
HEADER = ["#", "mapper", *(title for title, _, _ in COLUMNS)]
"""The column names of a mapping table (the printed one and the board's)."""
PERCENT = frozenset({"moved_precision", "moved_recall"})
"""Summary fields kept as shares (0-1) and shown as percentages."""
LEGEND = (
    "median, p95, worst: the beacon error, each scored beacon's distance from its place on the "
    "updated map (the prior updated by the answer) to the truth, pooled over the cases; a beacon "
    "the drive made observable that the map has no place for counts as infinitely wrong (inf). "
    "placed: the scored beacons the answers placed. precision, recall: of the beacons said "
    "moved, against those truly moved (- where none was said, or none moved). delay: the "
    "median, and worst, time from a moved beacon first being seen from two places 0.5 m apart "
    "to the first 2 s checkpoint whose answer says it moved (inf: not within 30 s); in 10 s: "
    "the share detected that soon. false moves: beacons said moved on the unchanged cases. "
    "ransac p75: ransac's p75 position error over every frame on the updated maps, a refusal "
    "infinite, of the cases whose p75 on the true map is finite; true map p75: the same on the "
    "true maps; ratio: the first over the second. "
    "failures: calls that raised, overran the time limit or died (charged as placing nothing). "
    "runtime: the median seconds of a whole drive's call. Ranked by the error p95, which "
    "charges the beacons a mapper leaves unplaced or stale, then by the median.")
"""What each column of the table is: printed under it and shown on the board."""


MAPPING_PART = "Mapping: beacon maps surveyed and repaired from a drive"
"""The heading of the board's mapping part (:mod:`azgym.bench.mapping.board`)."""
MAPPING_NOTE = (
    "A mapper places the beacons from one drive (its frames, odometry and IMU, and its start "
    "pose) and what was known before (a map, possibly stale, and two surveyed anchors), and says "
    "which beacons moved; each case's map is perturbed in a known way: unknown but for the "
    "anchors, beacons moved, a rack moved, or unchanged. Generated by azgym from its own mappers "
    "only; `azgym leaderboard verify FILE` reruns a file's cases. Columns: " + LEGEND)


def case_record(score: CaseScore) -> dict[str, Any]:
    """A case's score as ``mapping.json`` keeps it: its fields by name (null: inf or NaN)."""
    # Through JSON once: the tuples become lists, which clean() walks.
    record: dict[str, Any] = clean(json.loads(json.dumps(dataclasses.asdict(score))))
    return record


def mapping_record(result: MappingResult) -> dict[str, Any]:
    """What ``mapping.json`` holds of a run: its identity, then each mapper's summary and cases."""
    return {
        "kind": KIND, "format": RESULTS_FORMAT, "suite": result.suite,
        "suite_version": result.version, "split": result.split, "seed": result.seed,
        "quick": result.quick, "time_limit_s": result.time_limit,
        "azgym_version": __version__, "python": sys.version.split()[0],
        "timestamp": datetime.now(UTC).isoformat(timespec="seconds"),
        "cases": list(result.cases),
        "mappers": [{"mapper": mapper, "summary": summary_record(result.summaries[mapper]),
                     "cases": [case_record(score) for score in result.scores[mapper]]}
                    for mapper in result.mappers]}


def summary_record(summary: MapperSummary) -> dict[str, Any]:
    """A mapper's summary as the file keeps it: every field but the mapper's name."""
    record: dict[str, Any] = clean({key: value for key, value
                                    in dataclasses.asdict(summary).items() if key != "mapper"})
    return record


def write_mapping(result: MappingResult, out: Path, name: str = MAPPING_FILE) -> Path:
    """Write ``out/name`` (JSON, each case record on a line of its own); its path."""
    record = mapping_record(result)
    head = json.dumps({key: value for key, value in record.items() if key != "mappers"},
                      indent=1)
    mappers = ",\n".join(_mapper_text(mapper) for mapper in record["mappers"])
    return write_file(prepare_folder(out) / name,
                      f'{head[:-2]},\n "mappers": [\n{mappers}\n ]\n}}\n')


def _mapper_text(mapper: dict[str, Any]) -> str:
    """A mapper's record: its name and summary, then each case's record on a line of its own."""
    cases = ",\n".join("   " + json.dumps(case, allow_nan=False) for case in mapper["cases"])
    return (f'  {{"mapper": {json.dumps(mapper["mapper"])}, "summary": '
            f'{json.dumps(mapper["summary"], allow_nan=False)}, "cases": [\n{cases}\n  ]}}')


def rank_key(summary: MapperSummary) -> tuple[float, float, str]:
    """A mapper's place in a table: the beacon error p95, then the median, then its name.

    The p95 ranks, not the median: a stale map is right about most beacons, so the null
    mapper (``prior``) has a median of 0 on every case but those with an unknown map, and only
    the tail shows the beacons it leaves unplaced or moved. A missing figure (NaN) ranks last.
    """
    def low(value: float) -> float:
        return math.inf if math.isnan(value) else value

    return low(summary.error_p95_cm), low(summary.error_median_cm), summary.mapper


def ranked_rows(summaries: Iterable[MapperSummary]) -> list[list[str]]:
    """The mappers ranked (:func:`rank_key`), a row each: rank, mapper, then :data:`COLUMNS`.

    A figure's cell is ``inf`` when it is infinite, ``-`` when there is none.
    """
    rows = []
    for rank, summary in enumerate(sorted(summaries, key=rank_key), 1):
        values = dataclasses.asdict(summary)
        rows.append([str(rank), summary.mapper,
                     *(cell(100 * values[key] if key in PERCENT else values[key], decimals)
                       for _, key, decimals in COLUMNS)])
    return rows


def score_table(summaries: Iterable[MapperSummary]) -> str:
    """The mappers, ranked (:func:`rank_key`), as a text table."""
    rows = ranked_rows(summaries)
    widths = [max(len(text) for text in column) for column in zip(HEADER, *rows, strict=True)]
    return "\n".join("  ".join(text.ljust(width) if k < 2 else text.rjust(width)
                               for k, (text, width) in enumerate(zip(line, widths, strict=True)))
                     for line in (HEADER, *rows))

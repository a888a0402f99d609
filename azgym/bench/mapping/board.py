"""The mapping section of the leaderboard: its tables, and reruns of its files.

The board's mapping tables come from ``mapping.json`` files written by ``azgym bench mapping``
(:mod:`azgym.bench.mapping.report`), kept in ``leaderboard/mapping/``. Each file is checked
when read (:mod:`azgym.bench.mapping.results_file`: its summaries recomputed from its cases),
and the board has one table per suite and size, its mappers ranked by
:func:`~azgym.bench.mapping.report.rank_key`; :func:`verify_mapping` reruns a file's mappers on
its cases and compares every figure but the runtimes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from azgym.bench.leaderboard.board_page import Table
from azgym.bench.leaderboard.entries import differences
from azgym.bench.leaderboard.entry_files import LeaderboardError
from azgym.bench.mapping.report import HEADER, case_record, ranked_rows, summary_record
from azgym.bench.mapping.results_file import MappingFile, load_mapping
from azgym.bench.mapping.suites import MAPPING_SUITES
from azgym.progress import Progress

__all__ = ["FRAME_LISTS", "RUNTIMES", "mapping_tables", "table_rows", "verify_mapping"]

RUNTIMES = ("runtime", "runtime_median_s")
"""The figures a rerun does not compare: they depend on the machine."""
FRAME_LISTS = ("localization_updated", "localization_true")
"""A case record's figures of every frame, told one entry a list when a rerun differs."""
BOARD_GLYPHS = {"inf": "∞", "-": "–"}
"""How the board shows an infinite and a missing figure (the printed table's ``inf`` and ``-``)."""


def verify_mapping(path: Path, workers: int = 1, progress: Progress | None = None
                   ) -> dict[str, tuple[Any, Any]]:
    """Rerun a mapping file's mappers on its cases; every differing figure by its path.

    Runtimes (:data:`RUNTIMES`) are not compared; a case's frames that differ are one entry
    (:data:`FRAME_LISTS`). An empty answer: reproduced.
    """
    from azgym.bench.mapping.benchmark import run_mapping

    checked = load_mapping(path)
    data = checked.record
    fresh = run_mapping(data["suite"], list(checked.scores), quick=data["quick"],
                        workers=workers, time_limit=data["time_limit_s"], progress=progress)
    claimed = {mapper["mapper"]: _compared(mapper["summary"], mapper["cases"])
               for mapper in data["mappers"]}
    rerun = {mapper: _compared(summary_record(fresh.summaries[mapper]),
                               [case_record(score) for score in fresh.scores[mapper]])
             for mapper in checked.scores}
    return _per_list(differences(claimed, rerun, "mappers/"))


def _per_list(found: dict[str, tuple[Any, Any]]) -> dict[str, tuple[Any, Any]]:
    """The differing figures, those of a case's frames (:data:`FRAME_LISTS`) one entry a list.

    A changed map moves hundreds of frames' errors at once: the first that differs is shown,
    with how many more do.
    """
    grouped: dict[str, tuple[Any, Any]] = {}
    counts: dict[str, int] = {}
    for key, (claimed, fresh) in found.items():
        head, _, frame = key.rpartition("/")
        if not head.endswith(FRAME_LISTS):
            grouped[key] = (claimed, fresh)
        elif head not in counts:
            counts[head] = 0
            grouped[head] = (f"frame {frame}: {claimed!r}", f"frame {frame}: {fresh!r}")
        else:
            counts[head] += 1
    for head, more in counts.items():
        if more:
            claimed, fresh = grouped[head]
            grouped[head] = (f"{claimed} (and {more} more frames)", fresh)
    return grouped


def _compared(summary: dict[str, Any], cases: list[dict[str, Any]]) -> dict[str, Any]:
    """A mapper's summary and case records without their runtimes."""
    return {"summary": {key: value for key, value in summary.items() if key not in RUNTIMES},
            "cases": [{key: value for key, value in case.items() if key not in RUNTIMES}
                      for case in cases]}


def table_rows(checked: MappingFile) -> list[list[str]]:
    """A file's mappers as table rows, ranked, each figure from its recomputed summary."""
    return [[*row[:2], *(BOARD_GLYPHS.get(text, text) for text in row[2:])]
            for row in ranked_rows(checked.summaries.values())]


def mapping_tables(directory: Path) -> list[Table]:
    """The tables of every mapping file in ``directory`` (``*.json``), by suite, then size.

    Raises:
        LeaderboardError: A file is not sound (:func:`load_mapping`), or two files hold runs of
            the same suite and size (naming both: a board shows each case once).
    """
    files: dict[tuple[str, bool], MappingFile] = {}
    for path in sorted(directory.glob("*.json")):
        checked = load_mapping(path)
        key = (checked.record["suite"], checked.record["quick"])
        if key in files:
            raise LeaderboardError(
                f"{files[key].path} and {path} are both runs of the {key[0]} suite's "
                f"{'quick' if key[1] else 'full'} cases: a board shows each case once; keep "
                "one of them")
        files[key] = checked
    order = list(MAPPING_SUITES)
    tables = []
    for (name, quick), checked in sorted(files.items(),
                                         key=lambda item: (order.index(item[0][0]), item[0][1])):
        suite = MAPPING_SUITES[name]
        size = "quick" if quick else "full"
        record = checked.record
        title = (f"dev split (seed {record['seed']}), {size} size, {len(record['cases'])} cases, "
                 f"{record['time_limit_s']:g} s a call")
        tables.append((suite.name, suite.description, title, f"board-{suite.name}-{size}",
                       HEADER, table_rows(checked)))
    return tables

"""A navigation run's results: its file and its scores as a text table, one row per contender.

``azgym evaluate navigator`` prints a row per localizer, ``azgym bench`` on a navigation suite a row
per (navigator, localizer); the columns are the scores of
:func:`azgym.bench.navigation.scoring.summarize` and the wall time. Both keep the run in
:data:`RESULTS_FILE`, written by :meth:`NavigationResult.write`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from azgym.files import prepare_folder, write_file

__all__ = ["COLUMNS", "RESULTS_FILE", "NavigationResult", "figure", "score_table"]

RESULTS_FILE = "navigation.json"
"""The file a navigation run is kept in."""

COLUMNS = (("success %", 1), ("SPL", 3), ("collisions/ep", 2), ("collided %", 1),
           ("time to goal s", 1),
           ("answered %", 1), ("error median cm", 1), ("error p95 cm", 1), ("runtime s", 1))
"""The columns after the contender's names, each with its decimals."""


def figure(value: float | None, decimals: int = 1) -> str:
    """A figure as a table shows it: a dash where it does not exist (no answer, no success)."""
    return "–" if value is None or math.isnan(value) else f"{value:.{decimals}f}"


def score_table(rows: Sequence[dict[str, Any]], keys: Sequence[str]) -> str:
    """The scores of each row (its summary's figures and ``runtime_s``), named by ``keys``."""
    firsts = [max(len(key), *(len(str(row[key])) for row in rows)) for key in keys]
    widths = [max(len(title), 7) for title, _ in COLUMNS]
    lines = ["  ".join(key.ljust(width) for key, width in zip(keys, firsts, strict=True))
             + "".join(f"  {title:>{width}}" for (title, _), width
                       in zip(COLUMNS, widths, strict=True))]
    for row in rows:
        summary = row["summary"]
        values = (100 * summary["success"], summary["spl"], summary["collisions"],
                  100 * summary["collided"], summary["time_to_goal"], 100 * summary["answered"],
                  summary["error_median_cm"], summary["error_p95_cm"], row["runtime_s"])
        lines.append("  ".join(str(row[key]).ljust(width)
                               for key, width in zip(keys, firsts, strict=True))
                     + "".join(f"  {figure(value, decimals):>{width}}" for (_, decimals), width,
                               value in zip(COLUMNS, widths, values, strict=True)))
    return "\n".join(lines)


@dataclass(frozen=True)
class NavigationResult:
    """A navigation run: the record its results file holds, and how the record's rows are named.

    Attributes:
        record: The run's identity and its rows (JSON types only), as the file keeps them.
        rows: The record's key of the rows, one per contender.
        names: The fields that name a row in the table (e.g. its navigator and localizer).
    """

    record: dict[str, Any]
    rows: str = "contenders"
    names: tuple[str, ...] = ("navigator", "localizer")

    def table(self) -> str:
        """The scores of every row as a text table (:func:`score_table`)."""
        return score_table(self.record[self.rows], self.names)

    def write(self, out: Path, name: str = RESULTS_FILE) -> Path:
        """Write the record to ``out/name`` (JSON, one space of indent); its path."""
        return write_file(prepare_folder(out) / name, json.dumps(self.record, indent=1) + "\n")

"""The navigation scores as a text table: one row per contender, the way both commands print them.

``azgym evaluate navigator`` prints a row per localizer, ``azgym bench`` on a navigation suite a row
per (navigator, localizer); the columns are the scores of
:func:`azgym.bench.navigation.scoring.summarize` and the wall time.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

__all__ = ["COLUMNS", "figure", "score_table"]

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

"""Ranking, the one rule, and the ranked text table ``azgym bench`` prints."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

RANK_BY = "p75_cm"
"""Boards rank by the 75th percentile of the position error, the EvAAL competitions' headline."""


def rank_key(stats: Mapping[str, Any], name: str) -> tuple[float, float, str]:
    """Sort key of a contender: p75 error (missing last), then availability (higher first), name.

    Args:
        stats: Its overall statistics (``summarize_errors``; NaN or None where missing).
        name: Its name, the last tie-break, so that the order never depends on input order.
    """
    p75 = stats.get(RANK_BY)
    availability = stats.get("availability")
    return (math.inf if p75 is None or math.isnan(p75) else p75,
            -(availability or 0.0), name)


def ranked_table(summary: dict[str, Any]) -> str:
    """The contenders of a run, ranked (:func:`rank_key`), as a text table."""
    rows = sorted(summary["localizers"].items(), key=lambda item: rank_key(item[1]["all"],
                                                                           item[0]))
    width = max([len("localizer"), *(len(label) for label, _row in rows)])
    lines = [f"{summary['suite']} v{summary['suite_version']} ({summary['split']}, seed "
             f"{summary['seed']}{', quick' if summary['quick'] else ''}): "
             f"{summary['n_frames']} frames; errors in cm",
             f"{'#':>2} {'localizer':<{width}} {'avail':>6} {'mean':>8} {'median':>8} {'p75':>8} "
             f"{'p75 95% CI':>15} {'p95':>8} {'fail':>6} {'µs':>9} {'×ransac':>8}"]
    for rank, (label, row) in enumerate(rows, 1):
        a, t = row["all"], row["runtime_us"]
        low, high = row["ci95"].get("p75_cm", [math.nan, math.nan])
        lines.append(f"{rank:>2} {label:<{width}} {100 * a['availability']:5.1f}% "
                     f"{a['mean_cm']:8.2f} {a['median_cm']:8.2f} {a['p75_cm']:8.2f} "
                     f"{f'{low:.2f}-{high:.2f}':>15} "
                     f"{a['p95_cm']:8.1f} {100 * a['failure_rate']:5.1f}% {t['median']:9.1f} "
                     f"{t['ratio_to_ransac']:8.2f}")
        if row["crashes"]:
            lines.append(f"   ! {row['crashes']} frames raised: {row['first_error']}")
    return "\n".join(lines)


def tracking_table(summary: dict[str, Any]) -> str:
    """The track figures of a run with sequences (:mod:`azgym.bench.tracking`), or ""."""
    rows = [(label, row["tracking"]) for label, row in summary["localizers"].items()
            if row.get("tracking")]
    if not rows:
        return ""
    width = max([len("localizer"), *(len(label) for label, _ in rows)])
    lines = ["tracks: availability after the first fix; worst error and frames over 1 m outside "
             "2 s after a kidnapping; seconds to a fix within 10 cm after each event",
             f"   {'localizer':<{width}} {'avail':>6} {'max cm':>9} {'>1 m':>5}  recovery s"]
    for label, track in sorted(rows, key=lambda item: rank_key(summary["localizers"][item[0]][
            "all"], item[0])):
        recoveries = " ".join(
            f"{event['event']} " + ("never" if event["recovery_s"] is None
                                    else f"{event['recovery_s']:.1f}")
            for event in track["events"]) or "-"
        lines.append(f"   {label:<{width}} {100 * track['availability_after_first_fix']:5.1f}% "
                     f"{track['max_cm_outside_kidnaps']:9.1f} "
                     f"{track['frames_over_1m_outside_kidnaps']:5d}  {recoveries}")
    return "\n".join(lines)


def run_report(summary: dict[str, Any], seconds: float, written: list[Any]) -> str:
    """What ``azgym bench`` prints after a run: the ranking, the tracks, the time and the files."""
    parts = ["", ranked_table(summary)]
    if tracks := tracking_table(summary):
        parts.append(f"\n{tracks}")
    parts.append(f"\n{seconds:.1f} s; wrote {', '.join(map(str, written))}")
    return "\n".join(parts)

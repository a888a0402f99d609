"""Ranking, the one rule, and the ranked text table ``azgym bench`` prints."""

from __future__ import annotations

import math
import textwrap
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Final

from azgym.bench.report.tracking import SHOWN_DRIFT_M, drift_at
from azgym.metrics import BLOCK_SECONDS, FAILURE_DISTANCE, HEADLINE
from azgym.profile import field_texts

if TYPE_CHECKING:
    from azgym.bench.report.summary import Summary

__all__ = ["LEGEND", "POSITION_ONLY", "RANK_BY", "cell", "heading_scored", "interval_cell",
           "profile_lines", "rank_key", "ranked_table", "run_report", "tracking_table",
           "trajectory_lines"]

RANK_BY: Final = HEADLINE
"""Boards rank by the p75 position error over every frame, a refusal infinite (EvAAL's rule)."""
LEGEND = (
    f"p75: the 75th percentile of the position error over every frame, a frame without an "
    f"answer counting as infinitely wrong (inf: more than a quarter unanswered). Ranked by it, "
    f"then by fail, then by the answered p75; a p75 over {FAILURE_DISTANCE:g} m means more than "
    f"a quarter of the frames failed, and ranks after every other by fail, then by the answered "
    f"p75. 95% CI: a bootstrap of p75, resampling a route's frames in {BLOCK_SECONDS:g} s blocks "
    f"and other frames one by one. avail: frames answered. fail: frames with no answer or one "
    f"more than {FAILURE_DISTANCE:g} m off. answered median, p75, p95, mean: over the answered "
    f"frames only. µs: median time of a frame's call; ×ransac: that over ransac's median in the "
    f"same run.")
"""What each column of a ranked table is: printed under it and shown on the board."""
POSITION_ONLY = ("position-only truth: heading not scored (the truth has no heading; the heading "
                 "figures are null in results.json, and so is the drift: evo's relative pose "
                 "error needs the true orientation)")
"""Printed under a ranked table when the truth has no heading (:func:`heading_scored`)."""


def heading_scored(summary: Summary) -> bool:
    """Whether a run's heading was scored: False when an answered frame's heading figure is None.

    :func:`~azgym.metrics.summarize_errors` leaves a heading figure out (None) only when
    estimates were given and the truth had no heading to score them against.
    """
    return all(row["all"].get("heading_median_deg", 0.0) is not None
               for row in summary["localizers"].values())


def rank_key(stats: Mapping[str, Any], name: str
             ) -> tuple[bool, float, float, float, float, str]:
    """Sort key of a contender: the headline, then failures, answered p75, availability, name.

    The headline (:data:`~azgym.metrics.HEADLINE`) charges every refusal, so a contender
    that refuses the frames it would get wrong ranks below one that answers them. A headline
    over :data:`~azgym.metrics.FAILURE_DISTANCE` (infinite included) says that more than
    a quarter of the frames failed: no answer, or an answer more than that far off. Such
    contenders rank after every other, ordered by their failure rate (lower first), then by the
    p75 of their answered frames, so that a wild guess is worth no more than a refusal: both
    are failures. A missing figure (NaN or None; JSON keeps an infinite one as None) ranks last.

    Args:
        stats: Its overall statistics (``summarize_errors``; NaN or None where missing).
        name: Its name, the last tie-break, so that the order never depends on input order.
    """
    headline, failures = _or_inf(stats.get(RANK_BY)), _or_inf(stats.get("failure_rate"))
    failed = headline > FAILURE_DISTANCE * 100
    availability = stats.get("availability")
    first, second = (failures, headline) if failed else (headline, failures)
    return (failed, first, second, _or_inf(stats.get("p75_cm")), -(availability or 0.0), name)


def _or_inf(value: float | None) -> float:
    """A figure to sort on: a missing one (None, NaN) last."""
    return math.inf if value is None or math.isnan(value) else value


def cell(value: float | None, digits: int = 2) -> str:
    """A figure as a table shows it: ``inf`` for an infinite one, ``-`` for a missing one."""
    if value is None or math.isnan(value):
        return "-"
    return "inf" if math.isinf(value) else f"{value:.{digits}f}"


def interval_cell(bounds: Sequence[float | None] | None, digits: int = 2) -> str:
    """A 95 % interval as ``low-high``; ``-`` without a finite lower bound (none, or infinite)."""
    if not bounds or bounds[0] is None or not math.isfinite(bounds[0]) or bounds[1] is None \
            or math.isnan(bounds[1]):
        return "-"
    return f"{cell(bounds[0], digits)}-{cell(bounds[1], digits)}"


def ranked_table(summary: Summary) -> str:
    """The contenders of a run, ranked (:func:`rank_key`), as a text table with its legend."""
    rows = sorted(summary["localizers"].items(), key=lambda item: rank_key(item[1]["all"],
                                                                           item[0]))
    width = max([len("localizer"), *(len(label) for label, _row in rows)])
    lines = [f"{summary['suite']} v{summary['suite_version']} ({summary['split']}, seed "
             f"{summary['seed']}{', quick' if summary['quick'] else ''}): "
             f"{summary['n_frames']} frames; errors in cm",
             *profile_lines(summary),
             f"{'':>2} {'':<{width}} {'':>8} {'':>17} {'':>6} {'':>6} "
             f"{'answered frames':-^35}",
             f"{'#':>2} {'localizer':<{width}} {'p75':>8} {'p75 95% CI':>17} {'avail':>6} "
             f"{'fail':>6} {'median':>8} {'p75':>8} {'p95':>8} {'mean':>8} {'µs':>9} "
             f"{'×ransac':>8}"]
    for rank, (label, row) in enumerate(rows, 1):
        a, t = row["all"], row["runtime_us"]
        lines.append(f"{rank:>2} {label:<{width}} {cell(a[RANK_BY]):>8} "
                     f"{interval_cell(row['ci95'].get(RANK_BY)):>17} "
                     f"{100 * a['availability']:5.1f}% {100 * a['failure_rate']:5.1f}% "
                     f"{cell(a['median_cm']):>8} {cell(a['p75_cm']):>8} "
                     f"{cell(a['p95_cm'], 1):>8} {cell(a['mean_cm']):>8} "
                     f"{cell(t['median'], 1):>9} {cell(t['ratio_to_ransac']):>8}")
        if row["crashes"]:
            lines.append(f"   ! {row['crashes']} frames raised: {row['first_error']}")
    lines += textwrap.wrap(LEGEND, 100)
    if not heading_scored(summary):
        lines += textwrap.wrap(POSITION_ONLY, 100)
    return "\n".join(lines)


def profile_lines(summary: Summary) -> list[str]:
    """The profile a run applied (``summary["profile"]``), wrapped: [] when none was."""
    given = list(field_texts(summary.get("profile") or {}).values())
    return textwrap.wrap(f"profile (the contenders' defaults): {', '.join(given)}", 100) \
        if given else []


def tracking_table(summary: Summary) -> str:
    """The track figures of a run with sequences (:mod:`azgym.bench.report.tracking`), or ""."""
    rows = [(label, track) for label, row in summary["localizers"].items()
            if (track := row["tracking"]) is not None]
    if not rows:
        return ""
    width = max([len("localizer"), *(len(label) for label, _ in rows)])
    lines = textwrap.wrap(
        "tracks: availability after the first fix; worst error and frames over 1 m outside 2 s "
        f"after a kidnapping; drift over {SHOWN_DRIFT_M:g} m travelled (evo's relative pose "
        f"error: translation as % of {SHOWN_DRIFT_M:g} m, heading in °/m); seconds to a fix "
        "within 10 cm after each event", 100)
    lines.append(f"   {'localizer':<{width}} {'avail':>6} {'max cm':>9} {'>1 m':>5} "
                 f"{f'{SHOWN_DRIFT_M:g} m %':>7} {'°/m':>6}  recovery s")
    for label, track in sorted(rows, key=lambda item: rank_key(summary["localizers"][item[0]][
            "all"], item[0])):
        recoveries = " ".join(
            f"{event['event']} " + ("never" if event["recovery_s"] is None
                                    else f"{event['recovery_s']:.1f}")
            for event in track["events"]) or "-"
        drift = drift_at(summary["localizers"][label].get("drift"))
        moved, turned = (None, None) if drift is None else \
            (drift["translation_pct"], drift["heading_deg_per_m"])
        lines.append(f"   {label:<{width}} {100 * track['availability_after_first_fix']:5.1f}% "
                     f"{track['max_cm_outside_kidnaps']:9.1f} "
                     f"{track['frames_over_1m_outside_kidnaps']:5d} {cell(moved):>7} "
                     f"{cell(turned, 3):>6}  {recoveries}")
    return "\n".join(lines)


def trajectory_lines(summary: Summary) -> list[str]:
    """What a run's TUM files hold (:mod:`azgym.bench.report.trajectories`): [] without any."""
    files = summary.get("trajectories")
    if not files:
        return []
    left_out = ", ".join(
        f"{label} {sum(record['refused'] for record in row['sequences'].values())}"
        for label, row in summary["localizers"].items())
    text = (f"trajectories: {files['folder']}/, TUM files that evo reads, one per sequence "
            f"({len(files['files'])}) in {files['folder']}/{files['folders']['truth']}/ and "
            f"in each contender's folder; refused frames left out: {left_out}")
    if not files["truth_heading"]:
        text += ("; the truth has no heading, so its files carry the identity orientation "
                 "(not a measurement)")
    return textwrap.wrap(f"{text}.", 100)


def run_report(summary: Summary, seconds: float, written: list[Any]) -> str:
    """What ``azgym bench`` prints after a run: the ranking, the tracks, the time and the files."""
    parts = ["", ranked_table(summary)]
    if tracks := tracking_table(summary):
        parts.append(f"\n{tracks}")
    if trajectories := trajectory_lines(summary):
        parts.append("\n" + "\n".join(trajectories))
    parts.append(f"\n{seconds:.1f} s; wrote {', '.join(map(str, written))}")
    return "\n".join(parts)

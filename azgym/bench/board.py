"""The published board: ranked Markdown tables (``leaderboard/README.md``) and a sortable page.

A suite of driven routes adds track columns (:data:`TRACK_COLUMNS`) after the accuracy ones, and
one with events (an outage, a kidnapping) the worst recovery (:data:`RECOVERY_COLUMN`).

Everything an entry's submitter wrote (name, version, authors, link) is escaped where it is
shown: in Markdown, ``|``, backslashes, line breaks and HTML cannot forge a row or a tag; on the
page, HTML is escaped; a link is shown only when it is an ``http://`` or ``https://`` address.
"""

from __future__ import annotations

import base64
import csv
import html
import importlib.util
import io
from pathlib import Path
from typing import Any
from urllib.parse import quote

import numpy as np

from azgym.bench.leaderboard import LeaderboardError, load_all
from azgym.bench.suites import SUITES, get_suite
from azgym.bench.table import rank_key
from azgym.bench.tracking import KIDNAP_WINDOW_S, RECOVERED_CM
from azgym.files import prepare_folder, write_file

WEB_SCHEMES = ("http://", "https://")
"""A link is shown only with one of these schemes (no ``javascript:``, no local files)."""


def web_link(link: str) -> str | None:
    """The link made safe for an attribute or a Markdown target, or None if it is no web address."""
    if not isinstance(link, str) or not link.startswith(WEB_SCHEMES):
        return None
    return quote(link, safe=":/?#[]@!$&'*+,;=%~")


def markdown_cell(text: str) -> str:
    """Text as one Markdown table cell: no line break, no unescaped ``|``, no raw HTML."""
    escaped = html.escape(text, quote=False).replace("\\", "\\\\").replace("|", "\\|")
    return " ".join(escaped.splitlines())


KINDS = (("dev", False, "dev split, full size: the ranking"),
         ("dev", True, "dev split, quick size: fewer frames, ranked apart"),
         ("test", False, "test split: each entry on frames drawn from its own seed, ranked apart"),
         ("test", True, "test split, quick size: ranked apart"))
"""The tables of a suite: runs of different splits or sizes are never ranked together."""


def _ranked(loaded: list[tuple[dict[str, Any], str]], suite: str, split: str,
            quick: bool) -> list[tuple[dict[str, Any], str]]:
    rows = [(e, frames) for e, frames in loaded
            if (e["suite"], e["split"], e["quick"]) == (suite, split, quick)]
    return sorted(rows, key=lambda pair: rank_key(pair[0]["metrics"]["all"], pair[0]["name"]))


def _interval(bounds: list[float] | None) -> str:
    return "–" if not bounds or None in bounds else f"{bounds[0]:.2f}–{bounds[1]:.2f}"


def _fmt(value: Any, digits: int = 2) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


COLUMNS = [("#", None), ("name", None), ("version", None), ("authors", None),
           ("availability %", "availability"), ("mean cm", "mean_cm"),
           ("median cm", "median_cm"), ("p75 cm", "p75_cm"), ("p75 95% CI", None),
           ("p95 cm", "p95_cm"),
           ("failures %", "failure_rate"), ("µs", None), ("× ransac", None), ("split", None),
           ("azgym", None)]
NAME_COLUMN = 1
"""The column of the entry's name, which links to its web link."""
TRACK_COLUMNS = ("track avail. %", "track max cm")
"""A route suite's track figures: availability after the first fix, the largest error outside
kidnapping windows (:mod:`azgym.bench.tracking`)."""
RECOVERY_COLUMN = "worst recovery s"
"""On a suite with events: the longest recovery, or ``never (k/N)`` when k of N events had none."""
TRACKS_AT = [c for c, _ in COLUMNS].index("failures %") + 1
"""The track columns come after the accuracy ones."""
TRACKS_NOTE = (
    "Suites of driven routes add track columns: *track avail. %* is the share of frames with an "
    "estimate from each route's first fix on, *track max cm* the largest error outside the "
    f"{KIDNAP_WINDOW_S:g} s after a kidnapping; on a suite with events (an outage, a "
    f"kidnapping), *{RECOVERY_COLUMN}* is the longest time from an event to an estimate within "
    f"{RECOVERED_CM:g} cm of the truth, *never (k/N)* when k of its N events were never "
    "recovered from.")


def _percent(value: float | None) -> str:
    return _fmt(None if value is None else 100 * value, 1)


def _cells(rank: int, entry: dict[str, Any], tracks: int) -> list[str]:
    """A table row: the entry's figures, with ``tracks`` track cells (0, 2 or 3)."""
    stats, runtime = entry["metrics"]["all"], entry["metrics"]["runtime_us"]
    return [str(rank), entry["name"], entry["version"], ", ".join(entry["authors"]),
            _percent(stats["availability"]), _fmt(stats["mean_cm"]), _fmt(stats["median_cm"]),
            _fmt(stats["p75_cm"]), _interval(entry["metrics"].get("ci95", {}).get("p75_cm")),
            _fmt(stats["p95_cm"], 1), _percent(stats["failure_rate"]),
            *_track_cells(entry["metrics"]["tracking"])[:tracks],
            _fmt(runtime["median"], 1), _fmt(runtime["ratio_to_ransac"]),
            f"{entry['split']} ({'quick' if entry['quick'] else 'full'})",
            entry["azgym_version"]]


def _track_cells(tracking: dict[str, Any] | None) -> list[str]:
    """Availability after the first fix, the largest error outside kidnaps, worst recovery."""
    if tracking is None:
        return ["–"] * (len(TRACK_COLUMNS) + 1)
    events = tracking["events"]
    never = sum(1 for event in events if event["recovery_s"] is None)
    worst = f"never ({never}/{len(events)})" if never else \
        _fmt(max((event["recovery_s"] for event in events), default=None), 1)
    return [_percent(tracking["availability_after_first_fix"]),
            _fmt(tracking["max_cm_outside_kidnaps"], 1), worst]


def _header(entries: list[dict[str, Any]]) -> tuple[list[str], int]:
    """A table's column names and how many track columns it has (the suite's, for every row)."""
    tracks = [entry["metrics"]["tracking"] for entry in entries]
    extra = [*TRACK_COLUMNS] if any(tracks) else []
    if any(track and track["events"] for track in tracks):
        extra.append(RECOVERY_COLUMN)
    names = [c for c, _ in COLUMNS]
    return names[:TRACKS_AT] + extra + names[TRACKS_AT:], len(extra)


def build(entries_dir: Path, out_dir: Path) -> list[Path]:
    """Write the board: README.md (tables) and index.html (sortable, self-contained).

    Each suite has one table per split and size (:data:`KINDS`); only the dev split's full
    size is the suite's ranking.

    Raises:
        LeaderboardError: The entries folder is missing or holds no entry (a typo must not
            replace the board with an empty one), or an entry is not sound.
    """
    if not entries_dir.is_dir() or not any(entries_dir.glob("*.json")):
        raise LeaderboardError(f"{entries_dir}: no leaderboard entries there (*.json); the "
                               "board is left as it is")
    loaded = load_all(entries_dir)
    lines = ["# azgym leaderboard", "",
             f"Ranked by the 75th percentile of the position error (EvAAL's headline). Generated "
             f"by `azgym leaderboard build` from {len(loaded)} entries in `entries/`; every "
             "entry's figures are recomputed from its per-frame results when it is read, and "
             "its frames are checked to be the suite's. Runs of the dev split at full size are "
             "the ranking; quick runs and the test split have tables of their own.", "",
             TRACKS_NOTE, ""]
    sections = []
    for suite in SUITES:
        tables = [(split, quick, title, _ranked(loaded, suite, split, quick))
                  for split, quick, title in KINDS]
        tables = [table for table in tables if table[3]]
        if not tables:
            continue
        description = get_suite(suite).description
        lines += [f"## {suite} — {description}", ""]
        for split, quick, title, ranked in tables:
            table_id = f"board-{suite}" if (split, quick) == ("dev", False) else \
                f"board-{suite}-{split}-{'quick' if quick else 'full'}"
            header, tracks = _header([entry for entry, _ in ranked])
            rows = [_cells(rank, entry, tracks) for rank, (entry, _) in enumerate(ranked, 1)]
            lines += [f"### {title}", "",
                      *_markdown_table(header, rows, [e for e, _ in ranked]), ""]
            sections.append((suite, description, title, table_id, header, rows,
                             [web_link(entry["link"]) for entry, _ in ranked], _cdf_png(ranked)))
    prepare_folder(out_dir)
    readme = write_file(out_dir / "README.md", "\n".join(lines))
    page = write_file(out_dir / "index.html", _html(sections, len(loaded)))
    return [readme, page]


def _markdown_table(header: list[str], rows: list[list[str]],
                    entries: list[dict[str, Any]]) -> list[str]:
    """A ranked table's Markdown lines: header, rule, one escaped line per entry."""
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *("| " + " | ".join(_markdown_row(row, entry)) + " |"
              for row, entry in zip(rows, entries, strict=True))]


_SORT_SCRIPT = """
document.querySelectorAll("table.board th").forEach(function (th) {
  th.addEventListener("click", function () {
    var table = th.closest("table"), body = table.tBodies[0], column = th.cellIndex;
    var ascending = th.getAttribute("data-order") !== "ascending";
    table.querySelectorAll("th").forEach(function (h) { h.removeAttribute("data-order"); });
    th.setAttribute("data-order", ascending ? "ascending" : "descending");
    var rows = Array.prototype.slice.call(body.rows);
    rows.sort(function (a, b) {
      var x = a.cells[column].textContent, y = b.cells[column].textContent;
      var nx = parseFloat(x), ny = parseFloat(y);
      var order = (isNaN(nx) || isNaN(ny)) ? x.localeCompare(y) : nx - ny;
      return ascending ? order : -order;
    });
    rows.forEach(function (row) { body.appendChild(row); });
  });
});
"""


def _cdf_png(ranked: list[tuple[dict[str, Any], str]]) -> str | None:
    """A table's error CDFs, each from its entry's own per-frame results, as a base64 PNG.

    None without matplotlib.
    """
    if importlib.util.find_spec("matplotlib") is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 4), constrained_layout=True)
    for entry, frames in ranked:
        rows = list(csv.DictReader(io.StringIO(frames)))
        # A missing estimate is a failure: it sits at +inf, never at zero error.
        errors = np.sort([float(r["position_error_m"]) * 100 if r["ok"] == "1" else np.inf
                          for r in rows])
        axes.step(errors, np.arange(1, errors.size + 1) / errors.size, where="post",
                  label=entry["name"])
    axes.set_xscale("log")
    axes.set_xlim(left=0.1)
    axes.set_xlabel("position error [cm]")
    axes.set_ylabel("share of frames")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=7, loc="lower right")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90)
    plt.close(figure)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _markdown_row(row: list[str], entry: dict[str, Any]) -> list[str]:
    """A table row's cells escaped for Markdown; the name links to the entry's web link."""
    cells = [markdown_cell(cell) for cell in row]
    link = web_link(entry["link"])
    if link is not None:
        target = link.replace("(", "%28").replace(")", "%29")
        cells[NAME_COLUMN] = f"[{cells[NAME_COLUMN]}]({target})"
    return cells


def _html_cells(row: list[str], link: str | None) -> str:
    """A table row's cells as HTML; the name links to the entry's web link."""
    cells = [html.escape(cell) for cell in row]
    if link is not None:
        cells[NAME_COLUMN] = f'<a href="{html.escape(link)}">{cells[NAME_COLUMN]}</a>'
    return "".join(f"<td>{cell}</td>" for cell in cells)


Section = tuple[str, str, str, str, list[str], list[list[str]], list[str | None], str | None]
"""A table of the page: suite, its description, the table's title and id, its column names,
rows, each row's link, the CDF image."""


def _html(sections: list[Section], count: int) -> str:
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>azgym leaderboard</title><style>",
             "body{font-family:sans-serif;margin:2em}table{border-collapse:collapse;margin:1em 0}",
             "th,td{border:1px solid #bbb;padding:4px 8px;text-align:right}",
             "th{cursor:pointer;background:#eee}th[data-order=ascending]::after{content:' ▲'}",
             "th[data-order=descending]::after{content:' ▼'}</style></head><body>",
             "<h1>azgym leaderboard</h1>",
             f"<p>{count} entries, ranked by p75 position error. Click a column to sort.</p>",
             f"<p>{html.escape(TRACKS_NOTE.replace('*', ''))}</p>"]
    previous = None
    for suite, description, title, table_id, header, rows, links, cdf in sections:
        if suite != previous:
            parts.append(f'<h2>{html.escape(suite)}</h2><p>{html.escape(description)}</p>')
            previous = suite
        parts.append(f"<h3>{html.escape(title)}</h3>")
        if cdf is not None:
            parts.append(f'<img alt="error CDFs, {html.escape(suite)}" '
                         f'src="data:image/png;base64,{cdf}">')
        parts.append(f'<table class="board" id="{html.escape(table_id)}"><thead><tr>')
        parts += [f"<th>{html.escape(cell)}</th>" for cell in header]
        parts.append("</tr></thead><tbody>")
        for row, link in zip(rows, links, strict=True):
            parts.append("<tr>" + _html_cells(row, link) + "</tr>")
        parts.append("</tbody></table>")
    parts += [f"<script>{_SORT_SCRIPT}</script>", "</body></html>"]
    return "\n".join(parts)

"""The board's web page: every table sortable, with its error CDFs, in one self-contained file.

:func:`page` writes what :mod:`azgym.bench.leaderboard.board` lays out: the board's parts (the
suites and simulated logs, then the real data and the navigation suites, each under its own heading
and introduction), each suite's tables with the error CDF of each table's entries drawn from their
own per-frame results. Text is HTML-escaped; a link has already been made safe by
:func:`azgym.bench.leaderboard.board.web_link`.
"""

from __future__ import annotations

import base64
import html
import importlib.util
import io

import numpy as np

from azgym.bench.leaderboard.entry_files import Entry
from azgym.bench.report.plots import draw_error_cdfs
from azgym.bench.run.outcome import Outcome
from azgym.site.drawing import figures_skipped

__all__ = ["NAME_COLUMN", "Section", "Table", "cdf_png", "page"]

NAME_COLUMN = 1
"""The column of the entry's name, which links to its web link."""

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
      var nx = x === "∞" ? Infinity : parseFloat(x), ny = y === "∞" ? Infinity : parseFloat(y);
      var order = (isNaN(nx) || isNaN(ny)) ? x.localeCompare(y) : nx - ny;
      return ascending ? order : -order;
    });
    rows.forEach(function (row) { body.appendChild(row); });
  });
});
"""


def cdf_png(ranked: list[tuple[Entry, Outcome]]) -> str | None:
    """A table's error CDFs, each from its entry's own per-frame results, as a base64 PNG.

    The curves are drawn as a run's are (:func:`~azgym.bench.report.plots.draw_error_cdfs`),
    styled in the table's order, so they stay apart past ten entries.

    None without matplotlib.
    """
    if importlib.util.find_spec("matplotlib") is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 4), constrained_layout=True)
    # A missing estimate is a failure: it sits at +inf, never at zero error.
    curves = [(entry["name"], np.where(outcome.ok, outcome.position * 100, np.inf))
              for entry, outcome in ranked]
    draw_error_cdfs(axes, curves, legend_size=7)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90)
    plt.close(figure)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _html_cells(row: list[str], link: str | None) -> str:
    """A table row's cells as HTML; the name links to the entry's web link."""
    cells = [html.escape(cell) for cell in row]
    if link is not None:
        cells[NAME_COLUMN] = f'<a href="{html.escape(link)}">{cells[NAME_COLUMN]}</a>'
    return "".join(f"<td>{cell}</td>" for cell in cells)


Section = tuple[str, str, str, str, str, list[str], list[list[str]], list[str | None],
                str | None]
"""A table of the page: the board's part it is in ("" before the first: the suites'), suite, its
description, the table's title and id, its column names, rows, each row's link, the CDF image."""
Table = tuple[str, str, str, str, list[str], list[list[str]]]
"""A table of a part that shows no entries (navigation, mapping): suite, its description, the
table's title and id, its column names and rows."""


def page(sections: list[Section], count: int, intro: list[str],
         part_notes: dict[str, str]) -> str:
    """The page: a heading, ``intro``'s paragraphs, then each section's table.

    Without matplotlib the tables have no error CDFs, and the page says so under ``intro``.

    Args:
        sections: The tables, in the board's order.
        count: How many entries the board shows.
        intro: Paragraphs after the opening one (Markdown's ``*`` and backticks are dropped).
        part_notes: Each part's introduction, by its heading (as ``intro``'s).
    """
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>azgym leaderboard</title><style>",
             "body{font-family:sans-serif;margin:2em}table{border-collapse:collapse;margin:1em 0}",
             "th,td{border:1px solid #bbb;padding:4px 8px;text-align:right}",
             "th{cursor:pointer;background:#eee}th[data-order=ascending]::after{content:' ▲'}",
             "th[data-order=descending]::after{content:' ▼'}</style></head><body>",
             "<h1>azgym leaderboard</h1>",
             f"<p>{count} entries, ranked by the p75 position error over every frame, a frame "
             "without an answer counting as infinitely wrong. Click a column to sort.</p>",
             *(f"<p>{_plain(paragraph)}</p>" for paragraph in intro)]
    skipped = figures_skipped(["the tables' error CDFs"])
    if skipped is not None:
        parts.append(f"<p>{html.escape(skipped)}</p>")
    previous, part_before = None, ""
    for part, suite, description, title, table_id, header, rows, links, cdf in sections:
        if part != part_before:
            parts += [f"<h1>{html.escape(part)}</h1>",
                      f"<p>{_plain(part_notes.get(part, ''))}</p>"]
            part_before = part
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


def _plain(text: str) -> str:
    """Markdown-light text as escaped HTML: emphasis marks and backticks dropped."""
    return html.escape(text.replace("*", "").replace("`", ""))

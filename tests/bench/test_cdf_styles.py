"""Error CDFs of many contenders stay apart (no two curves share a colour and a line style), and
a board page without them says why."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from azgym.bench.leaderboard import board_page  # noqa: E402
from azgym.bench.report import plots  # noqa: E402

COUNT = 12


def _styles(monkeypatch, draw) -> list[tuple]:
    """Each curve's (colour, line style) of the figure ``draw`` makes and closes."""
    closed = []
    monkeypatch.setattr(plt, "close", closed.append)
    draw()
    lines = [line for line in closed[0].axes[0].get_lines() if not line.get_label().startswith("_")]
    assert len(lines) == COUNT
    return [(matplotlib.colors.to_hex(line.get_color()), line.get_linestyle()) for line in lines]


def test_the_board_cdf_styles_stay_distinct_past_ten_entries(monkeypatch):
    outcome = SimpleNamespace(ok=np.array([True, True, False]),
                              position=np.array([0.01, 0.02, np.nan]))
    ranked = [({"name": f"entry-{k}"}, outcome) for k in range(COUNT)]
    styles = _styles(monkeypatch, lambda: board_page.cdf_png(ranked))
    assert len(set(styles)) == COUNT
    assert styles == _styles(monkeypatch, lambda: board_page.cdf_png(ranked))  # deterministic


def test_the_run_cdf_styles_stay_distinct_past_ten_contenders(monkeypatch, tmp_path):
    labels = [f"contender-{k}" for k in range(COUNT)]
    summary = {"localizers": dict.fromkeys(labels), "suite": "s", "split": "dev"}
    outcome = SimpleNamespace(ok=np.array([True, True, False]),
                              position=np.array([0.01, 0.02, np.nan]))
    outcomes = dict.fromkeys(labels, outcome)
    styles = _styles(monkeypatch, lambda: plots._error_cdfs(plt, summary, outcomes,
                                                            tmp_path / "cdf.png"))
    assert len(set(styles)) == COUNT


def test_a_board_page_without_matplotlib_says_its_cdfs_were_skipped(monkeypatch):
    import importlib.util

    assert "skipped" not in board_page.page([], 0, [], {})
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *rest: None if name == "matplotlib" else real(name, *rest))
    text = board_page.page([], 0, [], {})
    assert "error CDFs" in text and "pip install &quot;azgym[plot]&quot;" in text

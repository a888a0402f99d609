"""A contender cannot climb the ranking by refusing the frames it would get wrong."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from azgym.bench.leaderboard import board as B
from azgym.bench.leaderboard import entries as L
from azgym.bench.report.table import ranked_table
from azgym.bench.run.runner import Contender, run_benchmark
from azgym.bench.suites import get_suite

PICKY = str(Path(__file__).parent / "plugins" / "picky.py") + ":Picky"


@pytest.fixture(scope="module")
def static_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("picky")
    result = run_benchmark(get_suite("warehouse-static"),
                           [Contender("ransac", "ransac"), Contender("picky", PICKY)], quick=True)
    result.write(out, figures=False)
    return result, out


def test_the_picky_plugin_answers_little_with_a_small_answered_error(static_run):
    result, _ = static_run
    picky, ransac = (result.summary["localizers"][name]["all"] for name in ("picky", "ransac"))
    # The attack is real: on the frames it answers, it beats ransac by far.
    assert picky["availability"] < 0.5 < ransac["availability"]
    assert picky["p75_cm"] < 0.5 * ransac["p75_cm"]
    # The headline charges its refusals.
    assert picky["p75_all_cm"] == math.inf > ransac["p75_all_cm"]


def test_the_picky_plugin_ranks_below_ransac_in_the_bench_table(static_run):
    result, _ = static_run
    table = ranked_table(result.summary).split("\np75: ")[0]  # the rows, not the legend
    rows = [line.split() for line in table.splitlines()]
    ranks = {row[1]: int(row[0]) for row in rows if row and row[0].isdigit()}
    assert ranks == {"ransac": 1, "picky": 2}


def test_the_picky_plugin_ranks_below_ransac_on_the_built_board(static_run, tmp_path):
    _, out = static_run
    entries = tmp_path / "entries"
    for label in ("picky", "ransac"):
        L.submit(out, label, entries, name=f"{label}-entry", version="1", authors=["a"])
    readme, page = B.build(entries, tmp_path / "board")
    ranked = [line for line in readme.read_text().splitlines() if line.startswith("| 1 ")
              or line.startswith("| 2 ")]
    assert "| ransac-entry |" in ranked[0] and "| picky-entry |" in ranked[1]
    assert "| ∞ |" in ranked[1]  # its headline, shown as infinite
    assert "infinitely wrong" in readme.read_text() and "infinitely wrong" in page.read_text()

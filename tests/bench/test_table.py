"""Ranking: one rule, with a complete tie-break, for the bench table and the leaderboard."""

from __future__ import annotations

import math

from azgym.bench.table import rank_key


def test_p75_ranks_first_then_availability_then_name():
    rows = {
        "b": {"p75_cm": 2.0, "availability": 0.9},
        "a": {"p75_cm": 2.0, "availability": 0.9},
        "c": {"p75_cm": 2.0, "availability": 1.0},
        "d": {"p75_cm": 1.0, "availability": 0.5},
        "nan": {"p75_cm": math.nan, "availability": 0.0},
        "none": {"p75_cm": None, "availability": None},
    }
    order = sorted(rows, key=lambda name: rank_key(rows[name], name))
    assert order == ["d", "c", "a", "b", "nan", "none"]

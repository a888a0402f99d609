"""Ranking: one rule, with a complete tie-break, for the bench table and the leaderboard."""

from __future__ import annotations

import math

from azgym.bench.report.table import (
    LEGEND,
    POSITION_ONLY,
    cell,
    interval_cell,
    rank_key,
    ranked_table,
)


def test_headline_ranks_first_then_failures_then_answered_p75_then_availability_then_name():
    rows = {
        "b": {"p75_all_cm": 2.0, "failure_rate": 0.1, "p75_cm": 1.5, "availability": 0.9},
        "a": {"p75_all_cm": 2.0, "failure_rate": 0.1, "p75_cm": 1.5, "availability": 0.9},
        "c": {"p75_all_cm": 2.0, "failure_rate": 0.1, "p75_cm": 1.5, "availability": 1.0},
        "d": {"p75_all_cm": 2.0, "failure_rate": 0.1, "p75_cm": 1.0, "availability": 0.5},
        "e": {"p75_all_cm": 2.0, "failure_rate": 0.05, "p75_cm": 1.9, "availability": 0.95},
        "f": {"p75_all_cm": 1.0, "failure_rate": 0.2, "p75_cm": 1.0, "availability": 0.8},
        # Infinite headlines (JSON keeps them as None): by failures, then the answered p75.
        "inf-few-failures": {"p75_all_cm": math.inf, "failure_rate": 0.3, "p75_cm": 9.0,
                             "availability": 0.7},
        "inf-json": {"p75_all_cm": None, "failure_rate": 0.5, "p75_cm": 1.0,
                     "availability": 0.5},
        "inf-many-failures": {"p75_all_cm": math.inf, "failure_rate": 0.5, "p75_cm": 2.0,
                              "availability": 0.5},
        "nothing": {"p75_all_cm": math.nan, "failure_rate": math.nan, "p75_cm": math.nan,
                    "availability": math.nan},
    }
    order = sorted(rows, key=lambda name: rank_key(rows[name], name))
    assert order == ["f", "e", "d", "c", "a", "b", "inf-few-failures", "inf-json",
                     "inf-many-failures", "nothing"]


def test_a_picky_contender_ranks_below_one_that_answers_every_frame():
    # The attack: answer only the easy fifth of the frames, with a tiny answered p75.
    picky = {"p75_all_cm": math.inf, "failure_rate": 0.8, "p75_cm": 1.0, "availability": 0.2}
    honest = {"p75_all_cm": 6.7, "failure_rate": 0.11, "p75_cm": 6.0, "availability": 0.94}
    assert rank_key(honest, "z") < rank_key(picky, "a")


def test_a_wild_guess_is_worth_no_more_than_a_refusal():
    # Answering 10 m off instead of refusing gives a finite headline over 1 m: more than a
    # quarter of the frames failed either way, so the failure rate decides, not the headline.
    guesser = {"p75_all_cm": 1000.0, "failure_rate": 0.526, "p75_cm": 1000.0,
               "availability": 1.0}
    refuser = {"p75_all_cm": math.inf, "failure_rate": 0.458, "p75_cm": 1.4,
               "availability": 0.6}
    drifting = {"p75_all_cm": 118.7, "failure_rate": 0.269, "p75_cm": 118.7, "availability": 1.0}
    close = {"p75_all_cm": 99.0, "failure_rate": 0.24, "p75_cm": 99.0, "availability": 1.0}
    rows = {"guesser": guesser, "refuser": refuser, "drifting": drifting, "close": close}
    order = sorted(rows, key=lambda name: rank_key(rows[name], name))
    assert order == ["close", "drifting", "refuser", "guesser"]


def test_cells_show_infinite_and_missing_figures():
    assert cell(math.inf) == "inf" and cell(None) == "-" and cell(math.nan) == "-"
    assert cell(3.14159) == "3.14" and cell(3.14159, 1) == "3.1"
    assert interval_cell([1.0, math.inf]) == "1.00-inf"
    assert interval_cell([math.nan, math.nan]) == "-" and interval_cell(None) == "-"
    assert interval_cell([math.inf, math.inf]) == "-"  # no finite interval: the p75 says inf


def test_the_legend_says_what_each_column_is():
    for words in ("every frame", "infinitely wrong", "Ranked by it", "then by fail",
                  "over 1 m means more than a quarter of the frames failed",
                  "blocks", "avail", "no answer or one more than 1 m off",
                  "over the answered frames only", "median time", "ransac's median"):
        assert words in LEGEND, words


def _summary(heading_median_deg):
    stats = {"p75_all_cm": 2.0, "failure_rate": 0.0, "availability": 1.0, "median_cm": 1.0,
             "p75_cm": 2.0, "p95_cm": 3.0, "mean_cm": 1.5, "heading_median_deg": heading_median_deg}
    return {"suite": "data:mini", "suite_version": 2, "split": "data", "seed": 0, "quick": False,
            "n_frames": 3, "localizers": {"ransac": {
                "all": stats, "ci95": {}, "crashes": 0,
                "runtime_us": {"median": 10.0, "ratio_to_ransac": 1.0}}}}


def test_a_table_on_position_only_truth_says_the_heading_was_not_scored():
    assert "position-only truth: heading not scored" in POSITION_ONLY
    assert "position-only truth: heading not scored" in ranked_table(_summary(None))
    assert "heading not scored" not in ranked_table(_summary(0.5))
    assert "heading not scored" not in ranked_table(_summary(math.nan))  # nothing answered


def test_the_table_says_which_profile_set_the_defaults() -> None:
    """A run with a profile prints it above the rows; a plain run prints no profile line."""
    from azgym.bench.report.table import profile_lines

    assert profile_lines({"profile": {}}) == [] and profile_lines({}) == []
    assert profile_lines({"profile": {"sensor": {"delta_alpha_d": 0.07, "coverage": False}}}) \
        == ["profile (the contenders' defaults): sensor.delta_alpha_d=0.07, "
            "sensor.coverage=false"]

"""Error statistics: a missing estimate is a failure, never a zero error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.metrics import (
    FAILURE_DISTANCE,
    bootstrap_blocks,
    confidence_intervals,
    quantile,
    summarize_errors,
)


def test_hand_worked_statistics():
    # Errors 1, 2, 3, 4 cm, all available; heading errors 1°, 2°, 3°, 10°.
    stats = summarize_errors([0.01, 0.02, 0.03, 0.04], np.radians([1.0, 2.0, 3.0, 10.0]),
                             [True] * 4)
    assert stats["n"] == 4
    assert stats["availability"] == 1.0
    assert stats["failure_rate"] == 0.0
    assert stats["mean_cm"] == pytest.approx(2.5)
    assert stats["rmse_cm"] == pytest.approx(math.sqrt((1 + 4 + 9 + 16) / 4))  # sqrt(7.5)
    assert stats["median_cm"] == pytest.approx(2.5)
    # Linear interpolation between order statistics: position 0.75·3 = 2.25 → 3 + 0.25.
    assert stats["p75_cm"] == pytest.approx(3.25)
    assert stats["p90_cm"] == pytest.approx(3.7)
    assert stats["p95_cm"] == pytest.approx(3.85)
    assert stats["max_cm"] == pytest.approx(4.0)
    assert stats["heading_mean_deg"] == pytest.approx(4.0)
    assert stats["heading_median_deg"] == pytest.approx(2.5)


def test_missing_estimate_is_a_failure_not_a_zero_error():
    # The third run produced no estimate; whatever its error slot holds (0 or NaN) is ignored.
    for placeholder in (0.0, math.nan):
        stats = summarize_errors([0.02, 0.04, placeholder], [0.0, 0.0, placeholder],
                                 [True, True, False])
        assert stats["n"] == 3
        assert stats["availability"] == pytest.approx(2 / 3)
        assert stats["failure_rate"] == pytest.approx(1 / 3)
        assert stats["mean_cm"] == pytest.approx(3.0)  # not (2 + 4 + 0) / 3 = 2
        assert stats["median_cm"] == pytest.approx(3.0)
        assert stats["rmse_cm"] == pytest.approx(math.sqrt(10.0))


def test_far_estimates_are_failures_but_still_in_the_error_statistics():
    stats = summarize_errors([0.5, 1.5, FAILURE_DISTANCE, 3.0], [0.0] * 4, [True] * 4)
    assert stats["availability"] == 1.0
    assert stats["failure_rate"] == pytest.approx(0.5)  # 1.5 m and 3 m; exactly 1 m is not
    assert stats["mean_cm"] == pytest.approx(150.0)
    assert stats["max_cm"] == pytest.approx(300.0)


def test_missing_and_far_failures_add_up():
    stats = summarize_errors([2.0, 0.01, 0.0, 0.0], [0.0] * 4, [True, True, False, False])
    assert stats["failure_rate"] == pytest.approx(0.75)
    assert stats["availability"] == pytest.approx(0.5)


def test_no_estimate_at_all():
    stats = summarize_errors([0.0, 0.0], [0.0, 0.0], [False, False])
    assert stats["n"] == 2
    assert stats["availability"] == 0.0
    assert stats["failure_rate"] == 1.0
    for key in ("mean_cm", "rmse_cm", "median_cm", "p75_cm", "p90_cm", "p95_cm", "max_cm",
                "heading_mean_deg", "heading_median_deg"):
        assert math.isnan(stats[key]), key


def test_no_runs():
    stats = summarize_errors([], [], [])
    assert stats["n"] == 0
    assert math.isnan(stats["availability"]) and math.isnan(stats["failure_rate"])
    assert math.isnan(stats["mean_cm"])


def test_same_keys_whether_or_not_estimates_exist():
    some = summarize_errors([0.01], [0.0], [True])
    none = summarize_errors([0.01], [0.0], [False])
    assert set(some) == set(none)


# The headline: p75 over every frame, a refusal infinite (EvAAL's rule).

def test_headline_hand_worked():
    # Errors 1, 2, 3 cm and one refusal: sorted 1, 2, 3, inf; position 0.75·3 = 2.25 lies
    # between 3 and inf, so the headline is infinite; at 0.5 it is (2 + 3) / 2.
    stats = summarize_errors([0.01, 0.02, 0.03, 0.0], [0.0] * 4, [True, True, True, False])
    assert stats["p75_all_cm"] == math.inf
    assert stats["p75_cm"] == pytest.approx(2.5)  # answered frames only: 2 + 0.5
    assert quantile([1.0, 2.0, 3.0, math.inf], 0.5) == pytest.approx(2.5)
    # Eight frames, one refused: position 0.75·7 = 5.25 between the 6th and 7th answered errors.
    stats = summarize_errors(np.arange(1, 9) / 100, [0.0] * 8, [True] * 7 + [False])
    assert stats["p75_all_cm"] == pytest.approx(6.25)
    assert stats["p75_cm"] == pytest.approx(5.5)  # 7 answered: position 4.5 → 5 + 0.5


def test_headline_exactly_on_the_first_refusal_is_infinite_and_before_it_finite():
    # Five frames, position 0.75·4 = 3 exactly: the 4th value.
    assert quantile([1.0, 2.0, 3.0, 4.0, math.inf], 0.75) == 4.0
    assert quantile([1.0, 2.0, 3.0, math.inf, math.inf], 0.75) == math.inf


def test_headline_equals_the_p75_when_every_frame_is_answered():
    rng = np.random.default_rng(3)
    errors = rng.exponential(0.05, 101)
    stats = summarize_errors(errors, np.zeros(101), np.ones(101, dtype=bool))
    assert stats["p75_all_cm"] == pytest.approx(stats["p75_cm"], abs=1e-12)
    assert quantile(errors, 0.3) == pytest.approx(np.percentile(errors, 30), abs=1e-15)


def test_refusing_the_hard_frames_does_not_improve_the_headline():
    # A picky contender answers only its best 30 % of frames: its answered p75 looks great,
    # its headline is infinite; the one that answers everything keeps a finite headline.
    rng = np.random.default_rng(0)
    errors = rng.exponential(0.05, 200)
    picky = errors < np.quantile(errors, 0.3)
    honest = summarize_errors(errors, np.zeros(200), np.ones(200, dtype=bool))
    refusing = summarize_errors(errors, np.zeros(200), picky)
    assert refusing["p75_cm"] < honest["p75_cm"]
    assert refusing["p75_all_cm"] == math.inf > honest["p75_all_cm"]


def test_no_runs_no_headline_and_no_answers_infinite():
    assert math.isnan(summarize_errors([], [], [])["p75_all_cm"])
    assert summarize_errors([0.0], [0.0], [False])["p75_all_cm"] == math.inf


# Bootstrap blocks and intervals.

def test_blocks_cut_each_sequence_by_time_and_leave_lone_frames_alone():
    sequences = ["a"] * 4 + ["", ""] + ["b"] * 3
    times = [0.0, 4.9, 5.0, 12.0, math.nan, math.nan, 100.0, 103.0, 106.0]
    blocks = bootstrap_blocks(sequences, times, block_seconds=5.0)
    # a: [0, 5) → 0, [5, 10) → 1, [10, 15) → 2; lone frames 3 and 4; b from its own start.
    assert blocks.tolist() == [0, 0, 1, 2, 3, 4, 5, 5, 6]


def test_block_bootstrap_is_wider_than_the_frame_bootstrap_on_correlated_errors():
    # A route whose error wanders slowly (an AR(1) process with a 3 s time constant at 10 Hz):
    # frames are far from independent, so resampling them one by one is overconfident.
    rng = np.random.default_rng(1)
    count, errors = 3000, np.empty(3000)
    level = 0.0
    for k in range(count):
        level = 0.967 * level + rng.normal(0.0, 1.0)
        errors[k] = abs(level) / 100
    ok = np.ones(count, dtype=bool)
    times = np.arange(count) * 0.1
    frames = confidence_intervals(errors, ok, bootstrap_blocks([""] * count, times))
    blocks = confidence_intervals(errors, ok, bootstrap_blocks(["r"] * count, times))

    def width(interval):
        return interval[1] - interval[0]

    assert width(blocks["p75_all_cm"]) > 2 * width(frames["p75_all_cm"])
    estimate = summarize_errors(errors, np.zeros(count), ok)["p75_all_cm"]
    for interval in (frames, blocks):
        assert interval["p75_all_cm"][0] <= estimate <= interval["p75_all_cm"][1]


def test_intervals_are_seeded_and_an_unbounded_headline_has_an_infinite_bound():
    rng = np.random.default_rng(2)
    errors = rng.exponential(0.05, 400)
    ok = rng.random(400) > 0.26  # about a quarter refused: the headline hovers at infinity
    blocks = bootstrap_blocks([""] * 400, [math.nan] * 400)
    first = confidence_intervals(errors, ok, blocks)
    assert first == confidence_intervals(errors, ok, blocks)
    assert first["p75_all_cm"][1] == math.inf
    low, high = first["failure_rate"]
    assert low < float(np.mean(~ok)) < high


@pytest.mark.parametrize("seed", range(6))
def test_a_resample_s_headline_is_the_quantile_of_its_frames_sorted(seed):
    """The bootstrap ranks the frames once and counts; each resample's p75 is what sorting its
    frames gives (refusals, ties and blocks of every size included), bit for bit."""
    from azgym.metrics import _resampled_quantile

    rng = np.random.default_rng(seed)
    count = int(rng.integers(2, 40))
    blocks = rng.integers(0, count, 600)
    blocks[:count] = np.arange(count)  # every block has a frame
    error = np.where(rng.random(600) < 0.2, np.inf, np.round(rng.exponential(30, 600), 1))
    by_error = np.argsort(error, kind="stable")
    chosen = rng.integers(0, count, (25, count))
    headlines = _resampled_quantile(chosen, error[by_error], blocks[by_error], count, 0.75)
    for drawn, headline in zip(chosen, headlines, strict=True):
        frames = np.concatenate([error[blocks == block] for block in drawn])
        assert headline == quantile(frames, 0.75)


def test_fewer_than_two_blocks_give_no_interval():
    one = confidence_intervals(np.array([0.01, 0.02]), np.array([True, True]),
                               np.array([0, 0]))
    assert all(math.isnan(bound) for bounds in one.values() for bound in bounds)


def test_a_runs_intervals_resample_its_routes_in_blocks_and_lone_frames_one_by_one():
    from azgym.bench.report.results import contender_metrics
    from azgym.bench.run.outcome import Outcome
    from azgym.bench.suites import get_suite

    for name, routes in (("warehouse-routes", True), ("warehouse-static", False)):
        cases = get_suite(name).build(get_suite(name).dev_seed, True)
        rng = np.random.default_rng(0)
        outcome = Outcome.empty(len(cases))
        outcome.ok[:] = rng.random(len(cases)) > 0.1
        outcome.position[:] = rng.exponential(0.05, len(cases))
        blocks = bootstrap_blocks([case.sequence for case in cases],
                                  [case.time for case in cases])
        assert (blocks.max() + 1 < len(cases)) == routes  # routes: fewer blocks than frames
        figures = contender_metrics(outcome, cases, 10.0)
        assert figures["ci95"] == confidence_intervals(outcome.position, outcome.ok, blocks)


def test_position_only_truth_leaves_the_heading_figures_out():
    # A log's truth without heading gives NaN heading errors: not a zero, not a NaN figure.
    stats = summarize_errors([0.1, 0.3], [math.nan, math.nan], [True, True])
    assert stats["median_cm"] == pytest.approx(20.0)
    assert stats["heading_mean_deg"] is None and stats["heading_median_deg"] is None
    none_answered = summarize_errors([math.nan], [math.nan], [False])
    assert math.isnan(none_answered["heading_median_deg"])  # nothing answered: NaN as before
    some = summarize_errors([0.1, 0.1], [math.radians(2.0), math.nan], [True, True])
    assert some["heading_mean_deg"] == pytest.approx(2.0)  # over the frames with a heading

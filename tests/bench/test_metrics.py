"""Error statistics: a missing estimate is a failure, never a zero error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.bench.metrics import FAILURE_DISTANCE, summarize_errors


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

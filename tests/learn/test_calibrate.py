"""Calibrating ng-ransac's answer test: the threshold by hand, and its record in a weight file."""

from __future__ import annotations

import numpy as np
import pytest

from azgym.learn.calibrate import GuidedRuns, choose_threshold


def runs(weights, errors):
    errors = np.asarray(errors, dtype=float)
    return GuidedRuns(np.isfinite(errors), errors, np.asarray(weights, dtype=float),
                      np.full(errors.size, 10))


def test_the_threshold_gives_up_at_most_the_share_of_right_answers_asked():
    # 10 right answers with weights 1..10, 3 wrong ones with weights 0.5, 2.5 and 9.5, 1 none.
    weights = [*range(1, 11), 0.5, 2.5, 9.5, 0.0]
    errors = [0.01] * 10 + [5.0, 5.0, 5.0, np.inf]
    result = choose_threshold(runs(weights, errors), max_right_lost=0.2)
    # 20 % of 10 right answers may go: the two lightest (1 and 2); the threshold is the third.
    assert result["min_support_weight"] == 3.0
    assert (result["right_before"], result["right_kept"]) == (10, 8)
    assert (result["wrong_before"], result["wrong_kept"]) == (3, 1)
    assert choose_threshold(runs(weights, errors), max_right_lost=0.0)["min_support_weight"] \
        == 1.0


def test_no_right_answer_gives_a_threshold_of_zero():
    assert choose_threshold(runs([1.0], [3.0]))["min_support_weight"] == pytest.approx(0.0)


def test_answers_the_consensus_settled_are_kept_and_count_in_the_share():
    # Right answers 1..10 tested, plus 30 the confident consensus settled (inf: never tested).
    # 5 % of all 40 right answers may go, and the two given up are the tested lightest.
    weights = [*range(1, 11), *[np.inf] * 30, 2.5]
    errors = [0.01] * 40 + [5.0]
    result = choose_threshold(runs(weights, errors), max_right_lost=0.05)
    assert result["min_support_weight"] == 3.0
    assert (result["right_before"], result["right_kept"], result["untested"]) == (40, 38, 30)
    assert result["wrong_kept"] == 0


def test_a_share_beyond_the_tested_answers_keeps_the_heaviest_tested_one():
    weights = [1.0, 2.0, *[np.inf] * 38]
    result = choose_threshold(runs(weights, [0.01] * 40), max_right_lost=0.5)
    assert result["min_support_weight"] == 2.0
    assert choose_threshold(runs([np.inf] * 3, [0.01] * 3))["min_support_weight"] == 0.0

"""Outlier injection of the paper's protocol (Sec. 3.1): K = 1 adds ±[10°, 170°], K >= 2 swaps."""

from __future__ import annotations

import math
import re
from collections import Counter

import numpy as np
import pytest

from azgym import InvalidInputError, wrap_angle
from azgym.sensing.synthetic import derangement, inject_outliers

# Twelve distinct azimuths, including both ends of (−π, π].
AZIMUTH = np.array([-3.1, -2.5, -1.7, -0.9, -0.3, 0.0, 0.4, 1.1, 1.9, 2.6, 3.0, math.pi])


def test_zero_outliers_leave_the_data_unchanged():
    corrupted, mask = inject_outliers(AZIMUTH, 0, np.random.default_rng(0))
    np.testing.assert_array_equal(corrupted, AZIMUTH)
    assert mask.dtype == bool and not mask.any() and mask.shape == AZIMUTH.shape
    assert corrupted is not AZIMUTH


@pytest.mark.parametrize("seed", range(40))
def test_one_outlier_changes_one_value_by_10_to_170_degrees(seed):
    original = AZIMUTH.copy()
    corrupted, mask = inject_outliers(original, 1, np.random.default_rng(seed))
    np.testing.assert_array_equal(original, AZIMUTH)  # the input is not modified
    changed = corrupted != AZIMUTH
    assert changed.sum() == 1
    np.testing.assert_array_equal(mask, changed)
    shift = abs(wrap_angle(corrupted[changed][0] - AZIMUTH[changed][0]))
    assert math.radians(10) - 1e-12 <= shift <= math.radians(170) + 1e-12
    # The corrupted value is itself a wrapped angle.
    assert -math.pi < corrupted[changed][0] <= math.pi


def test_one_outlier_uses_both_signs_and_the_whole_range():
    shifts = []
    for seed in range(400):
        corrupted, mask = inject_outliers(AZIMUTH, 1, np.random.default_rng(seed))
        shifts.append(wrap_angle(corrupted[mask][0] - AZIMUTH[mask][0]))
    shifts = np.degrees(shifts)
    assert (shifts > 0).sum() > 150 and (shifts < 0).sum() > 150
    assert np.abs(shifts).min() < 15 and np.abs(shifts).max() > 165


@pytest.mark.parametrize("k", [2, 3, 5, 12])
@pytest.mark.parametrize("seed", range(10))
def test_k_outliers_derange_the_chosen_values(k, seed):
    corrupted, mask = inject_outliers(AZIMUTH, k, np.random.default_rng(seed))
    assert mask.sum() == k
    # Untouched measurements keep their values; every chosen one changes (no fixed point)...
    np.testing.assert_array_equal(corrupted[~mask], AZIMUTH[~mask])
    assert (corrupted[mask] != AZIMUTH[mask]).all()
    # ...to the value of another chosen one: the chosen values are permuted among themselves.
    assert sorted(corrupted[mask]) == sorted(AZIMUTH[mask])


def test_outlier_positions_are_spread_over_all_measurements():
    hits = np.zeros(AZIMUTH.size)
    for seed in range(300):
        _, mask = inject_outliers(AZIMUTH, 3, np.random.default_rng(seed))
        hits += mask
    # 900 picks over 12 positions: 75 expected each; a miss of every position is impossible.
    assert hits.min() > 40 and hits.max() < 115


@pytest.mark.parametrize("k", [0, 1, 2, 4])
def test_injection_is_deterministic_per_seed(k):
    first = inject_outliers(AZIMUTH, k, np.random.default_rng(11))
    again = inject_outliers(AZIMUTH, k, np.random.default_rng(11))
    np.testing.assert_array_equal(first[0], again[0])
    np.testing.assert_array_equal(first[1], again[1])


def test_different_seeds_give_different_outliers():
    draws = {tuple(inject_outliers(AZIMUTH, 2, np.random.default_rng(s))[0]) for s in range(10)}
    assert len(draws) > 1


@pytest.mark.parametrize("k", [-1, 13, 1.0, 2.5, True, "2", None])
def test_k_out_of_range_or_not_an_integer_raises(k):
    with pytest.raises(InvalidInputError, match=re.escape("k must be an integer in [0, 12]")):
        inject_outliers(AZIMUTH, k, np.random.default_rng(0))


def test_numpy_integer_k_is_accepted():
    _, mask = inject_outliers(AZIMUTH, np.int64(2), np.random.default_rng(0))
    assert mask.sum() == 2


def test_one_outlier_needs_one_measurement():
    with pytest.raises(InvalidInputError, match=re.escape("[0, 0]")):
        inject_outliers(np.array([]), 1, np.random.default_rng(0))


@pytest.mark.parametrize("k", [2, 3, 4, 7, 20])
def test_derangement_has_no_fixed_point(k):
    rng = np.random.default_rng(k)
    for _ in range(50):
        perm = derangement(k, rng)
        assert sorted(perm.tolist()) == list(range(k))
        assert (perm != np.arange(k)).all()


def test_derangement_of_two_is_the_swap():
    assert derangement(2, np.random.default_rng(0)).tolist() == [1, 0]


def test_derangement_of_three_is_uniform_over_both_cycles():
    # The derangements of 3 are the two 3-cycles (1, 2, 0) and (2, 0, 1).
    rng = np.random.default_rng(3)
    counts = Counter(tuple(derangement(3, rng).tolist()) for _ in range(2000))
    assert set(counts) == {(1, 2, 0), (2, 0, 1)}
    # Binomial(2000, 1/2): standard deviation 22; 150 is ~7 of them.
    assert abs(counts[(1, 2, 0)] - 1000) < 150


def test_derangement_is_deterministic_per_seed():
    first = derangement(6, np.random.default_rng(5))
    again = derangement(6, np.random.default_rng(5))
    np.testing.assert_array_equal(first, again)


@pytest.mark.parametrize("k", [0, 1])
def test_derangement_needs_two_elements(k):
    with pytest.raises(InvalidInputError, match=re.escape("derangement: k must be >= 2")):
        derangement(k, np.random.default_rng(0))

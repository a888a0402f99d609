"""The learned localizers' features: worked by hand, invariant as promised, one kernel for all."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.core import BeaconMap, Measurements
from azgym.errors import InvalidInputError
from azgym.learn.dataset import layout_frames
from azgym.localize.base import Problem
from azgym.localize.learned.features import (
    CONSENSUS_TOLERANCE,
    FEATURE_NAMES,
    N_FEATURES,
    _stable_order,
    measurement_features,
)
from azgym.sensing.synthetic import ideal_azimuths

SQUARE = BeaconMap([1, 2, 3, 4], [[10.0, 0.0, 3.0], [0.0, 10.0, 3.0], [-10.0, 0.0, 3.0],
                                  [0.0, -10.0, 3.0]])
GHOST_OFFSET = 0.3
"""Where the hand-made ghost of beacon 1 appears, off its real azimuth [rad]."""


def column(features, name):
    return features[:, FEATURE_NAMES.index(name)]


def square_frame(heading=0.2):
    """The square's beacons seen from (1, 2), plus a dim ghost of beacon 1 (id 1 again)."""
    azimuth, _ = ideal_azimuths(1.0, 2.0, heading, SQUARE)
    ghost = azimuth[0] + GHOST_OFFSET
    return Measurements([1, 2, 3, 4, 1], [*azimuth, ghost], [3.0, 2.0, 1.0, 2.5, 0.5])


def test_the_features_of_a_tiny_frame_worked_by_hand():
    measurements = square_frame()
    features = measurement_features(Problem.from_frame(measurements, SQUARE),
                                     measurements.quality)
    assert features.shape == (5, N_FEATURES)
    # Quality 3, 2, 1, 2.5, 0.5: ranks among the other four, spans over [0.5, 3].
    assert column(features, "quality_rank") == pytest.approx([1.0, 0.5, 0.25, 0.75, 0.0])
    assert column(features, "quality_span") == pytest.approx([1.0, 0.6, 0.2, 0.8, 0.0])
    assert column(features, "same_id_others").tolist() == [0.5, 0, 0, 0, 0.5]
    assert column(features, "brightest_of_id").tolist() == [1, 1, 1, 1, 0]  # the ghost is not
    assert column(features, "beacons_in_view").tolist() == [4 / 16] * 5
    # The four real views agree on the true pose; the ghost is 0.3 rad off it.
    assert column(features, "consensus_support").tolist() == [4 / 5] * 5
    ghost = math.log1p(GHOST_OFFSET / CONSENSUS_TOLERANCE) / math.log1p(
        math.pi / CONSENSUS_TOLERANCE)
    assert column(features, "consensus_residual") == pytest.approx([0, 0, 0, 0, ghost],
                                                                   abs=1e-9)


def test_without_quality_the_quality_features_are_neutral_and_geometry_still_counts():
    measurements = square_frame()
    features = measurement_features(Problem.from_frame(measurements, SQUARE), None)
    assert column(features, "quality_rank").tolist() == [0.5] * 5
    assert column(features, "quality_span").tolist() == [0.5] * 5
    assert column(features, "brightest_of_id").tolist() == [0.5, 1, 1, 1, 0.5]
    assert column(features, "consensus_residual")[4] > 0.5
    assert column(features, "consensus_residual")[:4] == pytest.approx([0] * 4, abs=1e-9)


def test_a_frame_of_fewer_than_three_beacons_has_no_consensus():
    measurements = Measurements([1, 2], [0.1, 1.5], [1.0, 1.0])
    features = measurement_features(Problem.from_frame(measurements, SQUARE),
                                    measurements.quality)
    assert column(features, "consensus_support").tolist() == [0.0, 0.0]
    assert column(features, "consensus_residual").tolist() == [0.5, 0.5]
    assert column(features, "quality_span").tolist() == [0.5, 0.5]  # max == min


@pytest.fixture(scope="module")
def frames():
    """Frames of a generated warehouse, with ghosts, misreads and injected outliers."""
    scenario_frames = layout_frames(3, 30, seed=0, outlier_share=0.5)
    return [(frame.problem, frame.quality) for frame in scenario_frames]


def moved_world(problem, angle, shift):
    """The frame's beacons rotated by ``angle`` and shifted: the camera moved with them."""
    c, s = math.cos(angle), math.sin(angle)
    floats = problem.floats.copy()
    bx, by = problem.bx, problem.by
    floats[3], floats[4] = c * bx - s * by + shift[0], s * bx + c * by + shift[1]
    return Problem(floats, problem.ints.copy(), problem.n_distinct, problem.n_measurements)


def features_of(problem, quality):
    """Features with the quality given per usable measurement (as the source rows say)."""
    full = np.zeros(problem.n_measurements) if quality is not None else None
    if quality is not None:
        full[problem.source] = quality
    return measurement_features(problem, full)


@pytest.mark.parametrize(("angle", "shift"), [(0.0, (1234.5, -987.0)), (2.1, (0.0, 0.0)),
                                              (-0.7, (50.0, 3.0))])
def test_features_do_not_change_when_the_world_is_moved_and_turned(frames, angle, shift):
    for problem, quality in frames:
        before = features_of(problem, quality)
        after = features_of(moved_world(problem, angle, shift), quality)
        assert np.allclose(before, after, atol=1e-9, rtol=0)


def test_features_do_not_change_when_the_quality_is_scaled_or_has_more_columns(frames):
    for problem, quality in frames:
        before = features_of(problem, quality)
        assert np.allclose(before, features_of(problem, 37.0 * quality), atol=1e-12, rtol=0)
        wide = np.zeros((problem.n_measurements, 3))
        wide[problem.source, 0] = quality
        wide[:, 1:] = 99.0
        assert np.array_equal(before, measurement_features(problem, wide))


def test_features_follow_the_measurements_when_they_are_listed_in_another_order(frames):
    rng = np.random.default_rng(1)
    for problem, quality in frames:
        order = rng.permutation(problem.size)
        shuffled = Problem(problem.floats[:, order], problem.ints[:, order], problem.n_distinct,
                           problem.n_measurements)
        for given in (quality, None):
            before = features_of(problem, given)
            after = features_of(shuffled, None if given is None else given[order])
            assert np.allclose(before[order], after, atol=1e-12, rtol=0)


def test_quality_of_another_length_is_refused():
    measurements = square_frame()
    problem = Problem.from_frame(measurements, SQUARE)
    with pytest.raises(InvalidInputError, match=r"quality must have shape \(5,\) or \(5, Q\), "
                                                r"got \(4,\)"):
        measurement_features(problem, np.ones(4))
    with pytest.raises(InvalidInputError, match=r"got \(5, 1, 1\)"):
        measurement_features(problem, np.ones((5, 1, 1)))


@pytest.mark.parametrize("size", [1, 2, 5, 12, 24, 25, 40])
def test_the_candidates_order_is_numpys_stable_sort(size):
    # The features a model was trained on depend on this order: ties (equal qualities, as
    # quantised sensors give) must keep their index order, as merge sort keeps it.
    rng = np.random.default_rng(size)
    for _ in range(50):
        values = rng.integers(0, 4, size).astype(float)
        assert np.array_equal(_stable_order(values, True), np.argsort(-values, kind="mergesort"))
        assert np.array_equal(_stable_order(values, False), np.argsort(values, kind="mergesort"))

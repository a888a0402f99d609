"""ransac's consensus-first search: where it stops early, and that it answers as the full search.

The full search (every triplet ranked, ``solve_from_triplets``) is the paper's step 5; the
consensus first may only change which of the candidates every measurement supports the
refinement starts from, never the measurements it refines on.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame
from hypothesis import given, settings
from hypothesis import strategies as st

from azgym import Measurements, wrap_angle
from azgym.localize.base import Problem
from azgym.localize.ransac import (
    OUT_SIZE,
    Ransac,
    _all_triplets,
    solve_from_triplets,
)
from azgym.localize.ransac_search import CONSENSUS_MIN_TRIPLETS, CONSENSUS_TRIPLETS
from azgym.sensing.synthetic import inject_outliers, noisy_measurements


def full_search(ransac: Ransac, frame: Measurements, beacons):
    """The answer of ranking every triplet: (x, y, heading, inliers, n_valid), or None."""
    problem = Problem.from_frame(frame, beacons)
    out, cov = np.empty(OUT_SIZE), np.empty((3, 3))
    mask = np.zeros(len(frame), dtype=bool)
    solve_from_triplets(problem.floats, problem.ints, _all_triplets(problem.size),
                        ransac._settings, out, mask, cov)
    estimate = ransac._estimate(out, mask, cov)
    return estimate, cov


def at_degrees(*azimuths_deg: float, distance: float = 6.0) -> np.ndarray:
    """Beacon positions seen from the origin at these azimuths (heading 0), ``distance`` away."""
    angles = np.radians(azimuths_deg)
    return distance * np.c_[np.cos(angles), np.sin(angles)]


def test_a_clean_frame_is_settled_by_the_first_spread_triplet(paper_beacons):
    estimate = Ransac().localize(ideal_frame(1.0, 2.0, 3.0, paper_beacons), paper_beacons)
    assert estimate.diagnostics["n_triplets"] == 1
    assert estimate.diagnostics["n_valid_triplets"] == 1
    assert estimate.inliers.all()
    assert math.hypot(estimate.x - 1.0, estimate.y - 2.0) < 1e-9
    covariance = estimate.covariance
    np.testing.assert_allclose(covariance, covariance.T, rtol=1e-10, atol=0)
    assert (np.linalg.eigvalsh(covariance) > 0).all()


def test_weighted_ransac_ranks_every_triplet(paper_beacons):
    # Its weights are the model's at the winner's pose, so the tie among full-support candidates
    # (the smallest mean error) decides its answer: no early stop.
    estimate = Ransac(weighted=True).localize(ideal_frame(1.0, 2.0, 3.0, paper_beacons),
                                              paper_beacons)
    assert estimate.diagnostics["n_triplets"] == math.comb(12, 3)
    assert estimate.inliers.all()


def test_a_degenerate_first_spread_triplet_passes_to_the_second():
    # Six beacons seen from the origin. Sorted by azimuth, places 0, 2, 4 (10°, 90°, 170°) lie on
    # one circle through the camera, where their triplet is degenerate (eq. 7-18 have no unique
    # solution); places 1, 3, 5 (50°, 130°, 175°) do not. ⌊6/3⌋ = 2 spread triplets: places
    # (0, 2, 4), then (1, 3, 5), which settles it.
    on_circle = [(5.0 * math.sin(t), 5.0 - 5.0 * math.cos(t))
                 for t in np.radians([20.0, 180.0, 340.0])]  # azimuths 10°, 90°, 170°
    xy = np.vstack([on_circle, at_degrees(50.0, 130.0, 175.0)])
    beacons = beacon_map(xy)
    frame = ideal_frame(0.0, 0.0, 0.0, beacons)
    assert np.argsort(frame.azimuth).tolist() == [0, 3, 1, 4, 2, 5]
    estimate = Ransac().localize(frame, beacons)
    assert estimate.ok and estimate.inliers.all()
    assert estimate.diagnostics["n_triplets"] == 2
    assert estimate.diagnostics["n_valid_triplets"] == 1
    assert math.hypot(estimate.x, estimate.y) < 1e-9


def test_an_outlier_means_the_full_search_bit_for_bit(paper_room):
    # No triplet can have every measurement as a supporter, so every one is ranked.
    rng = np.random.default_rng(3)
    frame = noisy_measurements(2.0, -1.0, 0.5, paper_room.beacons, paper_room.error_model, rng)
    azimuth, outlier = inject_outliers(frame.azimuth, 1, rng)
    frame = Measurements(frame.ids, azimuth)
    ransac = Ransac()
    estimate = ransac.localize(frame, paper_room.beacons)
    expected, _ = full_search(ransac, frame, paper_room.beacons)
    assert estimate.diagnostics["n_triplets"] == math.comb(12, 3)
    assert estimate.pose == expected.pose
    np.testing.assert_array_equal(estimate.inliers, ~outlier)
    assert estimate.diagnostics == expected.diagnostics


@settings(max_examples=60, deadline=None)
@given(
    pose=st.tuples(st.floats(-9, 9), st.floats(-9, 9), st.floats(-math.pi, math.pi)),
    n_outliers=st.integers(0, 4),
    weighted=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_consensus_first_answers_as_the_full_search(paper_room, pose, n_outliers, weighted, seed):
    rng = np.random.default_rng(seed)
    beacons = paper_room.beacons
    frame = noisy_measurements(*pose, beacons, paper_room.error_model, rng)
    azimuth, _ = inject_outliers(frame.azimuth, n_outliers, rng)
    frame = Measurements(frame.ids, azimuth)
    ransac = Ransac(weighted=weighted)
    estimate = ransac.localize(frame, beacons)
    expected, expected_cov = full_search(ransac, frame, beacons)
    assert estimate.ok == expected.ok
    np.testing.assert_array_equal(estimate.inliers, expected.inliers)
    settled = estimate.diagnostics["n_triplets"] < math.comb(12, 3)
    if not settled:  # the full search itself
        assert estimate.pose == expected.pose or not expected.ok
        return
    assert not weighted and estimate.inliers.all()
    assert estimate.diagnostics["n_triplets"] <= CONSENSUS_TRIPLETS
    # The same minimum of eq. 31 on the same measurements, up to where Levenberg-Marquardt stops.
    assert math.hypot(estimate.x - expected.x, estimate.y - expected.y) < 1e-7
    assert abs(wrap_angle(estimate.heading - expected.heading)) < 1e-8
    # The covariance takes the model's variances at the answer, not at the start.
    np.testing.assert_allclose(estimate.covariance, expected_cov, rtol=0,
                               atol=1e-7 * np.abs(expected_cov).max())


@pytest.mark.parametrize("count", [3, 4, 5, 6, 7])
def test_only_a_frame_of_twenty_triplets_or_more_tries_the_consensus_first(count):
    # K <= 5 has at most ten triplets: the full search costs little more than the consensus.
    xy = at_degrees(*np.linspace(-150.0, 150.0, count))
    beacons = beacon_map(xy)
    frame = ideal_frame(0.5, -0.3, 0.2, beacons)
    estimate = Ransac().localize(frame, beacons)
    assert estimate.ok and estimate.inliers.all()
    consensus_first = math.comb(count, 3) >= CONSENSUS_MIN_TRIPLETS
    assert consensus_first == (count >= 6)
    expected = 1 if consensus_first else math.comb(count, 3)
    assert estimate.diagnostics["n_triplets"] == expected

"""The pairwise ray geometry of :mod:`azgym.localize.bearings`: crossings, spread, agreement."""

from __future__ import annotations

import numpy as np

from azgym.localize.bearings import (
    agreeing,
    crossings,
    intersect_robustly,
    meeting_point,
    pair_spread,
    spread,
)


def test_a_pair_crosses_where_its_two_rays_meet_and_spreads_as_the_pair_does():
    rng = np.random.default_rng(3)
    first, second = rng.uniform(-3, 3, (20, 2)), rng.uniform(-3, 3, (20, 2))
    theta1, theta2 = rng.uniform(-np.pi, np.pi, 20), rng.uniform(-np.pi, np.pi, 20)
    points = crossings(first, theta1, second, theta2)
    spreads = pair_spread(theta1, theta2)
    for k in range(20):
        origins = np.stack((first[k], second[k]))
        bearings = np.array([theta1[k], theta2[k]])
        np.testing.assert_allclose(points[k], meeting_point(origins, bearings, np.ones(2)),
                                   atol=1e-9)
        assert abs(spreads[k] - spread(bearings)) < 1e-7


def test_parallel_rays_cross_nowhere():
    with np.errstate(divide="ignore", invalid="ignore"):
        points = crossings(np.zeros((1, 2)), np.zeros(1), np.ones((1, 2)), np.zeros(1))
    assert not np.isfinite(points).all()


def test_the_rays_that_agree_are_those_the_robust_intersection_weighs_above_half():
    rng = np.random.default_rng(5)
    beacon = np.array([1.0, 2.0])
    origins = rng.uniform(-4, 4, (40, 2))
    bearings = np.arctan2(*(beacon - origins).T[::-1]) + rng.normal(0, 0.01, 40)
    bearings[:8] += rng.uniform(0.3, np.pi, 8)  # strays
    point, weights = intersect_robustly(origins, bearings)
    agree = agreeing(origins, bearings, point)
    assert agree.sum() >= 30
    np.testing.assert_array_equal(agree, weights > 0.5)
    assert not agreeing(origins, bearings, np.full(2, np.nan)).any()

"""Bearing rays by hand: the spread, the meeting point (plain and robust), the misses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.errors import InvalidInputError
from azgym.localize.bearings import (
    MIN_SPREAD,
    intersect_rays,
    intersect_robustly,
    meeting_point,
    ray_misses,
    spread,
)


def _rays_at(point: np.ndarray, bearings: np.ndarray, distance: float) -> np.ndarray:
    """Origins of rays that point along ``bearings`` at ``point`` from ``distance`` away."""
    return point - distance * np.column_stack((np.cos(bearings), np.sin(bearings)))


def test_spread_is_the_angle_of_two_rays_and_ignores_their_sense() -> None:
    for angle in (0.0, 0.05, MIN_SPREAD, 1.0, math.pi / 2):
        assert spread(np.array([0.3, 0.3 + angle])) == pytest.approx(angle, abs=1e-9)
    assert spread(np.array([0.3, 0.3 + math.pi])) == pytest.approx(0.0, abs=1e-7)  # one line
    assert spread(np.zeros(0)) == 0.0


def test_one_stray_ray_hardly_widens_the_spread() -> None:
    """Twenty parallel rays and one at 90°: the arc they cover is 90°, the information along
    them tiny.

    R = |20 + e^{iπ}| / 21 = 19/21, λ = (1 − R)/2 = 1/21, Δ = 2 asin √(1/21).
    """
    bearings = np.concatenate([np.zeros(20), [math.pi / 2]])
    assert spread(bearings) == pytest.approx(2.0 * math.asin(math.sqrt(1.0 / 21.0)), rel=1e-12)
    assert spread(bearings) < math.radians(26.0)


def test_meeting_point_of_two_rays_by_hand() -> None:
    """From (0, 0) at 45° and from (2, 0) at 135°, the rays cross at (1, 1); parallel: NaN."""
    origins = np.array([[0.0, 0.0], [2.0, 0.0]])
    bearings = np.array([math.pi / 4, 3 * math.pi / 4])
    np.testing.assert_allclose(meeting_point(origins, bearings, np.ones(2)), [1.0, 1.0],
                               atol=1e-12)
    assert np.isnan(meeting_point(origins, np.array([0.2, 0.2]), np.ones(2))).all()


def test_intersect_rays_weighs_by_range_and_refuses_parallel_rays() -> None:
    beacon = np.array([4.0, 3.0])
    bearings = np.radians([10.0, 60.0, 100.0])
    origins = _rays_at(beacon, bearings, 5.0)
    point, covariance, misses = intersect_rays(origins, bearings, np.full(3, 1e-6),
                                               np.zeros((3, 2, 2)))
    np.testing.assert_allclose(point, beacon, atol=1e-9)
    np.testing.assert_allclose(misses, 0.0, atol=1e-6)
    assert (np.linalg.eigvalsh(covariance) > 0).all()
    np.testing.assert_allclose(ray_misses(point + [0.0, 0.01], origins, bearings,
                                          np.full(3, 1e-6), np.zeros((3, 2, 2))),
                               0.01 * np.cos(bearings) / 5e-3, rtol=1e-2)  # ranges ≈ 5 m
    with pytest.raises(InvalidInputError, match="parallel"):
        intersect_rays(origins, np.full(3, 0.4), np.full(3, 1e-6), np.zeros((3, 2, 2)))
    with pytest.raises(InvalidInputError, match="two or more rays"):
        intersect_rays(origins[:1], bearings[:1], np.full(1, 1e-6), np.zeros((1, 2, 2)))


def test_intersect_robustly_sets_a_stray_ray_and_one_pointing_away_aside() -> None:
    beacon = np.array([10.0, 0.0])
    bearings = np.radians([-40.0, -20.0, 0.0, 20.0, 40.0])
    origins = _rays_at(beacon, bearings, 8.0)
    stray = np.array([[13.0, -8.0]])  # a misread id: a ray passing 3 m from the beacon
    away = _rays_at(beacon, np.array([0.5]), -3.0)  # on the far side, pointing away
    point, weights = intersect_robustly(
        np.concatenate([origins, stray, away]),
        np.concatenate([bearings, [math.atan2(8.0, 0.0)], [0.5]]))
    np.testing.assert_allclose(point, beacon, atol=0.05)  # a first guess: 1 % of its weight left
    assert (weights[:5] > 0.99).all() and weights[5] < 0.1 and weights[6] == 0.0
    point, _ = intersect_robustly(origins[:2], np.full(2, 0.3))
    assert np.isnan(point).all()

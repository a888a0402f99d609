"""The map repair's ray geometry by hand: the track's own error does not average away.

A suspect's rays start where the track put the camera, along the track's heading plus the
azimuth. The track's position and heading errors are shared by rays taken close in time (they
drift, they do not jump frame to frame), so however many rays meet at a point, the point
carries them: a common shift δ of the camera moves the point by δ, a common turn of the heading
turns the rays about their origins. Counted as independent, they would shrink as 1/N.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import beacon_map

from azgym.core import Measurements
from azgym.errors import InvalidInputError
from azgym.localize.bearings import intersect_rays, meet
from azgym.site.error_model import ErrorModel
from azgym.track.repair import MapRepair
from azgym.track.repair_rays import intersect, locate, origin_covariance, pack, scatter
from azgym.track.repair_state import MAX_KEPT

BEACONS = beacon_map([(1.0, 3.0), (10.0, 10.0), (10.0, 0.0)])
POSITION_VARIANCE = 0.03 ** 2
HEADING_VARIANCE = 0.01 ** 2
COV = np.diag([POSITION_VARIANCE, POSITION_VARIANCE, HEADING_VARIANCE, 1e-8, 1e-6])


def test_the_tracks_shared_error_stays_in_a_new_positions_covariance() -> None:
    # beacon 1 moved from (1, 3) to (1, 1), seen in turn from (0, 0) at 45° and from (2, 0) at
    # 135°: a common shift of the cameras moves the point with them (σ² I); a common turn δ of the
    # heading turns both rays, the first about (0, 0), the second about (2, 0), and their
    # crossing moves by (−2δ, 0) (y = x tan(45° + δ) meets y = (x − 2) tan(135° + δ) at
    # x = 1 − 2δ): together at least σ² I + diag(4 σφ², 0), however many rays
    repair = MapRepair(sightings=3, after=0.2, span=math.radians(20.0), max_std=0.1,
                       threshold=10.83, error_model=ErrorModel(), extra_sigma=0.0)
    made = []
    for k in range(40):
        x = 2.0 * (k % 2)
        azimuth = math.radians(135.0 if k % 2 else 45.0)
        frame = Measurements(np.array([1, 2, 3]), np.array([azimuth, 0.0, 0.0]))
        beacons = repair.begin_frame(BEACONS)
        used = np.array([bool(made), True, True])  # once repaired, the tracker uses it again
        made += repair.observe(0.1 * k, frame, used, beacons, np.array([x, 0.0, 0.0, 0.0, 0.0]),
                               COV, True)[1]
    (found,) = made
    np.testing.assert_allclose(found.new, [1.0, 1.0], atol=1e-9)
    shared = POSITION_VARIANCE * np.eye(2) + np.diag([4.0 * HEADING_VARIANCE, 0.0])
    assert np.linalg.eigvalsh(found.covariance - shared).min() >= -1e-12, found.covariance


def test_scatter_is_the_mean_square_miss_per_degree_of_freedom_at_least_one() -> None:
    # four rays, each missing by one standard deviation: 4 / (4 − 2) = 2, the covariance doubled
    assert scatter(np.ones(4)) == 2.0
    assert scatter(np.full(4, 0.5)) == 1.0  # tighter than their variances say: not narrowed
    assert scatter(np.array([3.0, 3.0])) == 1.0  # two rays: no freedom left to judge them by


def test_a_new_positions_covariance_is_honest_under_the_error_model() -> None:
    # 2000 draws of 20 rays from a camera driving past a beacon 4 m off its path, the track's
    # position and heading errors drawn once per draw (shared by its rays), each azimuth's own
    # error once per ray. The point's error over its covariance, (p − b)ᵀ C⁻¹ (p − b), is at
    # most chi-square with two degrees of freedom when C is honest: it exceeds the 99 % quantile
    # (9.21) in at most 1 % of draws (+ 3 binomial standard deviations over 2000 draws). The
    # rays' own covariance without the shared error is that far off several times as often.
    rng = np.random.default_rng(1)
    beacon = np.array([5.0, 4.0])
    azimuth_std, position_std, heading_std = 0.004, 0.02, 0.005
    draws, exceeded, exceeded_own = 2000, 0, 0
    for _ in range(draws):
        cameras = np.column_stack((np.linspace(0.0, 10.0, 20), np.zeros(20)))
        offset, turn = rng.normal(0.0, position_std, 2), rng.normal(0.0, heading_std)
        true_bearings = np.arctan2(*(beacon - cameras).T[::-1])
        bearings = true_bearings + turn + rng.normal(0.0, azimuth_std, 20)
        rays = np.concatenate([
            pack(camera + offset, np.array([bearing]),
                 azimuth_std ** 2 + heading_std ** 2, position_std ** 2 * np.eye(2),
                 heading_std ** 2, k)
            for k, (camera, bearing) in enumerate(zip(cameras, bearings, strict=True))])
        point, covariance, _ = intersect(rays)
        own = intersect_rays(rays[:, :2], rays[:, 2], rays[:, 3], origin_covariance(rays))[1]
        error = point - beacon
        exceeded += error @ np.linalg.solve(covariance, error) > 9.21
        exceeded_own += error @ np.linalg.solve(own, error) > 9.21
    tolerance = 3.0 * math.sqrt(0.01 * 0.99 / draws)
    assert exceeded / draws <= 0.01 + tolerance, exceeded
    assert exceeded_own / draws > 3 * (0.01 + tolerance), exceeded_own


def test_a_repaired_beacon_is_refined_as_its_rays_widen_and_reported_once() -> None:
    # beacon 1, mapped at (5, 8), hangs at (5, 4): seen from y = 0 as the camera drives east,
    # repaired once its first rays fix it within max_std, then moved where the wider rays since
    # put it, more certainly; the repair is reported once, the refinement in ``placed``. So
    # is a repaired beacon the tracker's state has no room for (MAX_KEPT others kept)
    beacons = beacon_map([(5.0, 8.0), (10.0, 10.0), (10.0, 0.0)])
    truth = np.array([5.0, 4.0])
    repair = MapRepair(sightings=3, after=0.2, span=math.radians(10.0), max_std=0.1,
                       threshold=10.83, error_model=ErrorModel(), extra_sigma=0.0)
    assert all(repair.kept.reserve(other) for other in range(100, 100 + MAX_KEPT))
    cov = np.diag([1e-6, 1e-6, 1e-8, 1e-8, 1e-6])
    rng = np.random.default_rng(3)
    made = []
    for k in range(100):
        camera = np.array([0.1 * k, 0.0])
        azimuth = math.atan2(*(truth - camera)[::-1]) + rng.normal(0.0, 0.004)
        frame = Measurements(np.array([1, 2, 3]), np.array([azimuth, 0.0, 0.0]))
        current = repair.begin_frame(beacons)
        used = np.array([bool(made), True, True])
        made += repair.observe(0.1 * k, frame, used, current, np.r_[camera, 0.0, 0.0, 0.0], cov,
                               True)[1]
    (first,) = made
    placed = repair.placed[1]
    assert placed.time > first.time and placed.old == first.old == (5.0, 8.0)
    assert placed.std < first.std
    assert math.dist(placed.new, truth) < math.dist(first.new, truth)
    np.testing.assert_array_equal(repair.begin_frame(beacons).xyz[0, :2], placed.new)
    assert 1 not in repair.kept


def test_rays_that_spread_but_meet_nowhere_once_weighed_locate_nothing() -> None:
    # twelve rays along the x axis from a camera sure of itself (bearing variance 1e-14, no
    # position error) and two loose ones across it from (-1, ±3): unweighted they meet at
    # (0, 0), and they spread 143°; weighed, the twelve outweigh the two by 10¹³ and the
    # normal matrix is singular to machine precision. A suspect's rays that say nothing are
    # not located: None, not intersect_rays' "parallel" error out of a tracker's update
    tight = [pack(np.array([x, 0.0]), np.zeros(1), 1e-14, np.zeros((2, 2)), 0.0, k)
             for k, x in enumerate(np.linspace(-6.0, -4.0, 12))]
    loose = [pack(np.array([-1.0, y]), np.array([math.atan2(-y, 1.0)]), 0.1,
                  np.eye(2) * 1e-2, 0.0, 12 + k) for k, y in enumerate((-3.0, 3.0))]
    rays = np.concatenate(tight + loose)
    box = (np.full(2, -20.0), np.full(2, 20.0))
    assert locate(rays, math.radians(10.0), 9.0, 0.1, box) is None
    assert intersect(rays) is None
    assert meet(rays[:, :2], rays[:, 2], rays[:, 3], origin_covariance(rays)) is None
    with pytest.raises(InvalidInputError, match="parallel"):  # the checked entry still says so
        intersect_rays(rays[:, :2], rays[:, 2], rays[:, 3], origin_covariance(rays))

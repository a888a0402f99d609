"""The predicted σ: closed forms, the refinement's own covariance, and its invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.localize import _kernels as K
from azgym.localize.refinement import refine_with_covariance
from azgym.placement.information import contributions, position_sigma
from azgym.site.error_model import ErrorModel

WIDTH = 0.03


def sigma_at(point, beacon_xy, model, width=WIDTH):
    beacon_xy = np.asarray(beacon_xy, dtype=float)
    seen = np.ones((1, len(beacon_xy)), dtype=bool)
    info = contributions(np.array([point], dtype=float), beacon_xy,
                         np.full(len(beacon_xy), width), model, seen).sum(axis=1)
    return float(position_sigma(info, seen.sum(axis=1))[0])


def ring(count, radius, centre=(0.0, 0.0), phase=0.0):
    angles = phase + 2 * math.pi * np.arange(count) / count
    return np.c_[centre[0] + radius * np.cos(angles), centre[1] + radius * np.sin(angles)]


@pytest.mark.parametrize(("count", "factor"),
                         [(3, math.sqrt(4 / 3)), (4, 1.0), (6, math.sqrt(2 / 3))])
@pytest.mark.parametrize("radius", [2.0, 7.5])
def test_beacons_evenly_round_the_camera_give_the_closed_form(count, factor, radius):
    # n beacons at distance R, evenly spaced: the information is diag(n/2R², n/2R², n)/s², so
    # σ_pos² = 2 · 2R²s²/n, i.e. σ_pos = s R sqrt(4/n): sqrt(4/3), 1 and sqrt(2/3) for n = 3, 4, 6.
    model = ErrorModel()
    s = math.sqrt(float(model.variance(radius, WIDTH)))
    got = sigma_at((0.0, 0.0), ring(count, radius, phase=0.3), model)
    assert got == pytest.approx(factor * s * radius, rel=1e-12)


def test_the_xy_block_equals_the_full_inverse():
    rng = np.random.default_rng(1)
    model = ErrorModel()
    for _ in range(20):
        beacons = rng.uniform(-10, 10, size=(int(rng.integers(3, 9)), 2))
        point = rng.uniform(-5, 5, size=2)
        info = contributions(point[None], beacons, np.full(len(beacons), WIDTH), model,
                             np.ones((1, len(beacons)), dtype=bool))[0].sum(axis=0)
        xx, xy, xh, yy, yh, hh = info
        cov = np.linalg.inv([[xx, xy, xh], [xy, yy, yh], [xh, yh, hh]])
        assert sigma_at(point, beacons, model) == pytest.approx(
            math.sqrt(cov[0, 0] + cov[1, 1]), rel=1e-9)


def test_it_is_the_covariance_the_weighted_refinement_reports():
    # refine_with_covariance, weighted by the model, started at the true pose on noise-free
    # azimuths, stays there and reports (JᵀWJ)⁻¹: the same σ_pos.
    model = ErrorModel()
    beacons = np.array([[11.0, -7.3], [11.0, 0.0], [7.3, 11.0], [-11.0, 3.0], [-4.0, -11.0]])
    x, y, heading = 2.0, -1.5, 0.7
    azimuth = np.arctan2(beacons[:, 1] - y, beacons[:, 0] - x) - heading
    start = np.array([x, y, math.cos(heading), math.sin(heading)])
    out, cov = np.empty(K.REFINED_SIZE), np.empty((3, 3))
    refine_with_covariance(beacons[:, 0].copy(), beacons[:, 1].copy(), np.cos(azimuth),
                           np.sin(azimuth), np.full(5, WIDTH), np.ones(5, dtype=bool), True,
                           model.delta_alpha_d, model.coverage, start, 20, out, cov)
    assert sigma_at((x, y), beacons, model) == pytest.approx(
        math.sqrt(cov[0, 0] + cov[1, 1]), rel=1e-9)


def test_adding_a_beacon_never_raises_sigma():
    rng = np.random.default_rng(2)
    model = ErrorModel()
    for _ in range(50):
        beacons = rng.uniform(-10, 10, size=(6, 2))
        point = rng.uniform(-5, 5, size=2)
        sigmas = [sigma_at(point, beacons[:k], model) for k in range(3, 7)]
        assert all(later <= earlier * (1 + 1e-12) for earlier, later in
                   zip(sigmas, sigmas[1:], strict=False))


def test_sigma_scales_with_the_noise():
    beacons = ring(5, 6.0, centre=(1.0, 2.0))
    small = sigma_at((0.5, 0.0), beacons, ErrorModel(math.radians(0.2), coverage=False))
    large = sigma_at((0.5, 0.0), beacons, ErrorModel(math.radians(0.6), coverage=False))
    assert large == pytest.approx(3 * small, rel=1e-6)


def test_under_three_beacons_or_on_their_circle_there_is_no_fix():
    model = ErrorModel()
    assert sigma_at((0.0, 0.0), [[5.0, 0.0], [0.0, 5.0]], model) == math.inf
    # The camera on the circle through the three beacons ("danger circle"): singular.
    assert sigma_at((0.0, 0.0), [[2.0, 0.0], [1.0, 1.0], [1.0, -1.0]], model) == math.inf
    assert math.isfinite(sigma_at((0.3, 0.0), [[2.0, 0.0], [1.0, 1.0], [1.0, -1.0]], model))


def test_a_beacon_not_seen_contributes_nothing():
    model = ErrorModel()
    beacons = ring(4, 5.0)
    seen = np.array([[True, True, True, False]])
    info = contributions(np.zeros((1, 2)), beacons, np.full(4, WIDTH), model, seen).sum(axis=1)
    assert float(position_sigma(info, seen.sum(axis=1))[0]) == pytest.approx(
        sigma_at((0.0, 0.0), beacons[:3], model))

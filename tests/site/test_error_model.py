"""The azimuth error model of Sec. 2.2 (eq. 1-3) and the RANSAC tolerance (eq. 25)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from azgym import ErrorModel, InvalidInputError

PAPER_DELTA_D = math.radians(0.4)


def test_eq1_one_pixel_at_150_pixels():
    # atan(u) = u − u³/3 + u⁵/5 − … with u = 1/150:
    # 0.0066666667 − 0.0000000988 + 0.0000000000026
    model = ErrorModel.from_camera(center_error_px=1.0, horizon_radius_px=150.0)
    assert model.delta_alpha_d == pytest.approx(0.0066665679038683, rel=1e-12)
    # The paper calls this "~0.4°" (it is 0.382°).
    assert math.degrees(model.delta_alpha_d) == pytest.approx(0.382, abs=1e-3)
    assert model.coverage is True


def test_eq1_zero_pixel_error_means_no_detection_error():
    assert ErrorModel.from_camera(0.0, 150.0).delta_alpha_d == 0.0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"center_error_px": -1.0, "horizon_radius_px": 150.0}, "center_error_px"),
        ({"center_error_px": 1.0, "horizon_radius_px": 0.0}, "horizon_radius_px"),
        ({"center_error_px": 1.0, "horizon_radius_px": -5.0}, "horizon_radius_px"),
        ({"center_error_px": math.nan, "horizon_radius_px": 150.0}, "center_error_px"),
    ],
)
def test_from_camera_rejects_bad_values(kwargs, field):
    with pytest.raises(InvalidInputError, match=re.escape(field)):
        ErrorModel.from_camera(**kwargs)


@pytest.mark.parametrize("bad", [-1e-3, math.pi / 2, 2.0, math.nan, math.inf])
def test_error_model_rejects_out_of_range_delta(bad):
    with pytest.raises(InvalidInputError, match=re.escape("ErrorModel.delta_alpha_d")):
        ErrorModel(delta_alpha_d=bad)


@pytest.mark.parametrize("bad", ["no", "false", 0, None])
def test_error_model_coverage_must_be_a_boolean(bad):
    # "no" is truthy: read as a flag, it would switch the coverage error on.
    with pytest.raises(InvalidInputError, match=re.escape(
            f"ErrorModel.coverage must be True or False, got {bad!r}")):
        ErrorModel(coverage=bad)


def test_eq2_coverage_bound_hand_values():
    model = ErrorModel(delta_alpha_d=PAPER_DELTA_D)
    # W = 3 cm at D = 2 m: atan(0.0075) = 0.0075 − 0.0075³/3 + … = 0.00749985937975
    assert model.coverage_bound(2.0, 0.03) == pytest.approx(0.0074998593797459, rel=1e-12)
    # W/2 = D: the half-beacon subtends exactly 45°.
    assert model.coverage_bound(0.5, 1.0) == pytest.approx(math.pi / 4, rel=1e-15)
    # Zero width, or a beacon at the camera's position (atan2(W/2, 0) = 90°).
    assert model.coverage_bound(3.0, 0.0) == 0.0
    assert model.coverage_bound(0.0, 0.03) == pytest.approx(math.pi / 2)
    # Vectorised, and falling with distance.
    bounds = model.coverage_bound(np.array([1.0, 2.0, 4.0]), 0.03)
    assert bounds.shape == (3,)
    assert bounds[0] > bounds[1] > bounds[2] > 0


def test_eq2_is_zero_without_coverage_errors():
    model = ErrorModel(delta_alpha_d=PAPER_DELTA_D, coverage=False)
    assert model.coverage_bound(np.array([0.5, 2.0]), 0.03).tolist() == [0.0, 0.0]


def test_eq25_tolerance_hand_values():
    model = ErrorModel(delta_alpha_d=PAPER_DELTA_D)
    # 2 (0.4° + atan(0.0075)) = 2 (0.00698131700798 + 0.00749985937975)
    assert model.tolerance(2.0, 0.03) == pytest.approx(0.0289623527754464, rel=1e-12)
    assert model.tolerance(0.5, 1.0) == pytest.approx(2 * (PAPER_DELTA_D + math.pi / 4))
    no_coverage = ErrorModel(delta_alpha_d=PAPER_DELTA_D, coverage=False)
    assert no_coverage.tolerance(2.0, 0.03) == pytest.approx(2 * PAPER_DELTA_D, rel=1e-15)


def test_variance_hand_values():
    # Two independent uniforms on ±a and ±b: (a² + b²) / 3.
    model = ErrorModel(delta_alpha_d=0.01)
    assert model.variance(0.5, 1.0) == pytest.approx((0.01**2 + (math.pi / 4) ** 2) / 3)
    assert model.variance(1.0, 0.0) == pytest.approx(0.01**2 / 3)
    assert ErrorModel(0.01, coverage=False).variance(0.5, 1.0) == pytest.approx(0.01**2 / 3)


DISTANCES = np.array([0.2, 0.5, 1.0, 3.0, 15.0])
WIDTHS = np.array([0.03, 0.03, 0.3, 0.03, 0.5])


@pytest.mark.parametrize("coverage", [True, False])
def test_sample_never_exceeds_the_eq3_bound(coverage):
    model = ErrorModel(delta_alpha_d=PAPER_DELTA_D, coverage=coverage)
    rng = np.random.default_rng(1)
    bound = model.delta_alpha_d + model.coverage_bound(DISTANCES, WIDTHS)
    draws = np.array([model.sample(DISTANCES, WIDTHS, rng) for _ in range(20_000)])
    assert draws.shape == (20_000, DISTANCES.size)
    assert (np.abs(draws) <= bound).all()
    # ...and the bound is nearly reached: the draws really spread over ±(Δα_d + Δα_c,i).
    assert (np.abs(draws).max(axis=0) > 0.95 * bound).all()
    # Half of the RANSAC tolerance of eq. 25 is exactly this bound.
    assert bound == pytest.approx(0.5 * model.tolerance(DISTANCES, WIDTHS))


def test_sample_variance_matches_variance_by_monte_carlo():
    model = ErrorModel(delta_alpha_d=PAPER_DELTA_D)
    rng = np.random.default_rng(2)
    n = 200_000
    draws = np.stack([model.sample(np.full(n, d), np.full(n, w), rng)
                      for d, w in zip(DISTANCES, WIDTHS, strict=True)], axis=1)
    expected = model.variance(DISTANCES, WIDTHS)
    # The sample variance of n draws of a bounded variable with kurtosis κ <= 3 has a relative
    # standard error sqrt((κ − 1) / n) <= sqrt(2 / n) = 0.32 %; 2 % is > 6 standard errors.
    assert draws.var(axis=0) == pytest.approx(expected, rel=0.02)
    # Zero mean: the standard error of the mean is sqrt(var / n).
    assert (np.abs(draws.mean(axis=0)) < 6 * np.sqrt(expected / n)).all()


def test_sample_is_deterministic_per_seed():
    model = ErrorModel()
    first = model.sample(DISTANCES, WIDTHS, np.random.default_rng(7))
    again = model.sample(DISTANCES, WIDTHS, np.random.default_rng(7))
    other = model.sample(DISTANCES, WIDTHS, np.random.default_rng(8))
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)


def test_sample_with_zero_bounds_is_exactly_zero():
    model = ErrorModel(delta_alpha_d=0.0, coverage=False)
    assert model.sample(DISTANCES, WIDTHS, np.random.default_rng(0)).tolist() == [0.0] * 5

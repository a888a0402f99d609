"""The weighted least-squares accuracy limit of the paper's setting (experiments.paper.bound)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import beacon_map

from azgym import ErrorModel
from azgym.experiments.paper.bound import wls_position_error
from azgym.localize.lsq import LeastSquares
from azgym.sensing.synthetic import ideal_azimuths, noisy_measurements


def numeric_covariance(x, y, beacons, model):
    """(JᵀΣ⁻¹J)⁻¹, J by central differences of the azimuths of eq. 21-22 (no formula shared)."""
    h = 1e-6
    columns = []
    for dx, dy, dphi in ((h, 0, 0), (0, h, 0), (0, 0, h)):
        plus, _ = ideal_azimuths(x + dx, y + dy, dphi, beacons)
        minus, _ = ideal_azimuths(x - dx, y - dy, -dphi, beacons)
        columns.append((plus - minus) / (2 * h))
    jacobian = np.column_stack(columns)
    distance = np.hypot(beacons.xy[:, 0] - x, beacons.xy[:, 1] - y)
    variance = model.variance(distance, beacons.width)
    return np.linalg.inv(jacobian.T @ (jacobian / variance[:, None]))


def test_hand_worked_square_around_the_camera():
    # Four beacons at distance R = 2 m, bearings 0°, 90°, 180°, 270°, width 0, Δα_d = 0.01 rad:
    # each azimuth has variance v = Δα_d²/3. Rows of J are (sin β/R, −cos β/R, −1), so
    # JᵀJ/v = diag(N/2R², N/2R², N)/v and the position covariance is (2R²v/N) I.
    # σ² = 2·4·(1e-4/3)/4 = 6.667e-5 per axis: RMS = sqrt(2σ²) = 0.0115470,
    # mean = σ sqrt(π/2) (Rayleigh) = 0.0102333.
    beacons = beacon_map([(2, 0), (0, 2), (-2, 0), (0, -2)], width=0.0)
    rms, mean = wls_position_error(0.0, 0.0, beacons, ErrorModel(delta_alpha_d=0.01))
    sigma = math.sqrt(2 * 4 * (1e-4 / 3) / 4)
    assert rms == pytest.approx(math.sqrt(2) * sigma, rel=1e-9)
    assert rms == pytest.approx(0.0115470, rel=1e-5)
    assert mean == pytest.approx(sigma * math.sqrt(math.pi / 2), rel=1e-9)
    assert mean == pytest.approx(0.0102333, rel=1e-5)


@pytest.mark.parametrize(("x", "y"), [(3.0, -5.0), (8.0, 8.0), (-9.5, 1.0)])
def test_rms_is_the_trace_of_the_numerically_derived_covariance(paper_room, x, y):
    covariance = numeric_covariance(x, y, paper_room.beacons, paper_room.error_model)
    rms, _ = wls_position_error(x, y, paper_room.beacons, paper_room.error_model)
    assert rms == pytest.approx(math.sqrt(np.trace(covariance[:2, :2])), rel=1e-6)


@pytest.mark.parametrize(("x", "y"), [(3.0, -5.0), (-9.5, 1.0), (10.0, 10.0)])
def test_mean_is_the_mean_norm_of_that_gaussian(paper_room, x, y):
    covariance = numeric_covariance(x, y, paper_room.beacons, paper_room.error_model)[:2, :2]
    rms, mean = wls_position_error(x, y, paper_room.beacons, paper_room.error_model)
    n = 400_000
    draws = np.random.default_rng(1).multivariate_normal(np.zeros(2), covariance, size=n)
    norms = np.hypot(draws[:, 0], draws[:, 1])
    # Standard error of the Monte Carlo mean: std(norm)/sqrt(n) (~0.1 % here); allow 6 of them.
    assert abs(norms.mean() - mean) < 6 * norms.std() / math.sqrt(n)
    assert math.sqrt(np.mean(norms**2)) == pytest.approx(rms, rel=0.01)
    # Jensen: the mean norm is below the RMS; and the error ellipse here is anisotropic, so the
    # mean is not the isotropic RMS·sqrt(π)/2 (which is an upper bound, equality iff isotropic).
    assert mean < rms * math.sqrt(math.pi) / 2


def test_weighted_least_squares_reaches_the_limit(paper_room):
    # End to end: uniform errors of eq. 3, weighted LSQ; its RMS error matches the limit.
    x, y = 3.0, -5.0
    rms, mean = wls_position_error(x, y, paper_room.beacons, paper_room.error_model)
    rng = np.random.default_rng(3)
    localizer = LeastSquares(weighted=True)
    errors = []
    for _ in range(1500):
        frame = noisy_measurements(x, y, 0.3, paper_room.beacons, paper_room.error_model, rng)
        estimate = localizer.localize(frame, paper_room.beacons)
        errors.append(math.hypot(estimate.x - x, estimate.y - y))
    errors = np.array(errors)
    # Relative standard error of an RMS from 1500 runs is ~2 %; allow 8 %.
    assert math.sqrt(np.mean(errors**2)) == pytest.approx(rms, rel=0.08)
    assert errors.mean() == pytest.approx(mean, rel=0.08)


def test_fewer_than_three_beacons_give_inf(paper_room):
    beacons, model = paper_room.beacons, paper_room.error_model
    two = np.zeros(len(beacons), dtype=bool)
    two[[0, 5]] = True
    assert wls_position_error(0.0, 0.0, beacons, model, use=two) == (math.inf, math.inf)
    assert wls_position_error(0.0, 0.0, beacon_map([(1, 0), (0, 1)]), model) == (math.inf,
                                                                                math.inf)
    three = two.copy()
    three[9] = True
    assert all(math.isfinite(v) for v in wls_position_error(0.0, 0.0, beacons, model, use=three))


def test_a_beacon_at_the_camera_carries_no_direction():
    beacons = beacon_map([(0, 0), (3, 0), (0, 3)])
    # Standing on beacon 1 leaves two directions: not enough.
    assert wls_position_error(0.0, 0.0, beacons, ErrorModel()) == (math.inf, math.inf)
    four = beacon_map([(0, 0), (3, 0), (0, 3), (-3, -1)])
    assert math.isfinite(wls_position_error(0.0, 0.0, four, ErrorModel())[0])


def test_beacons_collinear_with_the_camera_give_inf():
    beacons = beacon_map([(1, 0), (2, 0), (-3, 0)])
    assert wls_position_error(0.0, 0.0, beacons, ErrorModel()) == (math.inf, math.inf)


def test_room_centre_is_finite_and_isotropic(paper_room):
    beacons, model = paper_room.beacons, paper_room.error_model
    rms, mean = wls_position_error(0.0, 0.0, beacons, model)
    # By the 90° symmetry, the position covariance at the centre is σ² I with
    # 1/σ² = Σ sin²β_i / (D_i² v_i): 2/(11² v(11)) from the wall centres and
    # 4/(R² v(R)) from the eight others (R² = 1573/9, Σ sin² = 4), v(D) = (Δα_d² + Δα_c(D)²)/3.
    def v(distance):
        return (model.delta_alpha_d**2 + math.atan2(0.015, distance) ** 2) / 3

    radius_sq = 1573.0 / 9.0
    sigma_sq = 1.0 / (2 / (121 * v(11.0)) + 4 / (radius_sq * v(math.sqrt(radius_sq))))
    assert rms == pytest.approx(math.sqrt(2 * sigma_sq), rel=1e-9)
    assert mean == pytest.approx(math.sqrt(sigma_sq * math.pi / 2), rel=1e-9)
    assert 0.02 < mean < 0.03  # the paper's 2.65 cm is an average over the room


@pytest.mark.parametrize(("x", "y"), [(0.0, 0.0), (3.0, 1.0), (-5.0, 2.5), (9.0, -10.0)])
def test_room_symmetry(paper_room, x, y):
    beacons, model = paper_room.beacons, paper_room.error_model
    reference = wls_position_error(x, y, beacons, model)
    assert all(math.isfinite(v) for v in reference)
    # 90° rotations and the mirror images map the room's beacons onto each other.
    for image in ((-y, x), (-x, -y), (y, -x), (x, -y), (-x, y), (y, x)):
        assert wls_position_error(*image, beacons, model) == pytest.approx(reference, rel=1e-9)


def test_closer_to_a_wall_is_not_the_same_as_the_centre(paper_room):
    # A sanity check that the function depends on the position at all.
    beacons, model = paper_room.beacons, paper_room.error_model
    assert wls_position_error(0.0, 0.0, beacons, model) != pytest.approx(
        wls_position_error(9.0, 0.0, beacons, model), rel=1e-3)

"""The closed-form three-beacon solution of Sec. 2.5 (eq. 7-20), as the `triplet` localizer."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame, pose_error_of
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from azgym import InvalidInputError, Measurements, wrap_angle
from azgym.localize.triplet import Triplet

PI = math.pi


def solve(xy, azimuth, **params):
    beacons = beacon_map(xy)
    return Triplet(**params).localize(Measurements(beacons.ids, azimuth), beacons)


def test_hand_worked_camera_at_origin_heading_zero():
    # Camera C = (0, 0), φ = 0. Beacons (1, 0), (0, 1), (−1, 1) are seen at atan2(y, x):
    # 0, 90° and 135°. C is not on their circle (centre (−½, −½), r² = 5/2; |C − centre|² = ½).
    estimate = solve([(1, 0), (0, 1), (-1, 1)], [0.0, PI / 2, 3 * PI / 4])
    assert estimate.ok
    assert estimate.x == pytest.approx(0.0, abs=1e-10)
    assert estimate.y == pytest.approx(0.0, abs=1e-10)
    assert estimate.heading == pytest.approx(0.0, abs=1e-10)
    assert estimate.inliers.tolist() == [True, True, True]


def test_hand_worked_camera_off_origin_facing_north():
    # Camera C = (1, 2), φ = 90°. World bearings β to (4, 2), (1, 5), (−2, 5) are 0°, 90°, 135°,
    # so the camera-frame azimuths α = β − φ are −90°, 0°, 45°.
    estimate = solve([(4, 2), (1, 5), (-2, 5)], [-PI / 2, 0.0, PI / 4])
    assert estimate.ok
    assert estimate.x == pytest.approx(1.0, abs=1e-10)
    assert estimate.y == pytest.approx(2.0, abs=1e-10)
    assert estimate.heading == pytest.approx(PI / 2, abs=1e-10)


def test_hand_worked_heading_behind_the_camera():
    # Same beacons and position as above, φ = 180°: α = β − 180° wraps to 180°, −90°, −45°.
    estimate = solve([(4, 2), (1, 5), (-2, 5)], [PI, -PI / 2, -PI / 4])
    assert estimate.ok
    assert math.hypot(estimate.x - 1.0, estimate.y - 2.0) < 1e-10
    assert abs(abs(estimate.heading) - PI) < 1e-10


@pytest.mark.parametrize("heading", [0.0, PI / 3, -2.0, PI])
def test_eq18_limit_camera_between_two_beacons(heading):
    # Camera at the origin on the segment between (1, 0) and (−1, 0): θ = 180°, sin θ = 0, the
    # limit case of eq. 18. β = 0°, 90°, 180°; α = β − φ.
    azimuth = wrap_angle(np.array([-heading, PI / 2 - heading, PI - heading]))
    estimate = solve([(1, 0), (0, 1), (-1, 0)], azimuth)
    assert estimate.ok, estimate.reason
    x, y = estimate.x, estimate.y
    assert math.hypot(x, y) < 1e-10
    assert abs(math.remainder(estimate.heading - heading, 2 * PI)) < 1e-10


def test_eq18_limit_camera_beyond_two_beacons():
    # C = (0, 0) with (2, 0) and (5, 0) on the same ray: θ = 0, sin θ = 0. Third beacon (0, −3).
    estimate = solve([(2, 0), (5, 0), (0, -3)], [0.0, 0.0, -PI / 2])
    assert estimate.ok, estimate.reason
    assert math.hypot(estimate.x, estimate.y) < 1e-10
    assert abs(estimate.heading) < 1e-10


def test_eq18_limit_camera_beyond_two_beacons_on_the_opposite_side():
    # C = (0, 0) with (−3, 4) and (3, −4) on a line through it; third (4, 3). φ = 0.
    xy = [(-3, 4), (3, -4), (4, 3)]
    azimuth = [math.atan2(4, -3), math.atan2(-4, 3), math.atan2(3, 4)]
    estimate = solve(xy, azimuth)
    assert estimate.ok, estimate.reason
    assert math.hypot(estimate.x, estimate.y) < 1e-10


@pytest.mark.parametrize(
    ("xy", "azimuth"),
    [
        # All three beacons on one line through the camera at the origin.
        ([(1, 1), (2, 2), (-3, -3)], [PI / 4, PI / 4, -3 * PI / 4]),
        ([(1, 0), (2, 0), (7, 0)], [0.0, 0.0, 0.0]),
    ],
    ids=["through-camera", "on-one-ray"],
)
def test_beacons_collinear_with_the_camera_fail_with_a_reason(xy, azimuth):
    estimate = solve(xy, azimuth)
    assert not estimate.ok
    assert "degenerate" in estimate.reason
    assert math.isnan(estimate.x) and math.isnan(estimate.heading)
    assert not estimate.inliers.any()


@pytest.mark.parametrize(("cx", "cy"), [(0.0, -1.0), (0.6, -0.8), (-0.8, -0.6)])
def test_camera_on_the_circumcircle_fails_with_a_reason(cx, cy):
    # Beacons on the unit circle; so is the camera: every point of the circle sees the same
    # angles (the inscribed angle theorem), the position is not determined.
    beacons = beacon_map([(1, 0), (0, 1), (-1, 0)])
    estimate = Triplet().localize(ideal_frame(cx, cy, 0.3, beacons), beacons)
    assert not estimate.ok
    assert "circle" in estimate.reason


def test_best_conditioned_triplet_of_many(paper_beacons, make_frame):
    frame = make_frame(2.5, -4.0, 1.0, paper_beacons)
    estimate = Triplet().localize(frame, paper_beacons)
    position_error, heading_error = pose_error_of(estimate, 2.5, -4.0, 1.0)
    assert position_error < 1e-9 and heading_error < 1e-10
    assert estimate.n_inliers == 3  # no redundancy is used
    assert 0.0 < estimate.diagnostics["conditioning"] <= 1.0


def test_a_ghost_never_forms_a_triplet_with_its_own_beacon():
    # Three detections, two of them of beacon 2: only two distinct beacons.
    beacons = beacon_map([(1, 0), (0, 1), (-1, 1)])
    frame = Measurements([1, 2, 2], [0.0, PI / 2, 3 * PI / 4])
    estimate = Triplet().localize(frame, beacons)
    assert not estimate.ok
    assert "fewer than 3 distinct beacons" in estimate.reason


def test_a_ghost_beside_three_beacons_is_not_used():
    beacons = beacon_map([(1, 0), (0, 1), (-1, 1)])
    frame = Measurements([1, 2, 3, 2], [0.0, PI / 2, 3 * PI / 4, 0.3])
    estimate = Triplet().localize(frame, beacons)
    assert estimate.ok
    assert math.hypot(estimate.x, estimate.y) < 1e-10
    assert estimate.inliers.tolist() == [True, True, True, False]


def test_degeneracy_tol_is_validated():
    with pytest.raises(InvalidInputError, match=re.escape("Triplet.degeneracy_tol")):
        solve([(1, 0), (0, 1), (-1, 1)], [0.0, PI / 2, 3 * PI / 4], degeneracy_tol=-1.0)


coordinate = st.floats(-10.0, 10.0, allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(coordinate, coordinate), min_size=4, max_size=4),
       st.floats(-PI, PI, allow_nan=False))
def test_noise_free_random_poses_are_recovered(points, heading):
    (cx, cy), *xy = points
    xy = np.array(xy)
    # Camera at least 0.3 m from every beacon, beacons apart, not nearly on one line.
    assume(np.hypot(xy[:, 0] - cx, xy[:, 1] - cy).min() >= 0.3)
    sides = np.hypot(*(xy - np.roll(xy, 1, axis=0)).T)
    assume(sides.min() >= 0.5)
    (ex, ey), (fx, fy) = xy[1] - xy[0], xy[2] - xy[0]
    area = 0.5 * abs(ex * fy - ey * fx)
    assume(area >= 0.05 * sides.max() ** 2)
    # Circumcircle: the camera well away from it.
    a, b, c = xy
    d = 2 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    ux = (a @ a * (b[1] - c[1]) + b @ b * (c[1] - a[1]) + c @ c * (a[1] - b[1])) / d
    uy = (a @ a * (c[0] - b[0]) + b @ b * (a[0] - c[0]) + c @ c * (b[0] - a[0])) / d
    radius = math.hypot(a[0] - ux, a[1] - uy)
    assume(abs(math.hypot(cx - ux, cy - uy) - radius) >= max(0.3, 0.1 * radius))

    # The algebra is exact on noise-free data down to a tiny determinant; the default tolerance
    # would refuse some of these triplets, whose answers noise would move by metres.
    beacons = beacon_map(xy)
    estimate = Triplet(degeneracy_tol=1e-9).localize(ideal_frame(cx, cy, heading, beacons),
                                                     beacons)
    assert estimate.ok, estimate.reason
    position_error, heading_error = pose_error_of(estimate, cx, cy, heading)
    assert position_error < 1e-6
    assert heading_error < 1e-8

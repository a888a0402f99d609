"""The method of exhaustion (eq. 34): exhaustive grid search and its coarse-to-fine shortcut."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from helpers import ideal_frame, pose_error_of

from azgym import InvalidInputError, Measurements
from azgym.localize.base import Problem
from azgym.localize.mex import Mex
from azgym.sensing.synthetic import inject_outliers, noisy_measurements

STEP = 0.01


def grid_index(estimate, x0: float, y0: float, step: float = STEP) -> tuple[int, int]:
    """(column, row) of an estimate on the grid from (x0, y0), checking it lies on the grid."""
    i, j = (estimate.x - x0) / step, (estimate.y - y0) / step
    assert abs(i - round(i)) < 1e-6 and abs(j - round(j)) < 1e-6, (estimate.x, estimate.y)
    return round(i), round(j)


def window(x: float, y: float, half: float = 3.0) -> tuple[float, float, float, float]:
    """A (2·half) m square around (x, y) whose corner is on the centimetre lattice."""
    x0, y0 = round(x - half, 2), round(y - half, 2)
    return (x0, y0, x0 + 2 * half, y0 + 2 * half)


@pytest.mark.parametrize(("i", "j", "heading"), [(300, 300, 0.0), (123, 457, 2.5), (40, 555, -1.0)])
def test_truth_on_a_grid_point_is_found_exactly(paper_beacons, i, j, heading):
    x0, y0 = -4.0, -2.5
    x, y = x0 + i * STEP, y0 + j * STEP  # the very floats the grid evaluates
    estimate = Mex(bounds=(x0, y0, x0 + 6.0, y0 + 6.0)).localize(
        ideal_frame(x, y, heading, paper_beacons), paper_beacons)
    assert estimate.ok
    assert grid_index(estimate, x0, y0) == (i, j)
    position_error, heading_error = pose_error_of(estimate, x, y, heading)
    assert position_error < 1e-12
    assert heading_error < 1e-10
    assert estimate.diagnostics["cost"] < 1e-20
    assert estimate.diagnostics["grid_shape"] == (601, 601)


@pytest.mark.parametrize(
    ("x", "y", "heading"),
    [(0.3118, -1.2719, 0.5), (-4.4418, 3.0012, -2.0), (5.1183, 5.7519, 3.0), (2.0, -7.4386, 1.0)],
)
def test_noise_free_frame_gives_the_grid_point_nearest_the_truth(paper_beacons, x, y, heading):
    # Every truth is at most 0.2 steps from its nearest grid point in each coordinate, so its
    # neighbours are >= 0.8 steps away: with a cost ~ quadratic in the offset, the nearest wins.
    bounds = window(x, y)
    estimate = Mex(bounds=bounds).localize(ideal_frame(x, y, heading, paper_beacons),
                                           paper_beacons)
    nearest = (round((x - bounds[0]) / STEP), round((y - bounds[1]) / STEP))
    assert grid_index(estimate, bounds[0], bounds[1]) == nearest
    assert pose_error_of(estimate, x, y, heading)[0] <= STEP * math.sqrt(0.5)


def test_exhaustive_grid_over_the_whole_room_by_default(paper_beacons):
    mex = Mex()
    problem = Problem.from_frame(ideal_frame(0.0, 0.0, 0.0, paper_beacons), paper_beacons)
    assert mex.grid(problem) == (-11.0, -11.0, 2201, 2201)
    assert Mex(step=0.5, bounds=(0, 0, 2, 1)).grid(problem) == (0.0, 0.0, 5, 3)


def test_single_point_grid_returns_that_point(paper_beacons):
    estimate = Mex(bounds=(1.0, 2.0, 1.0, 2.0)).localize(
        ideal_frame(1.3, 2.4, 0.7, paper_beacons), paper_beacons)
    assert (estimate.x, estimate.y) == (1.0, 2.0)
    assert estimate.diagnostics["grid_shape"] == (1, 1)


def test_every_known_measurement_is_an_inlier(paper_beacons):
    frame = ideal_frame(0.5, 0.5, 0.0, paper_beacons)
    ids = np.append(frame.ids, 404)
    azimuth = np.append(frame.azimuth, 1.0)
    estimate = Mex(bounds=(-1, -1, 1, 1), step=0.05).localize(Measurements(ids, azimuth),
                                                              paper_beacons)
    assert estimate.inliers.tolist() == [True] * 12 + [False]


def outlier_frame(paper_room, seed: int):
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(-8.0, 8.0, 2)
    heading = rng.uniform(-math.pi, math.pi)
    frame = noisy_measurements(x, y, heading, paper_room.beacons, paper_room.error_model, rng)
    azimuth, _ = inject_outliers(frame.azimuth, 1 + seed % 5, rng)  # K = 1..5
    return float(x), float(y), Measurements(frame.ids, azimuth)


@pytest.mark.parametrize("seed", range(10))
def test_coarse_to_fine_finds_the_exhaustive_argmin_with_outliers(paper_room, seed):
    x, y, frame = outlier_frame(paper_room, seed)
    bounds = window(x, y)
    exhaustive = Mex(bounds=bounds).localize(frame, paper_room.beacons)
    fast = Mex(bounds=bounds, coarse_step=0.1).localize(frame, paper_room.beacons)
    assert grid_index(fast, *bounds[:2]) == grid_index(exhaustive, *bounds[:2])
    assert fast.diagnostics["cost"] == pytest.approx(exhaustive.diagnostics["cost"], rel=1e-12)
    assert abs(fast.heading - exhaustive.heading) < 1e-9


@pytest.mark.parametrize("seed", [100, 101])
def test_coarse_to_fine_matches_exhaustive_over_the_whole_room(paper_room, seed):
    x, y, frame = outlier_frame(paper_room, seed)
    exhaustive = Mex().localize(frame, paper_room.beacons)
    fast = Mex(coarse_step=0.1).localize(frame, paper_room.beacons)
    assert grid_index(fast, -11.0, -11.0) == grid_index(exhaustive, -11.0, -11.0)


def test_coarse_to_fine_in_a_long_valley(paper_beacons):
    # Found by sampling: pose (−0.7475, −6.7515, −1.2193) in the paper room, noisy, 3 deranged
    # measurements (beacons 5, 8, 12). The exhaustive minimum is (−0.02, −4.88); the coarse grid's
    # lowest point is (−0.05, −4.75), whose ±0.1 m fine window ends at −4.85.
    azimuth = [1.1732975919442918, 1.7399632679003265, 2.0885524919800167, 2.3634678431303806,
               -2.5001702281941798, 3.138288599063211, -2.8648504820490803, 0.7335098384156118,
               -1.863174938518199, -1.3551802848761403, -0.17344931850743706, 2.750248591238969]
    frame = Measurements(paper_beacons.ids, azimuth)
    bounds = (-3.75, -9.75, 2.25, -3.75)
    exhaustive = Mex(bounds=bounds).localize(frame, paper_beacons)
    assert grid_index(exhaustive, -3.75, -9.75) == (373, 487)
    fast = Mex(bounds=bounds, coarse_step=0.1).localize(frame, paper_beacons)
    assert grid_index(fast, -3.75, -9.75) == (373, 487)


@pytest.mark.parametrize("beacon_id", [2, 8, 11])
def test_coarse_to_fine_matches_exhaustive_with_the_camera_on_a_beacon(paper_room, beacon_id):
    # The camera sits exactly on a wall-centre beacon: that beacon's azimuth is garbage (coverage
    # error up to 90°) and E_ref is singular there, with a basin narrower than the coarse step.
    # (The exhaustive answer itself may be metres off: see baselines/README.md.)
    beacons = paper_room.beacons
    x, y = beacons.xy[beacons.index_of([beacon_id])[0]]
    rng = np.random.default_rng(beacon_id)
    frame = noisy_measurements(x, y, 0.8, beacons, paper_room.error_model, rng)
    exhaustive = Mex().localize(frame, beacons)
    fast = Mex(coarse_step=0.1).localize(frame, beacons)
    assert grid_index(fast, -11.0, -11.0) == grid_index(exhaustive, -11.0, -11.0)


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"bounds": (0.0, 0.0, 1.0)}, "Mex.bounds must be (x_min, y_min, x_max, y_max)"),
        ({"bounds": (0.0, 0.0, 1.0, 1.0, 2.0)}, "Mex.bounds must be (x_min, y_min, x_max, y_max)"),
        ({"bounds": (0.0, math.nan, 1.0, 1.0)}, "Mex.bounds must be a number"),
        ({"bounds": (0.0, 0.0, math.inf, 1.0)}, "Mex.bounds must be a number"),
        ({"bounds": (0.0, "0", 1.0, 1.0)}, "Mex.bounds must be a number"),
        ({"bounds": (1.0, 0.0, 0.0, 1.0)}, "Mex.bounds has max < min"),
        ({"bounds": (0.0, 1.0, 1.0, 0.0)}, "Mex.bounds has max < min"),
    ],
)
def test_bounds_are_validated(paper_beacons, params, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        Mex(**params).localize(ideal_frame(0.0, 0.0, 0.0, paper_beacons), paper_beacons)


def test_coarse_step_must_be_a_multiple_of_step(paper_beacons):
    frame = ideal_frame(0.0, 0.0, 0.0, paper_beacons)
    with pytest.raises(InvalidInputError, match=re.escape("Mex.coarse_step must be a multiple")):
        Mex(step=0.02, coarse_step=0.05, bounds=(-1, -1, 1, 1)).localize(frame, paper_beacons)
    # 0.3 / 0.1 is 2.9999999999999996 in floating point: still a multiple.
    estimate = Mex(step=0.1, coarse_step=0.3, bounds=(-1, -1, 1, 1)).localize(frame,
                                                                               paper_beacons)
    assert (estimate.x, estimate.y) == pytest.approx((0.0, 0.0), abs=1e-12)

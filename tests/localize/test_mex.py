"""The method of exhaustion (eq. 34): exhaustive grid search and its coarse-to-fine shortcut."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame, pose_error_of

import azgym
from azgym import InvalidInputError, Measurements
from azgym.localize.base import Problem
from azgym.localize.mex import Mex
from azgym.sensing.synthetic import inject_outliers, noisy_measurements

STEP = 0.01


def grid_index(estimate, x0: float, y0: float, step: float = STEP) -> tuple[int, int]:
    """(column, row) of an estimate on the grid from (x0, y0), checking it lies on the grid.

    For an estimate refused because the cost falls beyond the grid's edge, the edge point where
    the search ended (a coarse-to-fine search must end there as much as the exhaustive one).
    """
    x, y = (estimate.x, estimate.y) if estimate.ok else estimate.diagnostics["grid_point"]
    i, j = (x - x0) / step, (y - y0) / step
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


def test_single_point_grid_returns_that_point_when_the_camera_is_there(paper_beacons):
    estimate = Mex(bounds=(1.0, 2.0, 1.0, 2.0)).localize(
        ideal_frame(1.003, 1.998, 0.7, paper_beacons), paper_beacons)
    assert (estimate.x, estimate.y) == (1.0, 2.0)
    assert estimate.diagnostics["grid_shape"] == (1, 1)


def test_single_point_grid_away_from_the_camera_is_refused(paper_beacons):
    # The one grid point is 0.5 m from the camera: its neighbours outside the grid cost less.
    estimate = Mex(bounds=(1.0, 2.0, 1.0, 2.0)).localize(
        ideal_frame(1.3, 2.4, 0.7, paper_beacons), paper_beacons)
    assert not estimate.ok
    assert "on the edge of the grid and the cost keeps falling outside it" in estimate.reason


OUTSIDE = [(9.0, 2.0, 0.3), (-3.0, -4.0, 2.0), (2.0, 12.0, -1.0), (4.6, 4.6, 3.0)]


@pytest.mark.parametrize("coarse_step", [None, 0.5])
@pytest.mark.parametrize(("x", "y", "heading"), OUTSIDE)
def test_camera_outside_the_grid_is_refused_not_answered_from_the_edge(x, y, heading,
                                                                       coarse_step):
    # The map's extent is its beacons' box, (0, 0)-(4, 5), grown by the margin of 0.3 m; the
    # camera is outside it. The old answer was the edge point nearest the cost's slope, metres
    # off, ok=True.
    beacons = beacon_map([(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0), (2.0, 5.0)])
    estimate = Mex(step=0.05, coarse_step=coarse_step, margin=0.3).localize(
        ideal_frame(x, y, heading, beacons), beacons)
    assert not estimate.ok
    assert "the camera is outside the searched area (the map's extent" in estimate.reason
    assert math.isnan(estimate.x)


FORWARD = [(-2.0, 2.0, 0.0), (12.0, 3.0, math.pi), (4.0, -3.0, math.pi / 2)]


@pytest.mark.parametrize("coarse_step", [None, 0.5])
@pytest.mark.parametrize(("x", "y", "heading"), FORWARD)
def test_a_forward_camera_outside_the_seen_beacons_box_is_found_in_the_maps_extent(
        x, y, heading, coarse_step):
    # A forward camera (a 70° view) sees only the beacons ahead: never inside their box. mex
    # used to refuse every such frame ("outside the searched area"); the map's extent holds it.
    beacons = beacon_map([(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0), (2.0, 2.0),
                          (8.0, 2.0), (8.0, 5.0)])
    frame = ideal_frame(x, y, heading, beacons)
    ahead = np.abs(frame.azimuth) < math.radians(35.0)
    seen = Measurements(frame.ids[ahead], frame.azimuth[ahead])
    box = beacons.xy[beacons.index_of(seen.ids)]
    assert len(seen) >= 3
    assert not ((box.min(axis=0) <= (x, y)) & ((x, y) <= box.max(axis=0))).all()
    estimate = Mex(step=0.05, coarse_step=coarse_step).localize(seen, beacons)
    assert estimate.ok, estimate.reason
    assert pose_error_of(estimate, x, y, heading)[0] <= 0.05
    assert "the camera is outside the searched area" in Mex(
        step=0.05, coarse_step=coarse_step, margin=0.0).localize(seen, beacons).reason


def test_the_maps_extent_too_large_to_search_is_a_refusal_not_an_error():
    beacons = beacon_map([(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0), (2.0, 5.0)])
    estimate = Mex(step=0.05, margin=1e4).localize(ideal_frame(9.0, 2.0, 0.3, beacons), beacons)
    assert not estimate.ok
    assert "outside the searched area" in estimate.reason
    assert "more than 1e+08" in estimate.reason


def test_bounds_from_a_spec_are_the_area_searched():
    beacons = beacon_map([(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0), (2.0, 5.0)])
    mex = azgym.make_localizer("mex:bounds=8,1,10,3,step=0.05")
    assert mex.get_params()["bounds"] == [8, 1, 10, 3]
    estimate = mex.localize(ideal_frame(9.0, 2.0, 0.3, beacons), beacons)
    assert estimate.ok and pose_error_of(estimate, 9.0, 2.0, 0.3)[0] < 1e-9
    assert estimate.diagnostics["grid_shape"] == (41, 41)
    outside = mex.localize(ideal_frame(2.0, 2.0, 0.3, beacons), beacons)
    assert "outside the searched area (bounds;" in outside.reason


@pytest.mark.parametrize(("spec", "message"), [
    ("mex:bounds=0,0,5", "Mex.bounds must be (x_min, y_min, x_max, y_max) (in a spec: "
                         "bounds=x_min,y_min,x_max,y_max), got [0, 0, 5]"),
    ("mex:bounds=5,0,0,5", "Mex.bounds has max < min: [5, 0, 0, 5]"),
    ("mex:bounds=0,0,five,5", "bounds=0,0,five,5 is not a list of numbers separated by commas "
                              "('five' is not a number"),
    ("mex:bounds=0,0,5,5,", "a comma with nothing after it"),
    ("mex:margin=-1", "Mex.margin must be >= 0, got -1"),
])
def test_bad_bounds_in_a_spec_name_the_field(spec, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        azgym.make_localizer(spec)


@pytest.mark.parametrize(("x", "y"), [(0.01, 2.0), (3.98, 0.52), (1.0, 4.0), (0.0, 1.5)])
def test_camera_just_inside_the_edge_is_still_found(x, y):
    # The cost is anisotropic this close to the beacons' hull, so the grid's argmin may be a
    # neighbour of the nearest grid point: within two steps (test_properties bounds it exactly).
    beacons = beacon_map([(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0), (2.0, 5.0)])
    estimate = Mex(step=0.05).localize(ideal_frame(x, y, 0.4, beacons), beacons)
    assert estimate.ok, estimate.reason
    assert pose_error_of(estimate, x, y, 0.4)[0] <= 2 * 0.05


@pytest.mark.parametrize(
    ("params", "message"),
    [({"step": 1e-300}, "Mex.step=1e-300 is below the floating-point resolution"),
     ({"step": 1e-5}, "points to evaluate, more than 1e+08"),
     ({"step": 1e-6, "coarse_step": 1e-3}, "points to evaluate, more than 1e+08"),
     ({"step": 1e-9, "coarse_step": 1e-6}, "points a side")],
)
def test_grids_too_large_to_search_raise_before_any_work(params, message):
    # Each of these used to end in OverflowError, MemoryError or a run of hours.
    beacons = beacon_map([(0.0, 0.0), (400.0, 0.0), (400.0, 400.0), (0.0, 400.0)])
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        Mex(**params).localize(ideal_frame(100.0, 200.0, 0.0, beacons), beacons)


def test_beacons_at_huge_coordinates_raise_a_named_error():
    beacons = beacon_map([(0.0, 0.0), (4e200, 0.0), (4e200, 4e200), (0.0, 4e200)])
    with pytest.raises(InvalidInputError, match=re.escape("below the floating-point resolution")):
        Mex().localize(ideal_frame(1e200, 2e200, 0.1, beacons), beacons)


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
    assert fast.ok == exhaustive.ok
    assert grid_index(fast, *bounds[:2]) == grid_index(exhaustive, *bounds[:2])
    assert fast.diagnostics["cost"] == pytest.approx(exhaustive.diagnostics["cost"], rel=1e-12)
    assert not fast.ok or abs(fast.heading - exhaustive.heading) < 1e-9


@pytest.mark.parametrize("seed", [100, 101])
def test_coarse_to_fine_matches_exhaustive_over_the_whole_room(paper_room, seed):
    x, y, frame = outlier_frame(paper_room, seed)
    exhaustive = Mex().localize(frame, paper_room.beacons)
    fast = Mex(coarse_step=0.1).localize(frame, paper_room.beacons)
    assert fast.ok == exhaustive.ok
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
    assert fast.ok == exhaustive.ok
    assert grid_index(fast, -11.0, -11.0) == grid_index(exhaustive, -11.0, -11.0)


def test_coarse_step_must_be_a_multiple_of_step(paper_beacons):
    frame = ideal_frame(0.0, 0.0, 0.0, paper_beacons)
    with pytest.raises(InvalidInputError, match=re.escape("Mex.coarse_step must be a multiple")):
        Mex(step=0.02, coarse_step=0.05, bounds=(-1, -1, 1, 1)).localize(frame, paper_beacons)
    # 0.3 / 0.1 is 2.9999999999999996 in floating point: still a multiple.
    estimate = Mex(step=0.1, coarse_step=0.3, bounds=(-1, -1, 1, 1)).localize(frame,
                                                                               paper_beacons)
    assert (estimate.x, estimate.y) == pytest.approx((0.0, 0.0), abs=1e-12)


@pytest.mark.parametrize("coarse", [False, True])
def test_an_answer_on_the_seen_box_edge_next_to_a_beacon_is_checked_beyond_it(coarse):
    """A camera below four beacons (azimuths spread under π): the measured beacons' box has its
    best point on its edge, next to a beacon, with the cost rising outside; the camera is 0.2 m
    further out. The map's extent is searched too and its lower cost wins (found by the
    property test of mex)."""
    beacons = azgym.BeaconMap(np.array([1, 2, 3, 4]), np.array([
        [0.14367394, 0.14367394, 2.5], [0.23945657, 0.04789131, 2.5],
        [-0.23945657, -0.09578263, 2.5], [0.14367394, -0.14367394, 2.5]]), width=0.03)
    pose = (-0.09019322380503517, -0.3125037274910326, 0.0)
    step = 0.5126323423905267 / 40
    mex = Mex(step=step, coarse_step=4 * step if coarse else None, margin=0.5126323423905267)
    estimate = mex.localize(ideal_frame(*pose, beacons), beacons)
    assert estimate.ok
    assert math.hypot(estimate.x - pose[0], estimate.y - pose[1]) < step

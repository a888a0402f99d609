"""Map repair's fit test: the likelihood ratio by hand and against its dense formula, its null
distribution, which beacon it takes as moved, its bounded ring, and a fitted move on a route."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from helpers import beacon_map, dense_likelihood_ratio

import azgym
from azgym import InvalidInputError, Measurements
from azgym.site.error_model import ErrorModel
from azgym.track.repair import MapRepair
from azgym.track.repair_fit import (
    MAX_DETECTIONS,
    SHARED_ERROR_S,
    FitTest,
    likelihood_ratio,
)
from azgym.world.drive import simulate

SIGMA = math.radians(0.25)
BEACON = np.array([6.0, 4.0])


def path(count: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Times and camera positions of a camera driving past :data:`BEACON` at 1 m/s."""
    times = np.arange(count) * 0.1
    return times, np.column_stack((times, np.zeros(count)))


def sensitivities(cameras: np.ndarray, beacon: np.ndarray = BEACON) -> np.ndarray:
    """d(bearing)/d(beacon) up to sign, per camera (K, 2): the unit normal over the range."""
    offsets = beacon - cameras
    return np.column_stack((-offsets[:, 1], offsets[:, 0])) / (offsets ** 2).sum(axis=1)[:, None]


def bearings_with(cameras: np.ndarray, residuals: np.ndarray,
                  beacon: np.ndarray = BEACON) -> np.ndarray:
    offsets = beacon - cameras
    return np.arctan2(offsets[:, 1], offsets[:, 0]) + residuals


# -- the ratio, by hand ------------------------------------------------------------------------

def test_with_an_exact_track_a_residual_a_move_explains_counts_in_full():
    times, cameras = path()
    residuals = sensitivities(cameras) @ np.array([0.02, -0.05])  # what a small move turns
    ratio = likelihood_ratio(times, cameras, bearings_with(cameras, residuals), np.zeros((3, 3)),
                             np.full(times.size, SIGMA ** 2), BEACON)
    assert ratio == pytest.approx(np.sum(residuals ** 2) / SIGMA ** 2, rel=1e-9)


def test_a_residual_no_move_explains_counts_nothing():
    times, cameras = path()
    sensitivity = sensitivities(cameras)
    noise = np.random.default_rng(1).normal(0.0, SIGMA, times.size)
    basis, _ = np.linalg.qr(sensitivity)
    unexplained = noise - basis @ (basis.T @ noise)
    ratio = likelihood_ratio(times, cameras, bearings_with(cameras, unexplained),
                             np.zeros((3, 3)), np.full(times.size, SIGMA ** 2), BEACON)
    assert ratio == pytest.approx(0.0, abs=1e-9)


def test_bearings_along_one_line_give_the_one_dimensional_ratio():
    times = np.arange(10) * 0.1
    cameras = np.column_stack((np.linspace(0.0, 3.0, 10), np.zeros(10)))
    beacon = np.array([10.0, 0.0])  # every camera on the line through the beacon
    residuals = np.random.default_rng(2).normal(0.0, SIGMA, 10)
    along = 1.0 / (beacon[0] - cameras[:, 0])  # |J_k|: each bearing's normal over its range
    ratio = likelihood_ratio(times, cameras, bearings_with(cameras, residuals, beacon),
                             np.zeros((3, 3)), np.full(10, SIGMA ** 2), beacon)
    expected = np.sum(along * residuals) ** 2 / (SIGMA ** 2 * np.sum(along ** 2))
    assert ratio == pytest.approx(expected, rel=1e-9)


def test_with_a_shared_track_error_it_is_the_dense_formula():
    rng = np.random.default_rng(3)
    times, cameras = path()
    root = rng.normal(size=(3, 3)) * np.array([0.02, 0.02, 0.003])[:, None]
    covariance = root @ root.T
    variances = rng.uniform(0.5, 2.0, times.size) * SIGMA ** 2
    residuals = rng.normal(0.0, 2.0 * SIGMA, times.size)
    ratio = likelihood_ratio(times, cameras, bearings_with(cameras, residuals), covariance,
                             variances, BEACON)
    assert ratio == pytest.approx(dense_likelihood_ratio(times, cameras,
                                                         bearings_with(cameras, residuals),
                                                         covariance, variances, BEACON),
                                  rel=1e-8)


def test_where_the_map_is_right_it_is_chi_square_with_two_degrees_of_freedom():
    rng = np.random.default_rng(4)
    times, cameras = path()
    covariance = np.diag([0.02 ** 2, 0.02 ** 2, math.radians(0.3) ** 2])
    variances = np.full(times.size, SIGMA ** 2)
    shared = np.column_stack((sensitivities(cameras), np.ones(times.size)))
    sigma = np.diag(variances) + (shared @ covariance @ shared.T) * np.exp(
        -np.abs(np.subtract.outer(times, times)) / SHARED_ERROR_S)
    draws = rng.multivariate_normal(np.zeros(times.size), sigma, size=4000)
    ratios = np.array([likelihood_ratio(times, cameras, bearings_with(cameras, r), covariance,
                                        variances, BEACON) for r in draws])
    # chi-square(2): mean 2 (standard error 2/√4000 = 0.032), P(> 5.99) = 0.05 (se 0.0034)
    assert abs(ratios.mean() - 2.0) < 0.16
    assert abs(np.mean(ratios > 5.991) - 0.05) < 0.017


def test_a_covariance_not_positive_definite_gives_no_ratio():
    times, cameras = path(5)
    assert math.isnan(likelihood_ratio(times, cameras, bearings_with(cameras, np.zeros(5)),
                                       np.zeros((3, 3)), np.zeros(5), BEACON))


# -- which beacon is taken as moved ------------------------------------------------------------

MAP = beacon_map([(6.0, 4.0), (2.0, 5.0), (9.0, -4.0), (-2.0, -5.0)])
COV = np.diag([1e-4, 1e-4, 1e-6, 1e-8, 1e-6])


NO_OFFSET = np.zeros(2)


def feed(test: FitTest, where: np.ndarray, offset: np.ndarray = NO_OFFSET, frames: int = 60,
         seed: int = 5) -> list[int]:
    """Frames at 10 Hz from a camera driving along x, the track exact but by ``offset``, each
    beacon seen where ``where`` has it (noise of :data:`SIGMA`); the beacons taken as moved."""
    rng = np.random.default_rng(seed)
    taken = []
    for k in range(frames):
        camera = np.array([0.1 * k, 0.0])
        offsets = where[:, :2] - camera
        azimuths = np.arctan2(offsets[:, 1], offsets[:, 0]) + rng.normal(0.0, SIGMA, len(where))
        state = np.array([*(camera + offset), 0.0, 0.0, 0.0])
        test.record(0.1 * k, Measurements(MAP.ids[:len(where)], azimuths),
                    np.ones(len(where), dtype=bool), state, COV)
        found = test.moved(0.1 * k, MAP)
        if found is not None:
            taken.append(found)
    return taken


def fit_test() -> FitTest:
    return FitTest(ErrorModel(), math.radians(0.1))


def test_a_beacon_whose_azimuths_point_past_it_is_taken_as_moved_while_the_others_agree():
    where = MAP.xyz.copy()
    where[0, :2] += 0.6 * (where[0, :2] / np.linalg.norm(where[0, :2]))  # along the sight line
    assert feed(fit_test(), where)[:1] == [int(MAP.ids[0])]
    assert feed(fit_test(), MAP.xyz) == []  # nothing moved: nothing taken


def test_with_one_other_beacon_in_view_no_beacon_is_taken():
    where = MAP.xyz[:2].copy()
    where[0, :2] += 0.6 * (where[0, :2] / np.linalg.norm(where[0, :2]))
    assert feed(fit_test(), where) == []


def test_a_track_that_is_off_is_not_taken_for_a_moved_beacon():
    assert feed(fit_test(), MAP.xyz, offset=np.array([0.0, 0.25])) == []


def test_the_ring_holds_the_latest_detections_at_any_frame_rate():
    test = fit_test()
    ids = np.arange(1, 401)
    for k in range(3 * MAX_DETECTIONS // ids.size):
        test.record(1e-3 * k, Measurements(ids, np.zeros(ids.size)),
                    np.ones(ids.size, dtype=bool), np.zeros(5), COV)
    kept = test._kept
    assert kept.shape[0] == MAX_DETECTIONS
    assert np.nanmax(kept[:, 0]) == pytest.approx(1e-3 * (3 * MAX_DETECTIONS // ids.size - 1))
    assert test.moved(1.0, MAP) is None  # none of them on the map: nothing to test


def test_a_beacon_the_fit_test_set_aside_is_not_cleared_by_azimuths_that_pass_the_gate():
    repair = MapRepair(sightings=3, after=0.2, span=math.radians(20.0), max_std=0.1,
                       threshold=10.83, error_model=ErrorModel(), extra_sigma=math.radians(0.1))
    where = MAP.xyz.copy()
    where[0, :2] += 0.6 * (where[0, :2] / np.linalg.norm(where[0, :2]))
    rng = np.random.default_rng(6)
    suspected_at = None
    for k in range(100):
        if suspected_at is not None and k == suspected_at + 6:
            break  # twice the sightings that clear a suspect of rejections, its rays < 20° apart
        camera = np.array([0.1 * k, 0.0])
        seen = where if suspected_at is None else MAP.xyz  # later, right where the map has it
        offsets = seen[:, :2] - camera
        azimuths = np.arctan2(offsets[:, 1], offsets[:, 0]) + rng.normal(0.0, SIGMA, 4)
        inliers = np.array([beacon not in repair.suspects for beacon in MAP.ids.tolist()])
        repair.begin_frame(MAP)
        found, _ = repair.observe(0.1 * k, Measurements(MAP.ids, azimuths), inliers, MAP,
                                  np.array([*camera, 0.0, 0.0, 0.0]), COV, True)
        if found and suspected_at is None:
            suspected_at = k
    assert suspected_at is not None and repair.suspects == (int(MAP.ids[0]),)
    assert repair.repairs == []


# -- a fitted move on a route ------------------------------------------------------------------

def test_a_move_along_the_line_of_sight_that_the_gate_lets_pass_is_found_and_repaired():
    """warehouse-paper's beacon 14 moved 0.6 m, 27° off the line it is first seen along: its
    azimuths turn by at most 0.96°, they pass robust's gate, and no run of rejections forms."""
    scenario = azgym.load_scenario("warehouse-paper")
    row = scenario.beacons.ids.tolist().index(14)
    physical = scenario.beacon_positions.copy()
    physical[row] = (11.925296055869488, 23.59778408808722, 4.0)
    world = dataclasses.replace(scenario, physical_xyz=physical)
    frames = list(simulate(world, "A-B-C-D", seed=0))
    tracker = azgym.make_tracker("robust", repair=True)
    tracker.reset(seed=0, initial=frames[0].pose)
    for frame in frames:
        tracker.predict(frame.motion)
        tracker.update(frame.measurements, scenario.beacons)
    (repair,) = tracker.repairs
    assert repair.beacon == 14
    assert math.dist(tracker.placed[14].new, physical[row, :2]) < 0.05


def test_times_out_of_order_are_refused_by_name():
    times, cameras = path(5)
    with pytest.raises(InvalidInputError, match="ascending"):
        likelihood_ratio(times[::-1], cameras, bearings_with(cameras, np.zeros(5)),
                         np.zeros((3, 3)), np.full(5, SIGMA ** 2), BEACON)

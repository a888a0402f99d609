"""The mapping suite's scores on hand-built cases: errors, the unplaced charged, moves, delays."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.bench.mapping.scoring import (
    BeaconScore,
    CaseScore,
    MovedScore,
    beacon_scores,
    checkpoint_times,
    delays,
    first_seen_from_two_places,
    observable_by_truth,
    summarize,
    truly_moved,
)
from azgym.core import BeaconMap
from azgym.localize.bearings import MIN_RAYS, MIN_SPREAD
from azgym.mapping.base import map_answer


def beacons(rows: dict[int, tuple[float, float]]) -> BeaconMap:
    ids = sorted(rows)
    return BeaconMap(np.array(ids), np.array([[*rows[i], 3.0] for i in ids]))


def case(perturbation="moved", beacon_errors=(), moved=(), said=(), false=0,
         updated=(0.1,), true=(0.1,), failure=None, runtime=1.0) -> CaseScore:
    return CaseScore("s/r/" + perturbation, "s", "r", perturbation,
                     tuple(BeaconScore(k, e, math.isfinite(e))
                           for k, e in enumerate(beacon_errors)),
                     tuple(moved), tuple(said), false, tuple(updated), tuple(true), failure, 0,
                     runtime)


def test_a_placed_beacon_scores_its_distance_and_an_unplaced_one_infinity():
    truth = beacons({1: (0.0, 0.0), 2: (5.0, 0.0), 3: (0.0, 5.0)})
    answer = map_answer([1], [[0.03, 0.04]], [np.eye(2) * 1e-4])
    prior = beacons({2: (5.0, 0.1)})  # 3 is in neither the prior nor the answer
    scores = beacon_scores(answer.updated(prior), truth, [1, 2, 3], answer.ids.tolist())
    assert [(s.beacon, s.placed) for s in scores] == [(1, True), (2, False), (3, False)]
    assert scores[0].error == pytest.approx(0.05)
    assert scores[1].error == pytest.approx(0.1)  # the prior's position, as the user keeps it
    assert scores[2].error == math.inf


def test_observability_by_the_truth_needs_enough_rays_and_enough_spread():
    # beacon 7 at (0, 10) seen from x = -2, 0, 2 (heading 0): a spread of about 18 degrees
    poses = np.array([[-2.0, 0.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    azimuths = np.arctan2(10.0, 0.0 - poses[:, 0])
    frames = np.arange(3)
    assert observable_by_truth(frames, np.full(3, 7), azimuths, poses) == {7}
    # two rays only: too few, however wide
    assert MIN_RAYS == 3
    assert observable_by_truth(frames[:2], np.full(2, 7), azimuths[:2], poses) == frozenset()
    # three rays from nearly one place: too narrow
    close = poses * 0.1
    narrow = np.arctan2(10.0, -close[:, 0])
    assert math.degrees(MIN_SPREAD) == pytest.approx(10.0)
    assert observable_by_truth(frames, np.full(3, 7), narrow, close) == frozenset()
    # the camera's heading turns the ray: the same world bearings from a turned camera
    turned = poses.copy()
    turned[:, 2] = 0.5
    assert observable_by_truth(frames, np.full(3, 7), azimuths - 0.5, turned) == {7}


def test_first_seen_from_two_places_is_the_first_detection_half_a_metre_from_the_first():
    times = [1.0, 2.0, 3.0, 4.0]
    places = np.array([[0.0, 0.0], [0.3, 0.0], [0.0, 0.49], [0.3, 0.4]])
    assert first_seen_from_two_places(times, places) == 4.0
    assert first_seen_from_two_places(times[:3], places[:3]) is None
    assert first_seen_from_two_places([], np.zeros((0, 2))) is None


def test_checkpoints_every_two_seconds_for_thirty_shared_and_capped_at_the_end():
    assert checkpoint_times([10.0], 100.0) == tuple(10.0 + 2 * k for k in range(16))
    assert checkpoint_times([10.0, 11.0, None], 15.0) == (10.0, 11.0, 12.0, 13.0, 14.0, 15.0)
    assert checkpoint_times([None], 15.0) == ()


def test_delay_is_the_first_checkpoint_in_the_window_that_says_moved():
    answers = [(10.0, frozenset()), (12.0, frozenset({5})), (14.0, frozenset({5, 6})),
               (50.0, frozenset({7}))]
    found = delays({5: 10.0, 6: 11.0, 7: 10.0, 8: None}, answers)
    assert found == {5: 2.0, 6: 3.0, 7: None, 8: None}  # 7: said only past its 30 s window


def test_truly_moved_is_the_priors_non_anchor_beacons_the_world_has_elsewhere():
    prior = beacons({1: (0.0, 0.0), 2: (5.0, 0.0), 3: (0.0, 5.0)})
    truth = beacons({1: (0.5, 0.0), 2: (5.0, 0.0), 3: (0.0, 6.0), 4: (9.0, 9.0)})
    assert truly_moved(prior, (3,), truth) == {1}
    assert truly_moved(None, (), truth) == frozenset()


def test_summary_pools_the_cases():
    moved = [MovedScore(1, True, 5.0, 4.0), MovedScore(2, False, 7.0, None),
             MovedScore(3, False, None, None)]
    cases = [case("moved", (0.01, 0.02, math.inf), moved, said=(1, 9), false=1,
                  updated=(0.1, 0.2, math.inf, 0.3), true=(0.1, 0.1, 0.1, 0.1)),
             case("unchanged", (0.03,), (), said=(4,), false=1, failure="timed out",
                  runtime=None)]
    s = summarize("m", cases)
    assert (s.cases, s.beacons, s.failures) == (2, 4, 1)
    assert s.error_median_cm == pytest.approx(2.5)
    assert s.error_worst_cm == math.inf and s.error_p95_cm == math.inf
    assert s.placed_percent == 75.0
    assert s.moved_precision == pytest.approx(1 / 3) and s.moved_recall == pytest.approx(1 / 3)
    assert s.delay_median_s == 4.0 and s.delay_worst_s == math.inf  # beacon 2 seen, not caught
    assert s.detected_within_10s_percent == 50.0
    assert s.false_moves_unchanged == 1
    assert s.localization_p75_true_cm == pytest.approx(10.0)
    assert s.localization_p75_updated_cm == pytest.approx(30.0)  # 0.1 0.1 0.2 [0.3] inf
    assert s.runtime_median_s == 1.0


def test_summary_of_nothing_said_or_moved_is_nan_not_zero():
    s = summarize("m", [case("unchanged", (0.01,))])
    assert math.isnan(s.moved_precision) and math.isnan(s.moved_recall)
    assert math.isnan(s.delay_median_s) and math.isnan(s.detected_within_10s_percent)


def test_localization_pools_only_the_cases_ransac_can_score_on_the_true_map():
    # a narrow camera's case: ransac refuses half its frames even on the true map (p75 inf)
    narrow = case("moved", (0.01,), updated=(0.5, math.inf, math.inf, 0.4),
                  true=(0.02, math.inf, math.inf, 0.03))
    wide = case("moved", (0.01,), updated=(0.1, 0.2, 0.3, 0.4), true=(0.1, 0.1, 0.1, 0.1))
    s = summarize("m", [narrow, wide])
    assert s.localization_p75_true_cm == pytest.approx(10.0)
    assert s.localization_p75_updated_cm == pytest.approx(32.5)  # wide's frames alone
    assert s.localization_ratio == pytest.approx(3.25)
    alone = summarize("m", [narrow])
    assert math.isnan(alone.localization_p75_true_cm)
    assert math.isnan(alone.localization_ratio)  # nothing to compare, not a ratio of infinities

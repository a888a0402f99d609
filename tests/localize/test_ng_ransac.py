"""ng-ransac: the guided triplet order by hand, the hypothesis budget, the support test."""

from __future__ import annotations

import hashlib
import math
from itertools import combinations

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame

import azgym
from azgym import InvalidInputError, Measurements
from azgym.localize import _kernels as K
from azgym.localize.base import Problem
from azgym.localize.learned.ng_ransac import SHIPPED_WEIGHTS, NgRansac
from azgym.localize.learned.ng_search import guided_search, guided_settings, guided_triplets
from azgym.localize.learned.weights import load_weights
from azgym.localize.ransac import OUT_SIZE, score_candidate, score_triplets, settings_array


def log_sigmoid(z):
    return -np.log1p(np.exp(-np.asarray(z, dtype=float)))


def test_the_triplets_come_best_first_from_the_top_ranked():
    logits = np.array([2.0, -1.0, 0.5, 3.0, -4.0])
    beacon_index = np.arange(5)
    triplets = guided_triplets(logits, beacon_index, 4, 10)
    # The 4 best are measurements 3, 0, 2, 1: their C(4, 3) = 4 triplets, by joint log-probability.
    ranked = [3, 0, 2, 1]
    expected = sorted(combinations(ranked, 3), key=lambda t: -log_sigmoid(logits[list(t)]).sum())
    assert [tuple(t) for t in triplets.tolist()] == [tuple(sorted(t)) for t in expected]
    assert 4 not in triplets


def test_the_budget_caps_the_hypotheses_and_one_beacon_twice_is_never_tried():
    logits = np.linspace(3.0, -3.0, 12)
    beacon_index = np.array([0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10])  # a ghost beside beacon 0
    triplets = guided_triplets(logits, beacon_index, 8, 30)
    assert triplets.shape == (30, 3)
    assert not any({0, 1} <= set(t) for t in triplets.tolist())
    scores = log_sigmoid(logits[triplets]).sum(axis=1)
    assert (np.diff(scores) <= 0).all()


def test_fewer_ranked_than_three_distinct_beacons_gives_no_triplet():
    assert guided_triplets(np.zeros(3), np.array([4, 4, 5]), 8, 30).shape == (0, 3)


@pytest.fixture(scope="module")
def shipped():
    return NgRansac()


def test_a_clean_frame_is_solved_within_the_budget(shipped):
    beacons = beacon_map([(0, 0), (10, 0), (10, 10), (0, 10), (5, 12), (12, 5), (-2, 6),
                          (7, -3)])
    pose = (4.0, 3.0, 0.3)
    frame = ideal_frame(*pose, beacons)
    estimate = shipped.localize(Measurements(frame.ids, frame.azimuth, np.ones(8)), beacons)
    assert estimate.ok and math.dist(estimate.pose[:2], pose[:2]) < 1e-6
    # Every measurement agrees with the features' consensus pose: it settles the frame, scored
    # once more with the paper's tolerance, and the network is not consulted.
    assert estimate.diagnostics["n_hypotheses"] == math.comb(6, 3)
    assert estimate.diagnostics["guided"] is False
    assert "support_weight" not in estimate.diagnostics


def test_a_consensus_short_of_confident_hands_the_frame_to_the_network(shipped):
    beacons = beacon_map([(0, 0), (10, 0), (10, 10), (0, 10), (5, 12), (12, 5)])
    pose = (4.0, 3.0, 0.3)
    frame = ideal_frame(*pose, beacons)
    azimuth = frame.azimuth.copy()
    azimuth[[0, 1, 2]] += [0.4, -0.5, 0.3]  # half the frame off: 3 supporters, 4 needed
    estimate = shipped.localize(Measurements(frame.ids, azimuth, np.ones(6)), beacons)
    assert estimate.diagnostics["guided"] is True
    assert estimate.diagnostics["n_hypotheses"] > math.comb(6, 3)


def test_a_support_threshold_no_answer_can_reach_refuses_with_the_reason():
    beacons = beacon_map([(0, 0), (10, 0), (10, 10), (0, 10), (5, 12)])
    frame = ideal_frame(4.0, 3.0, 0.3, beacons)
    azimuth = frame.azimuth.copy()
    azimuth[[0, 1]] += [0.5, -0.4]  # 3 supporters of 4 needed: the network decides, and tests
    localizer = azgym.make_localizer("ng-ransac", min_support_weight=5.0)
    estimate = localizer.localize(Measurements(frame.ids, azimuth), beacons)
    assert not estimate.ok
    assert "under min_support_weight 5.00" in estimate.reason


@pytest.mark.parametrize(("params", "message"), [
    ({"max_hypotheses": 0}, r"NgRansac.max_hypotheses must be an integer >= 1"),
    ({"max_ranked": 2}, r"NgRansac.max_ranked must be an integer in \[3, 64\]"),
    ({"min_support_weight": -1.0}, r"NgRansac.min_support_weight must be >= 0"),
    ({"weights": 3}, r"NgRansac.weights must be a path"),
    ({"weights": "/nonexistent/model.npz"}, r"model.npz"),
])
def test_bad_hyperparameters_are_refused(params, message):
    with pytest.raises(InvalidInputError, match=message):
        NgRansac(**params)


def test_the_shipped_weights_are_calibrated_and_their_card_names_them():
    arrays, manifest = load_weights(SHIPPED_WEIGHTS, "ng-ransac")
    calibration = manifest["calibration"]
    assert NgRansac().support_threshold() == calibration["min_support_weight"] > 0.0
    card = (SHIPPED_WEIGHTS.parent / "model-card.md").read_text(encoding="utf-8")
    assert hashlib.sha256(SHIPPED_WEIGHTS.read_bytes()).hexdigest() in card
    assert SHIPPED_WEIGHTS.stat().st_size <= 2 * 1024 * 1024


def search_on(frame, beacons, logits):
    problem = Problem.from_frame(frame, beacons)
    out, mask, cov = np.empty(OUT_SIZE), np.zeros(len(frame), dtype=bool), np.empty((3, 3))
    tried = guided_search(problem.floats, problem.ints, np.asarray(logits, dtype=float),
                          problem.n_distinct, guided_settings(settings_array()), out, mask, cov)
    return tried, out, mask


def test_a_first_pass_without_a_confident_winner_tries_every_triplet_of_the_top_ranked():
    beacons = beacon_map([(10 * math.cos(a), 10 * math.sin(a))
                          for a in np.linspace(0, 2 * math.pi, 12, endpoint=False)])
    pose = (1.0, -2.0, 0.4)
    frame = ideal_frame(*pose, beacons)
    clean_tried, out, mask = search_on(frame, beacons, np.linspace(2, -2, 12))
    assert clean_tried == 10 and mask.all()  # the first pass's winner has all 12: confident
    # Five azimuths shuffled, and the network trusting exactly those most: the first pass's
    # triplets are all outliers, so it goes on with every triplet of the 12 most probable.
    azimuth = frame.azimuth.copy()
    azimuth[[0, 1, 2, 3, 4]] = azimuth[[3, 4, 0, 1, 2]]
    logits = np.r_[np.full(5, 3.0), np.full(7, -1.0)]
    tried, out, mask = search_on(Measurements(frame.ids, azimuth), beacons, logits)
    assert tried == 10 + 220
    assert mask.tolist() == [False] * 5 + [True] * 7
    assert math.hypot(out[K.POSE_X] - pose[0], out[K.POSE_Y] - pose[1]) < 1e-6


def test_the_second_pass_draws_from_at_least_the_first_pass_measurements():
    with pytest.raises(InvalidInputError, match="fallback_ranked must be 0 .* or at least "
                                                "max_ranked=8, got 6"):
        NgRansac(fallback_ranked=6)


def test_a_pose_found_elsewhere_is_scored_as_the_triplet_search_scores_its_own():
    # ng-ransac scores the features' consensus pose with ransac's tolerance instead of solving
    # its triplet again: the supporters and NS must be the triplet search's, for any positive
    # scale of the heading vector (the consensus keeps it unnormalised).
    beacons = beacon_map([(0, 0), (10, 0), (10, 10), (0, 10), (5, 12), (12, 5), (-2, 6)])
    frame = ideal_frame(4.0, 3.0, 0.3, beacons)
    azimuth = frame.azimuth + np.r_[0.0, 0.0, 0.0, 0.003, 0.2, -0.3, 0.002]
    problem = Problem.from_frame(Measurements(frame.ids, azimuth), beacons)
    settings = settings_array()
    pose, support = np.empty(K.POSE_SIZE), np.zeros(problem.size, dtype=bool)
    n_support, mean_sq, _ = score_triplets(problem.floats, problem.ints,
                                           np.array([[0, 1, 2]]), settings, pose, support)
    assert support.tolist() == [True] * 4 + [False, False, True] and n_support == 5
    elsewhere = pose.copy()
    elsewhere[[K.POSE_COS, K.POSE_SIN]] *= 3.7
    again = np.zeros(problem.size, dtype=bool)
    assert score_candidate(problem.floats, settings, elsewhere, again) == \
        pytest.approx((n_support, mean_sq), rel=1e-9)
    assert again.tolist() == support.tolist()
    assert elsewhere == pytest.approx(pose, rel=1e-12)  # the heading normalised again

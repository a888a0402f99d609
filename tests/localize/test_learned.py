"""learned: conformance, a clean frame solved (refined) or roughly placed (pure regression), the
covariance, determinism, bad hyperparameters and files refused, no torch when serving."""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame

import azgym
from azgym import InvalidInputError, Measurements
from azgym.localize.checks import check_localizer
from azgym.localize.learned.ng_ransac import SHIPPED_WEIGHTS as NG_RANSAC_WEIGHTS
from azgym.localize.learned.pose_regression import SHIPPED_WEIGHTS, Learned

BEACONS = beacon_map([(0, 0), (10, 0), (10, 10), (0, 10), (5, 12), (12, 5), (-2, 6), (7, -3)])
POSE = (4.0, 3.0, 0.3)


def test_it_passes_the_conformance_checks():
    check_localizer(azgym.make_localizer("learned"), verbose=False)


def test_a_clean_frame_is_solved_by_the_refinement_and_placed_by_the_regression():
    frame = ideal_frame(*POSE, BEACONS)
    frame = Measurements(frame.ids, frame.azimuth, np.ones(8))
    refined = Learned().localize(frame, BEACONS)
    assert refined.ok and math.dist(refined.pose[:2], POSE[:2]) < 1e-6
    assert refined.diagnostics["refinement_rounds"] == 3 and refined.n_inliers == 8
    regressed = Learned(refine_rounds=0).localize(frame, BEACONS)
    assert regressed.ok and regressed.diagnostics["refinement_rounds"] == 0
    error = math.dist(regressed.pose[:2], POSE[:2])
    assert error < 2.0  # a 12 m site: metres, not centimetres, without the refinement
    assert (regressed.diagnostics["regressed_x"], regressed.diagnostics["regressed_y"]) == \
        regressed.pose[:2]
    cov = regressed.covariance
    assert np.all(np.linalg.eigvalsh(cov) > 0.0)
    assert math.isclose(math.sqrt(cov[0, 0] + cov[1, 1]),
                        regressed.diagnostics["regressed_std_m"])
    assert abs(math.remainder(regressed.pose[2] - POSE[2], math.tau)) < 0.3


def test_the_same_frame_gets_the_same_answer_and_the_problem_path_agrees():
    frame = ideal_frame(*POSE, BEACONS)
    noisy = Measurements(frame.ids, frame.azimuth + np.random.default_rng(0).normal(
        scale=0.01, size=8))
    localizer = Learned()
    first, second = localizer.localize(noisy, BEACONS), localizer.localize(noisy, BEACONS)
    assert first.pose == second.pose
    np.testing.assert_array_equal(first.covariance, second.covariance)
    from azgym.localize.base import Problem

    via_problem = localizer._localize(Problem.from_frame(noisy, BEACONS))
    assert via_problem.pose == first.pose  # no quality either way: the same features


@pytest.mark.parametrize(("params", "message"), [
    ({"refine_rounds": -1}, r"Learned.refine_rounds must be an integer in \[0, 10\]"),
    ({"gate": 0.0}, r"Learned.gate must be in \(0"),
    ({"min_trust": math.nan}, r"Learned.min_trust"),
    ({"weights": 3}, r"Learned.weights must be a path"),
    ({"weights": "/nonexistent/model.npz"}, r"/nonexistent/model.npz: no such model file"),
    ({"weights": str(NG_RANSAC_WEIGHTS)}, r"holds a 'ng-ransac' model, not 'learned'"),
])
def test_bad_hyperparameters_and_files_are_refused(params, message):
    with pytest.raises(InvalidInputError, match=message):
        Learned(**params)


def test_the_shipped_weights_are_small_and_their_card_names_them():
    card = (SHIPPED_WEIGHTS.parent / "learned-model-card.md").read_text(encoding="utf-8")
    assert hashlib.sha256(SHIPPED_WEIGHTS.read_bytes()).hexdigest() in card
    assert SHIPPED_WEIGHTS.stat().st_size <= 2 * 1024 * 1024
    assert "![learning curve](learned-learning-curve.png)" in card
    assert (SHIPPED_WEIGHTS.parent / "learned-learning-curve.png").is_file()


def _refined_set(trust: list[float], error_deg: float = 0.0) -> tuple[np.ndarray, int]:
    """The measurements the refinement rounds end with, from a start 5 cm off, for given trust
    logits (the last measurement ``error_deg`` off its true azimuth)."""
    from azgym.localize import _kernels as K
    from azgym.localize.base import gather
    from azgym.localize.learned.pose_regression import (
        OUT_ITERATIONS,
        OUT_SIZE,
        _refine_rounds,
        settings_array,
    )

    room = beacon_map([(0.0, 0.0), (6.0, 0.0), (6.0, 6.0), (0.0, 6.0), (3.0, 7.0)])
    frame = ideal_frame(2.0, 2.5, 0.4, room)
    azimuth = frame.azimuth.copy()
    azimuth[-1] += math.radians(error_deg)
    floats, ints, _ = gather(frame.ids, azimuth, *room.lookup_tables())
    out, cov = np.zeros(OUT_SIZE), np.zeros((3, 3))
    out[K.POSE_X], out[K.POSE_Y] = 2.05, 2.5
    out[K.POSE_COS], out[K.POSE_SIN] = math.cos(0.4), math.sin(0.4)
    out[OUT_ITERATIONS] = 0.0
    use = np.ones(len(trust), dtype=np.bool_)
    rounds = _refine_rounds(floats, ints, np.array(trust), settings_array(), out, cov, use)
    return use, rounds


def test_a_good_measurement_the_network_doubted_comes_back_after_the_first_round():
    # A real camera's biased beacon (Roh's data): the network doubts it, the residuals do not.
    use, rounds = _refined_set([3.0, 3.0, 3.0, 3.0, -10.0])
    assert rounds == 3 and use.all()


def test_a_doubted_measurement_far_off_stays_out_by_its_residual():
    use, rounds = _refined_set([3.0, 3.0, 3.0, 3.0, -10.0], error_deg=20.0)
    assert rounds == 3 and use.tolist() == [True, True, True, True, False]

"""Drift figures: evo's relative pose error per distance travelled, by hand and against evo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from evo.core import filters
from evo.core import metrics as evo_metrics
from evo.core.trajectory import PoseTrajectory3D
from evo.main_rpe import rpe

from azgym.bench.report.tracking import drift_metrics
from azgym.bench.run.outcome import RunOutcome
from azgym.bench.suites.base import Case
from azgym.metrics import (
    DRIFT_DISTANCES,
    path_pairs,
    relative_pose_errors,
    summarize_drift,
)
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples

STEP = 0.125
"""A straight line's step [m]: exact in binary, so that 1, 5 and 10 m are whole steps."""


def straight(count: int, heading: float = 0.0) -> np.ndarray:
    """Poses along the x-axis, STEP apart, all with the same heading."""
    return np.column_stack([STEP * np.arange(count), np.zeros(count), np.full(count, heading)])


def test_a_scale_error_of_2_percent_is_a_drift_of_2_percent_of_each_pair_s_path():
    truth = straight(200)
    estimate = truth * [1.02, 1.0, 1.0]
    for distance in DRIFT_DISTANCES:
        drift = summarize_drift(*relative_pose_errors(truth, estimate, distance), distance)
        # Each start pairs with the frame D further on; near the line's end, with its last
        # frame while that is within 10 % of D (none at 1 m, whose 0.1 m is under a step).
        steps = round(distance / STEP)
        short = [distance - STEP * k for k in range(1, math.floor(0.1 * steps) + 1)]
        lengths = [distance] * (200 - steps) + short
        assert drift["pairs"] == len(lengths)
        assert drift["translation_pct"] == pytest.approx(2.0 * np.mean(lengths) / distance,
                                                         abs=1e-9)
        assert drift["heading_deg_per_m"] == pytest.approx(0.0, abs=1e-12)
    assert summarize_drift(*relative_pose_errors(truth, estimate, 1.0), 1.0)[
        "translation_pct"] == pytest.approx(2.0, abs=1e-9)


def test_a_constant_heading_bias_turns_every_step_by_it_and_drifts_no_heading():
    # The estimated step is the true one seen 1° off: 2 sin(0.5°) of its length, 1.745 %.
    truth = straight(200, heading=0.3)
    estimate = truth + [0.0, 0.0, math.radians(1.0)]
    drift = summarize_drift(*relative_pose_errors(truth, estimate, 1.0), 1.0)
    assert drift["translation_pct"] == pytest.approx(200 * math.sin(math.radians(0.5)),
                                                     abs=1e-9)
    assert drift["heading_deg_per_m"] == pytest.approx(0.0, abs=1e-9)


def test_a_heading_that_drifts_by_a_rate_per_metre_is_that_many_degrees_per_metre():
    truth = straight(200)
    estimate = truth.copy()
    estimate[:, 2] = np.radians(0.2) * truth[:, 0]  # 0.2° per metre travelled
    drift = summarize_drift(*relative_pose_errors(truth, estimate, 1.0), 1.0)
    assert drift["heading_deg_per_m"] == pytest.approx(0.2, abs=1e-9)


def test_a_pair_is_the_nearest_to_the_distance_within_the_tolerance_and_a_stop_its_first_frame():
    # Path lengths 0, 0.5, 1.0 (twice: the vehicle stood), 1.2, 2.5 m. From 0 m the nearest to
    # 1 m further on is the first 1.0 (index 2). Within 10 % of 1 m nothing else: from 0.5 m
    # the nearest is 1.2 (0.7 m on), from 1.2 m it is 2.5 (1.3 m on); within 35 % both count.
    xy = np.column_stack([[0.0, 0.5, 1.0, 1.0, 1.2, 2.5], np.zeros(6)])
    assert path_pairs(xy, 1.0).tolist() == [[0, 2]]
    assert path_pairs(xy, 1.0, tolerance=0.35).tolist() == [[0, 2], [1, 4], [4, 5]]
    poses = trajectory(np.column_stack([xy, np.zeros(6)])).poses_se3
    for tolerance in (0.1, 0.35):
        assert [tuple(pair) for pair in path_pairs(xy, 1.0, tolerance).tolist()] == \
            filters.filter_pairs_by_path(poses, 1.0, tolerance, all_pairs=True)
    assert path_pairs(xy[:1], 1.0).shape == (0, 2)


def test_without_pairs_or_without_a_true_heading_a_drift_figure_is_nan():
    truth = straight(5)  # 0.5 m of path: no pair 1 m apart
    assert summarize_drift(*relative_pose_errors(truth, truth, 1.0), 1.0)["pairs"] == 0
    assert math.isnan(summarize_drift(*relative_pose_errors(truth, truth, 1.0), 1.0)[
        "translation_pct"])
    truth = straight(50)
    truth[:, 2] = math.nan  # position-only truth: evo's translation part needs its orientation
    drift = summarize_drift(*relative_pose_errors(truth, straight(50), 1.0), 1.0)
    assert drift["pairs"] > 0
    assert math.isnan(drift["translation_pct"]) and math.isnan(drift["heading_deg_per_m"])


def wander(count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A winding drive with a stop, and a noisy, slowly turning estimate of it."""
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0.0, 0.05, count))
    step = rng.uniform(0.0, 0.3, count)
    step[40:55] = 0.0  # the vehicle stands
    xy = np.cumsum(np.column_stack([step * np.cos(heading), step * np.sin(heading)]), axis=0)
    truth = np.column_stack([xy, heading])
    estimate = truth + rng.normal(0.0, [0.04, 0.04, 0.02], (count, 3))
    estimate[:, 2] += 0.001 * np.arange(count)
    return truth, estimate


def trajectory(poses: np.ndarray) -> PoseTrajectory3D:
    """Poses as evo holds a TUM file's: z = 0, the heading as a yaw quaternion (w first)."""
    count = len(poses)
    quaternions = np.column_stack([np.cos(poses[:, 2] / 2), np.zeros(count), np.zeros(count),
                                   np.sin(poses[:, 2] / 2)])
    return PoseTrajectory3D(np.column_stack([poses[:, :2], np.zeros(count)]), quaternions,
                            0.1 * np.arange(count))


def evo_errors(truth: np.ndarray, estimate: np.ndarray, distance: float,
               relation: evo_metrics.PoseRelation) -> np.ndarray:
    """evo_rpe --delta D --delta_unit m --all_pairs --pairs_from_reference (no alignment)."""
    result = rpe(trajectory(truth), trajectory(estimate), relation, delta=distance,
                 delta_unit=evo_metrics.Unit.meters, all_pairs=True, pairs_from_reference=True)
    return result.np_arrays["error_array"]


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("distance", DRIFT_DISTANCES)
def test_the_relative_pose_errors_are_evo_s_pair_by_pair(seed, distance):
    truth, estimate = wander(400, seed)
    pairs = filters.filter_pairs_by_path(trajectory(truth).poses_se3, distance, 0.1 * distance,
                                         all_pairs=True)
    assert [tuple(pair) for pair in path_pairs(truth[:, :2], distance).tolist()] == pairs
    moved, turned = relative_pose_errors(truth, estimate, distance)
    translation = evo_errors(truth, estimate, distance,
                             evo_metrics.PoseRelation.translation_part)
    degrees = evo_errors(truth, estimate, distance, evo_metrics.PoseRelation.rotation_angle_deg)
    assert np.abs(moved - translation).max() < 1e-9
    drift = summarize_drift(moved, turned, distance)
    assert drift["translation_pct"] == pytest.approx(100 * translation.mean() / distance,
                                                     abs=1e-9)
    assert drift["heading_deg_per_m"] == pytest.approx(degrees.mean() / distance, abs=1e-9)


def still(time: float) -> Motion:
    """A driven frame's motion without samples."""
    empty = np.zeros(0)
    return Motion(time, OdometrySamples(empty, empty, empty),
                  ImuSamples(empty, empty, np.zeros((0, 2)), empty))


def test_a_contender_s_drift_pools_its_sequences_and_leaves_its_refused_frames_out():
    # Two routes; frames 10-29 of the first refused. evo, given the estimate file without
    # them, pairs the truth's remaining frames: so does azgym.
    (truth_a, estimate_a), (truth_b, estimate_b) = wander(150, 3), wander(120, 4)
    cases = [Case("s", None, tuple(pose), "clean", name, sequence=name, time=0.1 * k,
                  motion=still(0.1 * k))
             for name, truth in (("a", truth_a), ("b", truth_b)) for k, pose in enumerate(truth)]
    outcome = RunOutcome.empty(len(cases))
    outcome.estimate[:] = np.concatenate([estimate_a, estimate_b])
    outcome.ok[:] = True
    outcome.ok[10:30] = False
    kept = np.ones(150, dtype=bool)
    kept[10:30] = False
    for drift in drift_metrics(cases, outcome):
        distance = drift["distance_m"]
        translation = np.concatenate([
            evo_errors(truth_a[kept], estimate_a[kept], distance,
                       evo_metrics.PoseRelation.translation_part),
            evo_errors(truth_b, estimate_b, distance, evo_metrics.PoseRelation.translation_part)])
        assert drift["pairs"] == translation.size
        assert drift["translation_pct"] == pytest.approx(100 * translation.mean() / distance,
                                                         abs=1e-9)


def test_frames_without_a_driven_sequence_have_no_drift():
    cases = [Case("s", None, (0.0, 0.0, 0.0), "clean", "g", sequence="g", time=0.1 * k)
             for k in range(3)]
    assert drift_metrics(cases, RunOutcome.empty(3)) is None

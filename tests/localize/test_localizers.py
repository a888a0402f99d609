"""Every localizer: conformance, noise-free recovery, invariances, outliers and bad input."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame, pose_error_of
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import azgym
from azgym import BeaconMap, InvalidInputError, Measurements, wrap_angle
from azgym.localize.loo import LeaveOneOut
from azgym.localize.lsq import LeastSquares
from azgym.localize.ransac import Ransac, n_trials
from azgym.localize.triplet import Triplet
from azgym.sensing.synthetic import ideal_azimuths, inject_outliers, noisy_measurements

ALL_LOCALIZERS = azgym.list_localizers()
BUILTINS = ["triplet", "ransac", "mex", "lsq", "loo"]

# Poses at least this far from every beacon [m].
MIN_DISTANCE = 0.3


def far_from_beacons(x: float, y: float, beacons: BeaconMap) -> bool:
    return float(np.hypot(beacons.xy[:, 0] - x, beacons.xy[:, 1] - y).min()) >= MIN_DISTANCE


def random_pose(rng: np.random.Generator, beacons: BeaconMap, half_width: float = 10.7):
    while True:
        x, y = rng.uniform(-half_width, half_width, 2)
        if far_from_beacons(x, y, beacons):
            return float(x), float(y), float(rng.uniform(-math.pi, math.pi))


# --------------------------------------------------------------------------- conformance


@pytest.mark.parametrize("name", ALL_LOCALIZERS)
def test_check_localizer_passes(name):
    azgym.check_localizer(azgym.make_localizer(name))


def test_check_localizer_catches_a_broken_localizer():
    class Shifted(LeastSquares):
        def _localize(self, problem):
            estimate = super()._localize(problem)
            return azgym.Estimate(estimate.x + 0.5, estimate.y, estimate.heading,
                                  estimate.inliers)

    with pytest.raises(azgym.LocalizerCheckError, match=re.escape("noise-free recovery")):
        azgym.check_localizer(Shifted())


# --------------------------------------------------------------------------- noise-free


@pytest.mark.parametrize(
    "localizer",
    [Ransac(), Ransac(weighted=True), Triplet(), LeastSquares(), LeastSquares(weighted=True),
     LeaveOneOut()],
    ids=["ransac", "ransac-weighted", "triplet", "lsq", "lsq-weighted", "loo"],
)
def test_noise_free_paper_room_poses_are_recovered(localizer, paper_beacons):
    rng = np.random.default_rng(2021)
    for _ in range(60):
        x, y, heading = random_pose(rng, paper_beacons)
        estimate = localizer.localize(ideal_frame(x, y, heading, paper_beacons), paper_beacons)
        assert estimate.ok, estimate.reason
        position_error, heading_error = pose_error_of(estimate, x, y, heading)
        assert position_error < 1e-6, (x, y, heading)
        assert heading_error < 1e-8, (x, y, heading)
        assert -math.pi < estimate.heading <= math.pi


@settings(max_examples=60, deadline=None)
@given(st.floats(-10.7, 10.7), st.floats(-10.7, 10.7), st.floats(-math.pi, math.pi))
def test_noise_free_recovery_ransac_and_triplet(paper_beacons, x, y, heading):
    assume(far_from_beacons(x, y, paper_beacons))
    frame = ideal_frame(x, y, heading, paper_beacons)
    for localizer in (Ransac(), Triplet()):
        estimate = localizer.localize(frame, paper_beacons)
        position_error, heading_error = pose_error_of(estimate, x, y, heading)
        assert position_error < 1e-6 and heading_error < 1e-8


# --------------------------------------------------------------------------- invariances


def rotate(beacons: BeaconMap, angle: float, shift: tuple[float, float]) -> BeaconMap:
    c, s = math.cos(angle), math.sin(angle)
    xy = beacons.xy @ np.array([[c, s], [-s, c]]) + np.asarray(shift)
    return BeaconMap(beacons.ids, np.c_[xy, beacons.xyz[:, 2]], beacons.width)


def noisy_frame(paper_room, x, y, heading, n_outliers, seed):
    rng = np.random.default_rng(seed)
    frame = noisy_measurements(x, y, heading, paper_room.beacons, paper_room.error_model, rng)
    azimuth, _ = inject_outliers(frame.azimuth, n_outliers, rng)
    return Measurements(frame.ids, azimuth)


def robust_and_plain_frames(paper_room, pose, n_outliers, seed):
    """ransac on a noisy frame with outliers; lsq on the same frame without them.

    lsq is not given outliers: they pull its descent into long valleys (or onto a beacon) where it
    stops at max_iter, and an unconverged answer is not expected to be equivariant.
    """
    return [(Ransac(), noisy_frame(paper_room, *pose, n_outliers, seed)),
            (LeastSquares(), noisy_frame(paper_room, *pose, 0, seed))]


@settings(max_examples=25, deadline=None)
@given(
    pose=st.tuples(st.floats(-8, 8), st.floats(-8, 8), st.floats(-math.pi, math.pi)),
    angle=st.floats(-math.pi, math.pi),
    shift=st.tuples(st.floats(-50, 50), st.floats(-50, 50)),
    n_outliers=st.integers(0, 3),
    seed=st.integers(0, 2**32 - 1),
)
def test_rotating_and_translating_the_scene_moves_the_estimate_with_it(
    paper_room, pose, angle, shift, n_outliers, seed
):
    # Azimuths are measured in the camera frame, so moving the whole scene (beacons and camera)
    # rigidly leaves the measurements unchanged; the estimate must move with the scene.
    moved = rotate(paper_room.beacons, angle, shift)
    c, s = math.cos(angle), math.sin(angle)
    for localizer, frame in robust_and_plain_frames(paper_room, pose, n_outliers, seed):
        before = localizer.localize(frame, paper_room.beacons)
        after = localizer.localize(frame, moved)
        assert before.ok and after.ok
        expected_x = c * before.x - s * before.y + shift[0]
        expected_y = s * before.x + c * before.y + shift[1]
        assert math.hypot(after.x - expected_x, after.y - expected_y) < 1e-6
        assert abs(wrap_angle(after.heading - before.heading - angle)) < 1e-8
        np.testing.assert_array_equal(after.inliers, before.inliers)


@settings(max_examples=25, deadline=None)
@given(
    pose=st.tuples(st.floats(-8, 8), st.floats(-8, 8), st.floats(-math.pi, math.pi)),
    n_outliers=st.integers(0, 3),
    seed=st.integers(0, 2**32 - 1),
)
def test_permuting_the_measurements_permutes_only_the_inliers(paper_room, pose, n_outliers, seed):
    order = np.random.default_rng(seed).permutation(len(paper_room.beacons))
    for localizer, frame in robust_and_plain_frames(paper_room, pose, n_outliers, seed):
        shuffled = Measurements(frame.ids[order], frame.azimuth[order])
        before = localizer.localize(frame, paper_room.beacons)
        after = localizer.localize(shuffled, paper_room.beacons)
        assert before.ok and after.ok
        # The same minimum, up to where Levenberg-Marquardt stops (~1e-9 m here).
        assert math.hypot(after.x - before.x, after.y - before.y) < 1e-7
        assert abs(wrap_angle(after.heading - before.heading)) < 1e-8
        np.testing.assert_array_equal(after.inliers, before.inliers[order])


# --------------------------------------------------------------------------- outliers


@pytest.mark.parametrize("n_outliers", [1, 2, 3, 4, 5])
def test_ransac_removes_exactly_the_outliers(paper_room, n_outliers):
    # With noise-free inliers and every outlier outside its tolerance at the true pose (eq. 25-26),
    # the true pose has N − K supporters and zero error; ransac must find it and reject exactly the
    # outliers. Poses are kept 2.5 m from the walls: in the corners a wrong pose can gather more
    # supporters than the true one (a property of consensus, not of this implementation).
    beacons, model = paper_room.beacons, paper_room.error_model
    localizer = Ransac()
    checked = 0
    for seed in range(30):
        rng = np.random.default_rng([n_outliers, seed])
        x, y, heading = random_pose(rng, beacons, half_width=8.5)
        truth, distance = ideal_azimuths(x, y, heading, beacons)
        corrupted, is_outlier = inject_outliers(truth, n_outliers, rng)
        tolerance = model.tolerance(distance, beacons.width)
        error = np.abs(wrap_angle(corrupted - truth))
        if not (error[is_outlier] > tolerance[is_outlier] * (1 + 1e-6)).all():
            continue
        checked += 1
        estimate = localizer.localize(Measurements(beacons.ids, corrupted), beacons)
        assert estimate.ok, estimate.reason
        position_error, heading_error = pose_error_of(estimate, x, y, heading)
        assert position_error < 1e-6, (seed, x, y, heading)
        assert heading_error < 1e-8
        np.testing.assert_array_equal(estimate.inliers, ~is_outlier)
    assert checked >= 20  # the condition holds for most draws: the test is not vacuous


def test_ransac_with_noise_and_outliers_stays_close(paper_room):
    # Noise bounded by Δα_d + Δα_c (0.4° + ~0.1°) and three deranged measurements: the error
    # stays at the centimetre level, as in the paper's Fig. 5.
    rng = np.random.default_rng(5)
    errors = []
    for seed in range(40):
        x, y, heading = random_pose(rng, paper_room.beacons, half_width=8.5)
        frame = noisy_frame(paper_room, x, y, heading, 3, seed)
        errors.append(pose_error_of(Ransac().localize(frame, paper_room.beacons), x, y, heading)[0])
    assert np.mean(errors) < 0.1
    assert np.max(errors) < 0.5


def test_lsq_is_not_robust_but_loo_and_ransac_are(paper_beacons):
    x, y, heading = 1.0, 2.0, 0.3
    frame = ideal_frame(x, y, heading, paper_beacons)
    azimuth = frame.azimuth.copy()
    azimuth[4] = wrap_angle(azimuth[4] + math.pi / 2)  # one gross (90°) outlier
    corrupted = Measurements(frame.ids, azimuth)

    lsq = LeastSquares().localize(corrupted, paper_beacons)
    assert lsq.ok and lsq.inliers.all()
    assert pose_error_of(lsq, x, y, heading)[0] > 0.1

    loo = LeaveOneOut().localize(corrupted, paper_beacons)
    assert loo.diagnostics["removed"] == [4]
    assert pose_error_of(loo, x, y, heading)[0] < 1e-6
    assert loo.inliers.tolist() == [k != 4 for k in range(12)]

    ransac = Ransac().localize(corrupted, paper_beacons)
    assert pose_error_of(ransac, x, y, heading)[0] < 1e-6
    assert not ransac.inliers[4] and ransac.n_inliers == 11


def test_loo_keeps_everything_when_nothing_is_wrong(paper_room):
    frame = noisy_frame(paper_room, -2.0, 3.0, 1.0, 0, seed=3)
    estimate = LeaveOneOut().localize(frame, paper_room.beacons)
    assert estimate.diagnostics["removed"] == []
    assert estimate.inliers.all()


def test_ghost_of_a_beacon_is_not_an_inlier(paper_beacons, make_frame):
    x, y, heading = -3.0, 4.0, 2.0
    frame = make_frame(x, y, heading, paper_beacons)
    # A mirror ghost: a second detection of beacon 3, 30° off.
    ids = np.append(frame.ids, 3)
    azimuth = np.append(frame.azimuth, wrap_angle(frame.azimuth[2] + math.radians(30)))
    estimate = Ransac().localize(Measurements(ids, azimuth), paper_beacons)
    assert estimate.ok
    assert pose_error_of(estimate, x, y, heading)[0] < 1e-6
    assert estimate.inliers.tolist() == [True] * 12 + [False]


@pytest.mark.parametrize("name", BUILTINS)
def test_a_ghost_does_not_break_any_localizer(name, paper_beacons, make_frame):
    frame = make_frame(1.0, 1.0, 0.0, paper_beacons)
    ids = np.append(frame.ids, frame.ids[0])
    azimuth = np.append(frame.azimuth, wrap_angle(frame.azimuth[0] + 0.5))
    localizer = azgym.make_localizer(name, bounds=(-1, -1, 3, 3)) if name == "mex" else \
        azgym.make_localizer(name)
    estimate = localizer.localize(Measurements(ids, azimuth), paper_beacons)
    assert estimate.ok
    assert estimate.inliers.shape == (13,)
    if name in ("ransac", "loo"):  # the robust ones are not even moved by it
        assert pose_error_of(estimate, 1.0, 1.0, 0.0)[0] < 1e-6
        assert not estimate.inliers[-1]


@pytest.mark.parametrize("name", BUILTINS)
def test_unknown_ids_are_never_inliers(name, paper_beacons):
    x, y, heading = 2.0, -1.0, -0.7
    frame = ideal_frame(x, y, heading, paper_beacons)
    ids = np.concatenate([[99], frame.ids, [-5]])
    azimuth = np.concatenate([[0.5], frame.azimuth, [-2.0]])
    localizer = azgym.make_localizer(name, bounds=(-3, -4, 5, 2)) if name == "mex" else \
        azgym.make_localizer(name)
    estimate = localizer.localize(Measurements(ids, azimuth), paper_beacons)
    assert estimate.ok
    assert estimate.inliers.shape == (14,)
    assert not estimate.inliers[0] and not estimate.inliers[-1]
    tolerance = 0.01 if name == "mex" else 1e-6  # mex answers on its 1 cm grid
    assert pose_error_of(estimate, x, y, heading)[0] < tolerance


# --------------------------------------------------------------------------- bad input


def too_few_frames(beacons: BeaconMap):
    frame = ideal_frame(0.5, 0.5, 0.0, beacons)
    return {
        "none": Measurements([], []),
        "two": Measurements(frame.ids[:2], frame.azimuth[:2]),
        "two-distinct-and-a-ghost": Measurements([1, 2, 2], frame.azimuth[:3]),
        "unknown-ids": Measurements([1, 2, 77, 78], frame.azimuth[:4]),
    }


@pytest.mark.parametrize("case", ["none", "two", "two-distinct-and-a-ghost", "unknown-ids"])
@pytest.mark.parametrize("name", BUILTINS)
def test_fewer_than_three_usable_measurements_fail_without_raising(name, case, paper_beacons):
    frame = too_few_frames(paper_beacons)[case]
    estimate = azgym.make_localizer(name).localize(frame, paper_beacons)
    assert not estimate.ok
    assert "fewer than 3 distinct beacons" in estimate.reason
    assert math.isnan(estimate.x) and math.isnan(estimate.y) and math.isnan(estimate.heading)
    assert estimate.inliers.shape == (len(frame),) and not estimate.inliers.any()
    if case == "unknown-ids":
        assert "2 had ids not in the map" in estimate.reason


COLLINEAR = beacon_map([(1.0, 0.0), (2.0, 0.0), (4.0, 0.0), (7.0, 0.0)])


@pytest.mark.parametrize(
    "name",
    BUILTINS,
)
def test_camera_on_the_line_of_all_beacons_fails(name):
    # Every beacon is seen at 0° or 180° from the line: the position along it is undetermined.
    frame = ideal_frame(-2.5, 0.0, 0.3, COLLINEAR)
    estimate = azgym.make_localizer(name).localize(frame, COLLINEAR)
    assert not estimate.ok
    assert estimate.reason
    assert math.isnan(estimate.x)


@pytest.mark.parametrize("name", ["triplet", "ransac", "lsq", "loo"])
def test_collinear_beacons_seen_from_off_the_line_are_solved(name):
    # Collinear beacons alone are no degeneracy: the circles through pairs meet at the camera.
    x, y, heading = 2.5, 3.0, 0.3
    estimate = azgym.make_localizer(name).localize(ideal_frame(x, y, heading, COLLINEAR),
                                                   COLLINEAR)
    assert estimate.ok
    assert pose_error_of(estimate, x, y, heading)[0] < 1e-6


@pytest.mark.parametrize("name", BUILTINS)
def test_wrong_argument_types_raise(name, paper_beacons):
    localizer = azgym.make_localizer(name)
    frame = ideal_frame(0.0, 0.0, 0.0, paper_beacons)
    with pytest.raises(InvalidInputError,
                       match=re.escape("measurements must be an azgym.Measurements")):
        localizer.localize((frame.ids, frame.azimuth), paper_beacons)
    with pytest.raises(InvalidInputError, match=re.escape("beacons must be an azgym.BeaconMap")):
        localizer.localize(frame, paper_beacons.xyz)
    with pytest.raises(InvalidInputError):
        localizer.localize(paper_beacons, frame)  # swapped


# --------------------------------------------------------------------------- eq. 4-6 sampling


def test_n_trials_hand_computation():
    # N_B = 12, N_GOOD = 9, P* = 0.9: eq. 4 gives C(9,3)/C(12,3) · 0.9 = 84/220 · 0.9 = 0.343636...
    # eq. 6: ln(0.001) / ln(1 − 0.343636) = −6.907755 / −0.421024 = 16.41, so 17 trials.
    assert n_trials(12, 9, 0.999, 0.9) == 17
    # N_B = 40, N_GOOD = 20: 1140/9880 · 0.9 = 0.103846; −6.907755 / −0.109643 = 63.002 → 64.
    assert n_trials(40, 20, 0.999, 0.9) == 64
    # Every triplet reliable with certainty: one trial.
    assert n_trials(10, 10, 0.999, 1.0) == 1
    # Pr_hit = 0.99, half of 6 beacons good: p = C(3,3)/C(6,3) = 1/20;
    # ln(0.01) / ln(0.95) = 89.78 → 90.
    assert n_trials(6, 3, 0.99, 1.0) == 90


@pytest.mark.parametrize(("n", "good", "pr_hit", "p_star"),
                         [(12, 9, 0.999, 0.9), (40, 20, 0.999, 0.9), (50, 47, 0.99, 0.8),
                          (8, 4, 0.9, 0.5), (100, 30, 0.9999, 0.95)])
def test_n_trials_is_the_smallest_count_reaching_pr_hit(n, good, pr_hit, p_star):
    p = math.comb(good, 3) / math.comb(n, 3) * p_star  # eq. 4
    count = n_trials(n, good, pr_hit, p_star)
    assert 1 - (1 - p) ** count >= pr_hit * (1 - 1e-12)  # eq. 5 reached...
    assert 1 - (1 - p) ** (count - 1) < pr_hit  # ...and not with one trial less


def wall_beacons(per_wall: int, half: float = 11.0) -> BeaconMap:
    offsets = np.linspace(-half, half, per_wall + 2)[1:-1]
    xy = np.concatenate([
        np.c_[np.full(per_wall, half), offsets], np.c_[-offsets, np.full(per_wall, half)],
        np.c_[np.full(per_wall, -half), -offsets], np.c_[offsets, np.full(per_wall, -half)],
    ])
    return beacon_map(xy, first_id=100)


def test_ransac_samples_triplets_by_eq6_when_there_are_many_beacons():
    beacons = wall_beacons(10)
    assert len(beacons) == 40 and math.comb(40, 3) > Ransac().max_exhaustive
    x, y, heading = 1.5, -2.5, 2.0
    truth, _ = ideal_azimuths(x, y, heading, beacons)
    corrupted, is_outlier = inject_outliers(truth, 5, np.random.default_rng(0))
    frame = Measurements(beacons.ids, corrupted)
    estimate = Ransac(random_state=1).localize(frame, beacons)
    # N_GOOD = ceil(0.5 · 40) = 20 → 64 sampled triplets instead of C(40, 3) = 9880.
    assert estimate.diagnostics["n_triplets"] == 64 < math.comb(40, 3)
    assert pose_error_of(estimate, x, y, heading)[0] < 1e-6
    np.testing.assert_array_equal(estimate.inliers, ~is_outlier)

    again = Ransac(random_state=1).localize(frame, beacons)
    assert (again.x, again.y, again.heading) == (estimate.x, estimate.y, estimate.heading)
    np.testing.assert_array_equal(Ransac(random_state=1).triplets(40),
                                  Ransac(random_state=1).triplets(40))
    assert not np.array_equal(Ransac(random_state=1).triplets(40),
                              Ransac(random_state=2).triplets(40))


def test_sampled_triplets_are_valid_and_exhaustive_below_the_limit():
    triplets = Ransac(random_state=0).triplets(40)
    assert triplets.shape == (64, 3)
    assert ((triplets >= 0) & (triplets < 40)).all()
    assert all(len(set(row)) == 3 for row in triplets.tolist())
    assert Ransac().triplets(12).shape == (220, 3)
    assert len({tuple(sorted(row)) for row in Ransac().triplets(12).tolist()}) == 220
    # Sampling that would need more trials than there are triplets uses them all.
    assert Ransac(max_exhaustive=10, pr_hit=0.999999).triplets(8).shape == (56, 3)


def test_the_shared_triplets_cannot_be_changed_through_what_ransac_hands_out():
    handed_out = Ransac().triplets(12)
    with pytest.raises(ValueError, match="read-only"):
        handed_out[0, 0] = 5
    assert Ransac().triplets(12)[0].tolist() == [0, 1, 2]


@pytest.mark.parametrize("seed", range(6))
def test_ransac_fast_path_answers_exactly_as_the_general_path(paper_room, seed):
    # localize() looks ids up inside the compiled kernel; _localize(Problem) is the general path.
    from azgym.localize.base import Problem

    rng = np.random.default_rng(seed)
    beacons = paper_room.beacons
    frame = noisy_measurements(*rng.uniform(-9, 9, 2), rng.uniform(-3, 3), beacons,
                               paper_room.error_model, rng)
    ids, azimuth = frame.ids.copy(), frame.azimuth.copy()
    if seed % 2:  # a mirror ghost of one beacon and a misdecoded id
        ids = np.append(ids, [ids[3], 777])
        azimuth = np.append(azimuth, [azimuth[3] + 0.4, 0.1])
    frame = Measurements(ids, azimuth)
    ransac = azgym.make_localizer("ransac")
    fast = ransac.localize(frame, beacons)
    general = ransac._localize(Problem.from_frame(frame, beacons))
    assert (fast.x, fast.y, fast.heading) == (general.x, general.y, general.heading)
    assert np.array_equal(fast.inliers, general.inliers)
    assert fast.diagnostics == general.diagnostics

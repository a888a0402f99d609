"""Repaired beacons kept in the tracker's state (EKF-SLAM), by hand and against the joint update.

A kept beacon is seen where the state has it; its azimuth's Jacobian row has −(y_i − y)/r²,
(x_i − x)/r² in the beacon's columns, so one update corrects pose and beacon together. The
prediction leaves it in place; a restart of the pose keeps it; the state keeps at most
MAX_KEPT of them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import beacon_map

import azgym
from azgym import Measurements
from azgym.localize.base import ROW_BEACON_INDEX, Problem
from azgym.track.azimuth_update import gated_update
from azgym.track.repair_records import Repair
from azgym.track.repair_state import MAX_KEPT, StateBeacons, placed_map
from azgym.track.unicycle import STATE_SIZE, MotionNoise, Step, predict

DELTA_D = 0.003


def slam_update(state, cov, beacons, ids, azimuths, columns):
    """The textbook joint EKF update with beacons in the state, with numpy (the reference)."""
    rows = beacons.index_of(ids)
    xy = beacons.xy[rows].copy()
    for k, column in enumerate(columns):
        if column >= 0:
            xy[k] = state[column:column + 2]
    dx, dy = xy[:, 0] - state[0], xy[:, 1] - state[1]
    r2 = dx**2 + dy**2
    nu = np.angle(np.exp(1j * (np.asarray(azimuths) - np.arctan2(dy, dx) + state[2])))
    H = np.zeros((len(ids), state.size))
    H[:, 0], H[:, 1], H[:, 2] = dy / r2, -dx / r2, -1.0
    for k, column in enumerate(columns):
        if column >= 0:
            H[k, column], H[k, column + 1] = -dy[k] / r2[k], dx[k] / r2[k]
    R = np.diag((DELTA_D**2 + np.arctan2(0.5 * beacons.width[rows], np.sqrt(r2)) ** 2) / 3)
    gain = cov @ H.T @ np.linalg.inv(H @ cov @ H.T + R)
    return state + gain @ nu, cov - gain @ H @ cov


def test_a_kept_beacons_azimuth_by_hand():
    # camera at the origin facing +x, beacon 1 kept in the state at (1, 0) (columns 5, 6), its
    # map position (9, 9) unused: α̂ = 0, H = [0, −1, −1, 0, 0, 0, 1] (dy = 0, dx = 1, r² = 1)
    beacons = beacon_map([(9.0, 9.0)], width=0.0)
    state = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0])
    cov = np.diag([1e-2, 1e-2, 1e-4, 1e-6, 1e-4, 4e-2, 4e-2])
    problem = Problem.from_frame(Measurements([1], [0.01]), beacons)
    passed, d2 = gated_update(state, cov, problem.floats, problem.ints[ROW_BEACON_INDEX],
                              DELTA_D, True, 0.0, 10.83, np.array([5]))
    s = 1e-2 + 1e-4 + 4e-2 + DELTA_D**2 / 3
    assert passed.tolist() == [True] and d2[0] == pytest.approx(0.01**2 / s)
    assert state[1] == pytest.approx(-1e-2 / s * 0.01)  # the pose moves as before ...
    assert state[2] == pytest.approx(-1e-4 / s * 0.01)
    assert state[6] == pytest.approx(4e-2 / s * 0.01)  # ... and the beacon across the ray
    assert state[5] == 1.0  # along the ray the azimuth says nothing of it
    assert cov[1, 6] == pytest.approx(1e-2 * 4e-2 / s) and cov[6, 1] == cov[1, 6]
    assert cov[6, 6] == pytest.approx(4e-2 - 4e-2**2 / s)


@pytest.mark.parametrize("seed", range(10))
def test_the_scalar_updates_with_kept_beacons_are_the_joint_slam_update(seed):
    rng = np.random.default_rng(seed)
    beacons = beacon_map([tuple(p) for p in rng.uniform(-15, 15, (6, 2))], width=0.1)
    kept = {2: STATE_SIZE, 5: STATE_SIZE + 2}  # beacons 2 and 5 in the state, the rest mapped
    size = STATE_SIZE + 4
    truth = np.r_[rng.uniform(-2, 2, 2), rng.uniform(-math.pi, math.pi)]
    root = rng.normal(size=(size, size)) * [0.05, 0.05, 0.01, 1e-4, 0.01, 0.03, 0.03, 0.03, 0.03]
    cov = root @ root.T + np.diag([1e-4, 1e-4, 1e-6, 1e-8, 1e-6, 1e-4, 1e-4, 1e-4, 1e-4])
    state = np.zeros(size)
    state[:3] = truth + rng.multivariate_normal(np.zeros(3), cov[:3, :3])
    for beacon, column in kept.items():
        state[column:column + 2] = beacons.xy[beacon - 1] + rng.normal(0.0, 0.02, 2)
    ids = list(range(1, 7))
    azimuths = [math.remainder(math.atan2(y - truth[1], x - truth[0]) - truth[2]
                               + rng.normal(0, 0.002), math.tau) for x, y in beacons.xy]
    columns = np.array([kept.get(beacon, -1) for beacon in ids], dtype=np.int64)
    expected_state, expected_cov = slam_update(state, cov, beacons, ids, azimuths, columns)
    problem = Problem.from_frame(Measurements(ids, azimuths), beacons)
    passed, _ = gated_update(state, cov, problem.floats, problem.ints[ROW_BEACON_INDEX],
                             DELTA_D, True, 0.0, math.inf, columns)
    assert passed.all()
    expected_state[2] = math.remainder(expected_state[2], math.tau)
    np.testing.assert_allclose(state, expected_state, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(cov, expected_cov, rtol=1e-7, atol=1e-15)
    np.testing.assert_array_equal(cov, cov.T)


def test_the_prediction_leaves_kept_beacons_in_place_and_carries_their_ties_to_the_pose():
    rng = np.random.default_rng(0)
    root = rng.normal(size=(7, 7)) * 0.1
    cov = root @ root.T
    state = np.array([1.0, 2.0, 0.3, 0.001, 0.01, 5.0, -4.0])
    small_state, small_cov = state[:STATE_SIZE].copy(), cov[:STATE_SIZE, :STATE_SIZE].copy()
    step = Step(speed=1.0, yaw_rate=0.2, observed=0.1, seconds=0.1, unseen=0.0,
                speed_spread=0.01, turn_spread=0.01)
    before = cov.copy()
    predict(state, cov, step, 0.5, MotionNoise())
    predict(small_state, small_cov, step, 0.5, MotionNoise())
    np.testing.assert_array_equal(state[5:], [5.0, -4.0])
    np.testing.assert_array_equal(cov[5:, 5:], before[5:, 5:])
    np.testing.assert_array_equal(state[:STATE_SIZE], small_state)  # the pose as without
    np.testing.assert_allclose(cov[:STATE_SIZE, :STATE_SIZE], small_cov, rtol=1e-12)
    # the pose's ties to the beacon move with it: J · cov[pose, beacon]
    moved = small_state.copy()
    jacobian = np.empty((STATE_SIZE, STATE_SIZE))
    for a in range(STATE_SIZE):  # the step's Jacobian, column by column, numerically
        nudged, ignored = np.array([1.0, 2.0, 0.3, 0.001, 0.01]), np.zeros((5, 5))
        nudged[a] += 1e-6
        predict(nudged, ignored, step, 0.5, MotionNoise())
        jacobian[:, a] = (nudged - moved) / 1e-6
    np.testing.assert_allclose(cov[:STATE_SIZE, 5:], jacobian @ before[:STATE_SIZE, 5:],
                               atol=1e-6)


def repair(beacon, new, std=0.05):
    return Repair(time=1.0, frame=10, beacon=beacon, old=(0.0, 0.0), new=new,
                  covariance=np.eye(2) * std**2, rays=12)


def test_the_state_keeps_at_most_max_kept_beacons_each_in_its_two_columns():
    kept = StateBeacons()
    assert all(kept.reserve(beacon) for beacon in range(MAX_KEPT))
    assert not kept.reserve(99) and 99 not in kept  # no room: refined from its rays instead
    assert kept.reserve(3)  # one kept, placed afresh: its entries are set anew
    placed = {beacon: repair(beacon, (float(beacon), 1.0)) for beacon in range(MAX_KEPT)}
    state, cov = kept.sync(np.arange(5.0), np.eye(5), placed)
    assert state.size == STATE_SIZE + 2 * MAX_KEPT
    np.testing.assert_array_equal(state[:5], np.arange(5.0))
    for beacon in range(MAX_KEPT):
        column = kept.columns[beacon]
        np.testing.assert_array_equal(state[column:column + 2], [beacon, 1.0])
        np.testing.assert_array_equal(cov[column:column + 2, column:column + 2],
                                      np.eye(2) * 0.05**2)
        assert not cov[:column, column:column + 2].any()  # no tie to the pose yet
    np.testing.assert_array_equal(
        kept.columns_of(np.array([3, 42, 0])), [kept.columns[3], -1, kept.columns[0]])


def test_placements_are_read_back_from_the_state_and_a_snapshot_gets_them_appended():
    kept = StateBeacons()
    before = kept.stamp()  # the lag's snapshot, from before the repair
    kept.reserve(7)
    placed = {7: repair(7, (2.0, 3.0)), 8: repair(8, (4.0, 4.0))}
    state, cov = kept.sync(np.zeros(5), np.eye(5), placed)
    snapshot = state[:5].copy(), cov[:5, :5].copy(), placed, before
    state[5:7] = (2.1, 2.9)  # the filter moved it
    cov[5:7, 5:7] = np.eye(2) * 1e-4
    state, cov = kept.sync(state, cov, placed)
    assert placed[7].new == (2.1, 2.9) and placed[7].std == pytest.approx(0.01)
    assert placed[7].time == 1.0 and placed[7].old == (0.0, 0.0)  # the repair's, as reported
    assert placed[8].new == (4.0, 4.0)  # not kept: left alone
    restored, restored_cov = kept.restored(*snapshot)
    np.testing.assert_array_equal(restored[5:7], (2.1, 2.9))
    np.testing.assert_array_equal(restored_cov[5:7, 5:7], np.eye(2) * 1e-4)
    assert kept.restored(state, cov, placed, kept.stamp())[0] is state  # already has it


def test_the_map_widens_only_the_repaired_beacons_the_state_does_not_keep():
    beacons = beacon_map([(0.0, 0.0), (5.0, 5.0), (9.0, 1.0)], width=0.1)
    kept = StateBeacons()
    kept.reserve(1)
    placed = {1: repair(1, (0.5, 0.5)), 2: repair(2, (5.5, 5.0), std=0.04)}
    current = placed_map(beacons, placed, kept)
    np.testing.assert_array_equal(current.xy, [(0.5, 0.5), (5.5, 5.0), (9.0, 1.0)])
    np.testing.assert_allclose(current.width, [0.1, math.sqrt(0.1**2 + 12 * 0.04**2), 0.1])


def test_a_restart_of_the_pose_keeps_the_kept_beacons():
    tracker = azgym.make_tracker("gated-ekf")
    tracker.reset(seed=0, initial=(0.0, 0.0, 0.0))
    state = np.r_[tracker._state, 3.0, 4.0]
    cov = np.eye(7) * 0.01
    tracker._state, tracker._cov = state, cov
    tracker._start(np.array([1.0, 1.0, 0.5]), np.eye(3) * 1e-4)
    np.testing.assert_array_equal(tracker._state[5:], (3.0, 4.0))
    np.testing.assert_array_equal(tracker._cov[5:, 5:], np.eye(2) * 0.01)
    assert not tracker._cov[:5, 5:].any() and not tracker._cov[5:, :5].any()


def test_a_kept_beacon_placed_afresh_does_not_take_another_ones_room():
    kept = StateBeacons()
    assert all(kept.reserve(beacon) for beacon in range(MAX_KEPT - 1))
    kept.sync(np.zeros(5), np.eye(5), {b: repair(b, (float(b), 0.0)) for b in range(MAX_KEPT)})
    assert kept.reserve(0) and len(kept) == MAX_KEPT - 1  # kept, about to be set anew: once
    assert kept.reserve(MAX_KEPT - 1)  # the last room is still free
    assert not kept.reserve(99)

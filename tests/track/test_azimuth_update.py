"""The compiled gated azimuth update: by hand, one detection per beacon, the joint update."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import beacon_map

from azgym import Measurements
from azgym.localize.base import ROW_BEACON_INDEX, Problem
from azgym.track.azimuth_update import gated_update

CHI2_999 = 10.83


def update(state, cov, ids, azimuths, beacons, delta_d=0.003, extra=0.0, threshold=CHI2_999):
    problem = Problem.from_frame(Measurements(ids, azimuths), beacons)
    return gated_update(state, cov, problem.floats, problem.ints[ROW_BEACON_INDEX], delta_d,
                        True, extra, threshold)


def test_an_update_by_hand():
    beacons = beacon_map([(1.0, 0.0)], width=0.0)
    state, cov = np.zeros(5), np.diag([1e-2, 1e-2, 1e-4, 1e-6, 1e-4])
    passed, d2 = update(state, cov, [1], [0.01], beacons)
    # α̂ = atan2(0, 1) − 0 = 0, H = [dy/r², −dx/r², −1, 0, 0] = [0, −1, −1, 0, 0], R = Δ²/3.
    s = 1e-2 + 1e-4 + 0.003**2 / 3
    assert passed.tolist() == [True] and d2[0] == pytest.approx(0.01**2 / s)
    assert state[1] == pytest.approx(-1e-2 / s * 0.01)
    assert state[2] == pytest.approx(-1e-4 / s * 0.01)
    assert cov[1, 1] == pytest.approx(1e-2 - 1e-4 / s)
    assert cov[1, 2] == pytest.approx(-1e-2 * 1e-4 / s) and cov[2, 1] == cov[1, 2]


def test_of_two_detections_of_one_beacon_only_the_nearer_passes():
    beacons = beacon_map([(10.0, 0.0), (0.0, 10.0), (-10.0, 0.0)], width=0.0)
    state, cov = np.zeros(5), np.diag([1e-4, 1e-4, 1e-6, 1e-8, 1e-6])
    # Beacon 1 twice (a ghost 0.005 rad off, first, then the true one), beacon 2 true, beacon 3
    # far off the gate.
    passed, d2 = update(state, cov, [1, 1, 2, 3], [0.005, 0.0005, math.pi / 2, math.pi - 0.3],
                        beacons)
    assert passed.tolist() == [False, True, True, False]
    assert d2[0] < CHI2_999 and d2[3] > CHI2_999  # the ghost passed the gate, but the true won
    tie_state, tie_cov = np.zeros(5), np.diag([1e-4, 1e-4, 1e-6, 1e-8, 1e-6])
    tie, _ = update(tie_state, tie_cov, [1, 1], [0.001, 0.001], beacons)
    assert tie.tolist() == [True, False]  # a tie: the earlier detection


def test_nothing_passes_and_nothing_moves():
    beacons = beacon_map([(10.0, 0.0), (0.0, 10.0)], width=0.0)
    state, cov = np.array([0.0, 0.0, 0.0, 1e-3, 0.01]), np.diag([1e-4, 1e-4, 1e-6, 1e-8, 1e-6])
    before = state.copy(), cov.copy()
    passed, _ = update(state, cov, [1, 2], [1.0, -1.0], beacons)
    assert not passed.any()
    np.testing.assert_array_equal(state, before[0])
    np.testing.assert_array_equal(cov, before[1])


def joint_update(state, cov, beacons, ids, azimuths, delta_d):
    """The textbook joint EKF update on every azimuth, with numpy (the reference)."""
    rows = beacons.index_of(ids)
    xy = beacons.xy[rows]
    dx, dy = xy[:, 0] - state[0], xy[:, 1] - state[1]
    r2 = dx**2 + dy**2
    nu = np.angle(np.exp(1j * (np.asarray(azimuths) - np.arctan2(dy, dx) + state[2])))
    H = np.zeros((len(ids), 5))
    H[:, 0], H[:, 1], H[:, 2] = dy / r2, -dx / r2, -1.0
    R = np.diag((delta_d**2 + np.arctan2(0.5 * beacons.width[rows], np.sqrt(r2)) ** 2) / 3)
    gain = cov @ H.T @ np.linalg.inv(H @ cov @ H.T + R)
    return state + gain @ nu, cov - gain @ H @ cov


@pytest.mark.parametrize("seed", range(20))
def test_the_scalar_updates_in_turn_are_the_joint_update(seed):
    rng = np.random.default_rng(seed)
    beacons = beacon_map([tuple(p) for p in rng.uniform(-15, 15, (6, 2))], width=0.1)
    truth = np.r_[rng.uniform(-2, 2, 2), rng.uniform(-math.pi, math.pi)]
    root = rng.normal(size=(5, 5)) * [0.05, 0.05, 0.01, 1e-4, 0.01]
    cov = root @ root.T + np.diag([1e-4, 1e-4, 1e-6, 1e-8, 1e-6])
    state = np.r_[truth + rng.multivariate_normal(np.zeros(3), cov[:3, :3]), 0.0, 0.0]
    ids = list(range(1, 7))
    azimuths = [math.remainder(math.atan2(y - truth[1], x - truth[0]) - truth[2]
                               + rng.normal(0, 0.002), math.tau)
                for x, y in beacons.xy]
    expected_state, expected_cov = joint_update(state, cov, beacons, ids, azimuths, 0.003)
    passed, _ = update(state, cov, ids, azimuths, beacons, threshold=math.inf)
    assert passed.all()
    expected_state[2] = math.remainder(expected_state[2], math.tau)
    np.testing.assert_allclose(state, expected_state, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(cov, expected_cov, rtol=1e-7, atol=1e-15)
    np.testing.assert_array_equal(cov, cov.T)

"""The trackers' leave-one-out test: a moved beacon that passes a wide gate is withheld."""

from __future__ import annotations

import itertools
import math
from statistics import NormalDist

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame

import azgym
from azgym import Measurements
from azgym.bench.suites.base import keep_every, route_cases
from azgym.core import pose_error
from azgym.localize.base import ROW_BEACON_INDEX, Problem
from azgym.sensing.image.sensor import ImageSensor
from azgym.track.azimuth_update import gated_update
from azgym.world.drive import simulate

BEACONS = beacon_map([(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (5.0, 12.0)])
POSE = (4.0, 3.0, 0.3)
GATE = NormalDist().inv_cdf(0.5 + 0.5 * 0.999) ** 2
"""The default gate (gate_probability 0.999, one degree of freedom)."""
NOISE = (math.radians(0.4), True, math.radians(0.1))
"""The default delta_alpha_d, coverage and extra_sigma."""
# (map row of the moved beacon, how far it moved [m], the map rows measured): each moved
# beacon pulled the old filter, started at the true pose, 40-44 cm off in one frame.
MOVES = [(2, (1.0, 0.0), [0, 2, 4]), (3, (0.0, 1.5), [0, 2, 3, 4])]


def moved_frame(row: int, shift: tuple[float, float], measured: list[int]) -> Measurements:
    """What the camera at POSE measures of ``measured`` once beacon ``row`` moved by ``shift``."""
    xy = np.array(BEACONS.xy, dtype=float)
    xy[row] += shift
    seen = ideal_frame(*POSE, beacon_map(xy))
    return Measurements(seen.ids[measured], seen.azimuth[measured])


def judged(state, cov, frame):
    """Which azimuths pass the gate and the leave-one-out test, and each one's distance ν²/S.

    ``state`` and ``cov`` are left as they were.
    """
    problem = Problem.from_frame(frame, BEACONS)
    return gated_update(np.array(state, dtype=float), np.array(cov, dtype=float),
                        problem.floats, problem.ints[ROW_BEACON_INDEX], *NOISE, GATE)


@pytest.mark.parametrize("name", ["gated-ekf", "robust"])
@pytest.mark.parametrize(("row", "shift", "measured"), MOVES)
def test_a_moved_beacon_that_passes_a_wide_gate_is_withheld(name, row, shift, measured):
    frame = moved_frame(row, shift, measured)
    tracker = azgym.make_tracker(name)
    tracker.reset(initial=POSE)  # a start pose is never exact: its covariance is a few cm wide
    # On its own, the moved beacon's azimuth is within the gate of the wide start.
    _, d2 = judged(np.r_[POSE, 0.0, 0.0], np.diag([0.005, 0.005, 6e-4, 0.0, 0.0]), frame)
    assert d2[measured.index(row)] < GATE
    estimate = tracker.update(frame, BEACONS)
    assert estimate.ok and pose_error(estimate.pose, POSE)[0] < 1e-3
    assert estimate.inliers.tolist() == [k != row for k in measured]
    # Once tight, the track keeps it out by the gate alone.
    again = tracker.update(frame, BEACONS)
    assert again.inliers.tolist() == [k != row for k in measured]


def test_azimuths_that_agree_pass_however_far_from_a_wide_prediction():
    frame = ideal_frame(*POSE, BEACONS)
    state = np.r_[POSE[0] + 0.15, POSE[1] - 0.1, POSE[2] + 0.02, 0.0, 0.0]  # 18 cm, 1° off
    cov = np.diag([0.04, 0.04, 1e-3, 1e-6, 1e-4])
    passed, d2 = judged(state, cov, frame)
    # The innovations and their noise by hand (eq. 1-3): the shortcut Σ ν²/R does not decide.
    offset = BEACONS.xy - state[:2]
    nu = np.angle(np.exp(1j * (frame.azimuth - np.arctan2(offset[:, 1], offset[:, 0])
                               + state[2])))
    coverage = np.arctan2(0.5 * BEACONS.width, np.hypot(*offset.T))
    noise = (NOISE[0] ** 2 + coverage**2) / 3 + NOISE[2] ** 2
    assert (d2 < GATE).all() and (nu * nu / noise).sum() > GATE
    assert passed.all()


def test_each_azimuth_is_tested_against_the_prediction_corrected_by_the_others():
    # The withheld azimuth is the one whose residual, given all the others, is worst; a second
    # detection of its beacon (which lost the gate to it) is then judged in its place.
    frame = moved_frame(3, (0.0, 1.5), [0, 2, 3, 4])
    twin = Measurements(np.r_[frame.ids, frame.ids[2]],
                        np.r_[frame.azimuth, ideal_frame(*POSE, BEACONS).azimuth[3] + 0.082])
    state, cov = np.r_[POSE, 0.0, 0.0], np.diag([0.005, 0.005, 6e-4, 1e-6, 1e-4])
    passed, d2 = judged(state, cov, twin)
    assert d2[2] < d2[4] < GATE  # the moved one nearer the prediction: it wins the gate
    assert passed.tolist() == [True, True, False, True, False]


@pytest.mark.parametrize("name", ["gated-ekf", "robust"])
def test_the_image_route_start_with_a_moved_beacon_stays_within_centimetres(name):
    # The image path's blinking ids leave the first frames dark: the start's covariance grows,
    # and the first lit frame has three beacons and a moved one, which pulled the old filter
    # 49-57 cm off for five seconds.
    scenario = azgym.load_scenario("warehouse-small")
    frames = simulate(scenario, "aisle-loop", [17, 0], sensor=ImageSensor(scenario, ids="blink"))
    cases = keep_every(route_cases(scenario.name, "aisle-loop",
                                   itertools.islice(frames, 240)), 3)
    tracker = azgym.make_tracker(name)
    tracker.reset(initial=cases[0].initial)
    errors = []
    for case in cases:
        if case.motion is not None:
            tracker.predict(case.motion)
        estimate = tracker.update(case.measurements, scenario.beacons)
        assert estimate.ok
        errors.append(pose_error(estimate.pose, case.pose)[0])
    assert "moved" in {case.cause for case in cases[:10]}
    assert max(errors) < 0.1

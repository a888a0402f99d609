"""A corpus of hostile frames, each pinned to what every built-in localizer does with it.

Each case is a frame (or the attempt to build one) that a careless localizer would crash on
inside numpy or numba, or answer confidently and wrongly. The outcome of each is one of:

- a named azgym error (InvalidInputError) with its message, raised before any work;
- ``ok=False`` with the reason pinned (per localizer, since each explains in its own terms);
- the true pose (``TRUTH``), where the frame is odd but determines it.
"""

from __future__ import annotations

import math
import re
import time

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame, pose_error_of

import azgym
from azgym import BeaconMap, InvalidInputError, Measurements
from azgym.localize.base import MAX_MEASUREMENTS

BUILTINS = ["ransac", "loo", "lsq", "triplet", "mex", "ng-ransac", "learned"]
PARAMS = {"mex": {"coarse_step": 0.1}}  # as the benchmark runs it
ROOM = beacon_map([(3.0, -1.5), (3.0, 1.5), (1.2, 3.0), (-1.6, 3.0), (-3.0, 1.0), (-3.0, -2.0),
                   (-1.0, -3.0), (2.0, -3.0)], first_id=10)
POSE = (0.4, -0.7, 0.3)
FRAME = ideal_frame(*POSE, ROOM)
TRUTH = "truth"
FEWER = "fewer than 3 distinct beacons"
DEGENERATE = {
    "ransac": "no non-degenerate triplet with at least 3 supporters",
    "loo": "no subset of the measurements determines the pose",
    "lsq": "do not determine the pose",
    "triplet": "every triplet is degenerate or ill-conditioned",
    "mex": "",  # pinned per case: mex's refusals name where its search ended
}
ON_BEACON = "the refinement ended on a beacon it used"
OUTSIDE = "the camera is outside the searched area"
NOT_DETERMINED = "the measured beacons do not determine the pose"
"""mex's refusal once its second stage, the map's extent, holds a camera outside the seen box."""


def localizer(name: str) -> azgym.Localizer:
    return azgym.make_localizer(name, **PARAMS.get(name, {}))


# --------------------------------------------------------------------------- frames refused early

BAD_FRAMES = [
    (lambda: Measurements([10, 11, 12], [0.1, math.nan, 0.3]),
     "Measurements.azimuth must be finite, got nan at index 1"),
    (lambda: Measurements([10, 11, 12], [0.1, math.inf, 0.3]),
     "Measurements.azimuth must be finite, got inf at index 1"),
    (lambda: Measurements([10, 11, 12], [0.1, 7.0, 0.3]),
     "Measurements.azimuth must be radians in [-π, π], got 7.0 at index 1"),
    (lambda: Measurements([10, 11.5, 12], [0.1, 0.2, 0.3]),
     "Measurements.ids must hold integers, got 11.5"),
    (lambda: Measurements([10, 11, 12], [0.1, 0.2]),
     "Measurements.azimuth must have shape (3,), got (2,)"),
    (lambda: Measurements([[10, 11]], [[0.1, 0.2]]), "Measurements.ids must be 1-D"),
]


@pytest.mark.parametrize(("build", "message"), BAD_FRAMES, ids=[m for _, m in BAD_FRAMES])
def test_malformed_frames_cannot_be_built(build, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        build()


@pytest.mark.parametrize("name", BUILTINS)
def test_a_frame_of_sixty_thousand_detections_is_refused_before_any_work(name):
    # ransac used to allocate its M × M × 4 pair table (115 GB) and die of MemoryError.
    rng = np.random.default_rng(0)
    frame = Measurements(rng.choice(ROOM.ids, 60_000), rng.uniform(-3.0, 3.0, 60_000))
    start = time.perf_counter()
    with pytest.raises(InvalidInputError,
                       match=re.escape("measurements has 60000 detections, more than the 1024")):
        localizer(name).localize(frame, ROOM)
    assert time.perf_counter() - start < 1.0


@pytest.mark.parametrize("name", ["ransac", "lsq"])
def test_a_frame_at_the_cap_is_solved(name):
    # MAX_MEASUREMENTS detections of a 1024-beacon ring: within the cap, in bounded memory.
    angles = np.linspace(-math.pi, math.pi, MAX_MEASUREMENTS, endpoint=False)
    ring = beacon_map(np.c_[20 * np.cos(angles), 20 * np.sin(angles)])
    estimate = localizer(name).localize(ideal_frame(*POSE, ring), ring)
    assert estimate.ok, estimate.reason
    assert pose_error_of(estimate, *POSE)[0] < 1e-6


# --------------------------------------------------------------------------- frames answered

def _huge_scene() -> tuple[Measurements, BeaconMap]:
    beacons = beacon_map([(0.0, 0.0), (4e200, 0.0), (4e200, 4e200), (0.0, 4e200)])
    return ideal_frame(1e200, 2e200, 0.1, beacons), beacons


def _collinear_through_camera() -> tuple[Measurements, BeaconMap]:
    beacons = beacon_map([(1.0, 0.0), (2.0, 0.0), (4.0, 0.0)])
    return ideal_frame(-1.0, 0.0, 0.2, beacons), beacons


def _danger_circle() -> tuple[Measurements, BeaconMap]:
    beacons = beacon_map([(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0)])  # the unit circle
    return ideal_frame(0.0, -1.0, 0.2, beacons), beacons


def _beacons_at_one_point() -> tuple[Measurements, BeaconMap]:
    beacons = BeaconMap([1, 2, 3, 4], np.tile([1.0, 2.0, 2.5], (4, 1)))
    return Measurements([1, 2, 3, 4], [0.1, 0.5, 1.0, 2.0]), beacons


ids, azimuth = FRAME.ids, FRAME.azimuth
CASES = {
    # name: (frame, beacons) builder, {localizer: TRUTH | reason substring}
    "empty": (lambda: (Measurements([], []), ROOM), dict.fromkeys(BUILTINS, FEWER)),
    "one-beacon": (lambda: (Measurements(ids[:1], azimuth[:1]), ROOM),
                   dict.fromkeys(BUILTINS, FEWER)),
    "ids-not-in-the-map": (lambda: (Measurements(ids + 1000, azimuth), ROOM),
                           dict.fromkeys(BUILTINS, "8 had ids not in the map")),
    "empty-map": (lambda: (FRAME, BeaconMap(np.zeros(0, int), np.zeros((0, 3)))),
                  dict.fromkeys(BUILTINS, FEWER)),
    "every-measurement-twice": (lambda: (Measurements(np.r_[ids, ids], np.r_[azimuth, azimuth]),
                                         ROOM), dict.fromkeys(BUILTINS, TRUTH)),
    "a-ghost-of-every-beacon": (
        lambda: (Measurements(np.r_[ids, ids], np.r_[azimuth, azimuth + 0.5]), ROOM),
        # triplet ignores all but its best-conditioned triplet, ghosts included: no claim.
        {"ransac": TRUTH, "loo": TRUTH}),
    "all-azimuths-equal": (lambda: (Measurements(ids, np.full(ids.size, 0.3)), ROOM),
                           {**DEGENERATE, "mex": OUTSIDE}),
    "beacons-collinear-with-the-camera": (
        _collinear_through_camera,
        {**DEGENERATE, "mex": NOT_DETERMINED}),
    "camera-on-the-danger-circle": (_danger_circle, {**DEGENERATE, "mex": NOT_DETERMINED}),
    "beacons-at-one-point": (_beacons_at_one_point,
                             {**DEGENERATE, "mex": "no grid point has a finite cost"}),
    "camera-on-a-beacon": (lambda: (ideal_frame(3.0, 1.5, 0.3, ROOM), ROOM),
                           {"ransac": TRUTH, "lsq": TRUTH, "loo": TRUTH,
                            "triplet": TRUTH, "mex": TRUTH}),
    "camera-under-two-stacked-beacons": (
        lambda: _stacked(), {"ransac": ON_BEACON, "lsq": ON_BEACON, "loo": ON_BEACON,
                             "triplet": TRUTH, "mex": TRUTH}),
    "camera-a-nanometre-from-a-beacon": (
        lambda: (ideal_frame(3.0 - 1e-9, 1.5, 0.3, ROOM), ROOM),
        {"ransac": TRUTH, "lsq": TRUTH, "loo": TRUTH, "triplet": TRUTH,
         "mex": TRUTH}),
    "camera-a-thousand-km-away": (
        lambda: (ideal_frame(1e6, 1e6, 0.1, ROOM), ROOM),
        {**DEGENERATE, "lsq": "do not determine the pose", "mex": OUTSIDE}),
    "coordinates-near-1e200": (_huge_scene, {**DEGENERATE, "triplet": TRUTH}),
}
def _stacked():
    """Two beacons at one spot (at two heights), the camera right under them."""
    stacked = BeaconMap(np.r_[ROOM.ids, 99], np.r_[ROOM.xyz, [[3.0, 1.5, 3.5]]], width=0.03)
    return ideal_frame(3.0, 1.5, 0.3, stacked), stacked


OUTCOMES = [(case, name) for case, (_, expected) in CASES.items() for name in expected]


@pytest.mark.parametrize(("case", "name"), OUTCOMES)
def test_hostile_frame_outcome(case, name):
    build, expected = CASES[case]
    frame, beacons = build()
    if case == "coordinates-near-1e200" and name == "mex":
        with pytest.raises(InvalidInputError, match="below the floating-point resolution"):
            localizer(name).localize(frame, beacons)
        return
    estimate = localizer(name).localize(frame, beacons)
    if expected[name] == TRUTH:
        assert estimate.ok, estimate.reason
        pose = {"camera-on-a-beacon": (3.0, 1.5, 0.3),
                "camera-under-two-stacked-beacons": (3.0, 1.5, 0.3),
                "camera-a-nanometre-from-a-beacon": (3.0 - 1e-9, 1.5, 0.3),
                "coordinates-near-1e200": (1e200, 2e200, 0.1)}.get(case, POSE)
        scale = 1e200 if case == "coordinates-near-1e200" else 1.0
        tolerance = 0.01 if name == "mex" else 1e-6  # mex answers on its 1 cm grid
        assert pose_error_of(estimate, *pose)[0] <= tolerance * scale
    else:
        assert not estimate.ok
        assert expected[name] in estimate.reason
        assert math.isnan(estimate.x) and not estimate.inliers.any()

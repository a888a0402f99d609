"""The survey with a site's map as its prior, by hand: a moved beacon found and placed, a right
map confirmed, odometry that reads long corrected by the map, a map 2 % too large kept as it is,
and the leave-its-prior-out position of :func:`azgym.mapping.graph.left_out`."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from azgym.core import BeaconMap
from azgym.errors import InvalidInputError
from azgym.mapping import Drive, Prior, Settings, survey
from azgym.mapping.checks import line_drive
from azgym.sensing.motion import OdometrySamples

pytest.importorskip("gtsam")

WORLD = BeaconMap([1, 2, 3, 4, 5, 6], [[2.0, 3.0, 3.0], [4.0, -3.0, 3.0], [6.0, 4.0, 3.0],
                                      [8.0, -3.5, 3.0], [10.0, 3.0, 3.0], [12.0, -3.0, 3.0]],
                  0.03)
"""Six beacons on both sides of the checks' 10 m drive along the x axis (start (0, 0), heading
0, every azimuth exact)."""
MOVED = BeaconMap(WORLD.ids, WORLD.xyz + np.array([[0.0, 0.0, 0.0]] * 2 + [[0.6, -0.8, 0.0]]
                                                  + [[0.0, 0.0, 0.0]] * 3), 0.03)
"""The world after beacon 3 moved 1 m (0.6, -0.8); the map still has it where it was."""
SETTINGS = Settings()
CAUCHY_SCALE = SETTINGS.loss_scale
"""Where the map prior's Cauchy loss turns, in its standard deviations (3)."""


def read_long(drive: Drive, factor: float) -> Drive:
    """The drive with its odometry's speeds multiplied by ``factor``."""
    frames = []
    for frame in drive.frames:
        odometry = frame.motion.odometry
        frames.append(dataclasses.replace(frame, motion=dataclasses.replace(
            frame.motion, odometry=OdometrySamples(odometry.time, odometry.speed * factor,
                                                   odometry.steer, odometry.yaw_rate))))
    return dataclasses.replace(drive, frames=tuple(frames))


def errors(result, truth: BeaconMap) -> dict[int, float]:
    """Each surveyed beacon's distance from ``truth`` [m]."""
    where = dict(zip(truth.ids.tolist(), truth.xyz[:, :2], strict=True))
    return {i: math.dist(result.xy[b], where[i]) for b, i in enumerate(result.ids.tolist())
            if result.observable[b]}


def held_bound(cost: float) -> float:
    """How far from its map position a held beacon can be placed [m], given the cost the truth
    leaves in the graph: the solve's cost is at most the truth's, and a held beacon off by r
    costs its Cauchy prior c²/2 log(1 + (r/σc)²) (σ the map's accuracy, c the loss's scale)."""
    c = CAUCHY_SCALE
    return SETTINGS.map_sigma * c * math.sqrt(math.expm1(2.0 * cost / c**2))


def test_exact_readings_find_the_moved_beacon_where_it_is_and_nothing_on_a_right_map():
    """Every factor holds exactly at the truth once beacon 3's map prior is left out, so the
    solve lands on it: within a millimetre (the solver's convergence is far finer)."""
    result = survey(line_drive(MOVED), Prior(WORLD))
    assert result.moved == (3,)
    assert sorted(errors(result, MOVED)) == [1, 2, 3, 4, 5, 6]
    assert max(errors(result, MOVED).values()) < 1e-3
    right = survey(line_drive(WORLD), Prior(WORLD))
    assert right.moved == () and max(errors(right, WORLD).values()) < 1e-3


def test_the_map_corrects_odometry_reading_5_percent_long():
    """The odometry reads 5 % long. Without a map (the start pose alone fixing the frame)
    nothing tells the scale but that odometry, and the beacons come out 5 % too far from the
    start, decimetres off. With the map as the prior, the truth leaves
    one factor unsatisfied, the scale error's prior (the odometry's true scale error,
    1/1.05 − 1 = −4.8 %, is 2.4 of its 2 % standard deviations: a cost of 2.83), so no held
    beacon can be placed further from the map than that cost allows (:func:`held_bound`,
    2.8 cm; measured: under half a millimetre); beacon 3, moved 1 m, is found and placed as
    well; on the map as it is, nothing is called moved."""
    cost = 0.5 * ((1.0 / 1.05 - 1.0) / SETTINGS.noise.speed_scale) ** 2
    bound = held_bound(cost)
    assert 0.027 < bound < 0.029
    result = survey(read_long(line_drive(MOVED), 1.05), Prior(WORLD))
    assert result.moved == (3,)
    off = errors(result, MOVED)
    assert max(v for i, v in off.items() if i != 3) < bound
    assert off[3] < 0.01
    right = survey(read_long(line_drive(WORLD), 1.05), Prior(WORLD))
    assert right.moved == () and max(errors(right, WORLD).values()) < bound
    free = survey(read_long(line_drive(WORLD), 1.05), Prior())  # no map: the start alone
    assert max(errors(free, WORLD).values()) > 0.1  # what the map's positions save


def test_a_map_2_percent_too_large_is_kept_as_it_is():
    """The map is the world scaled by 1.02 about the start (a survey with a stretched tape),
    the drive exact. Azimuths cannot tell a scaled map from a scaled world, and the odometry's
    scale error has a 2 % standard deviation: the map, its positions consistent with every
    azimuth, is explained by an odometry reading 2 % short (a cost of 0.5) rather than by 6
    beacons moved. Right: nothing moved, every beacon kept in the map's frame, within what that
    cost allows (:func:`held_bound`, 1.0 cm; measured: under 0.2 mm), not moved 7-25 cm to the
    world's."""
    stretched = BeaconMap(WORLD.ids, WORLD.xyz * np.array([1.02, 1.02, 1.0]), 0.03)
    bound = held_bound(0.5)
    assert 0.0102 < bound < 0.0104
    result = survey(line_drive(WORLD), Prior(stretched))
    assert result.moved == ()
    assert max(errors(result, stretched).values()) < bound
    assert min(errors(result, WORLD).values()) > 0.05


def test_left_out_removes_the_beacons_own_prior_by_hand():
    """A held beacon whose data say A = diag(4·10⁴, 10²) m⁻² (sure across its rays, unsure
    along) and whose prior says P = w I / σ², σ = 1 cm, w the Cauchy weight at its residual:
    solved at m + e with e = (1, 2) mm, r = |e| / σ = 0.2236, w = 9 / (9 + r²) = 0.99447. Its
    marginal covariance is (A + P)⁻¹; left out, its covariance is A⁻¹ and its position
    m + A⁻¹ (A + P) e."""
    from azgym.mapping.graph import Solution, left_out, skeleton

    data = np.diag([4e4, 1e2])
    e = np.array([0.001, 0.002])
    weight = 9.0 / (9.0 + (np.hypot(*e) / 0.01) ** 2)
    assert weight == pytest.approx(0.99447, abs=1e-5)
    prior = weight / 0.01**2 * np.eye(2)
    m = np.array([5.0, 3.0])
    graph = dataclasses.replace(
        skeleton([line_drive(WORLD)], np.array([0, 101]), [_still()], np.zeros((101, 3)),
                 SETTINGS),
        beacons=(m + e)[None], priors=np.array([0]), prior_xy=m[None])
    solution = Solution(np.zeros((101, 3)), (m + e)[None], np.zeros((100, 2)), np.zeros(0), 0)
    position, covariance = left_out(graph, solution, SETTINGS,
                                    np.linalg.inv(data + prior)[None])
    np.testing.assert_allclose(covariance[0], np.linalg.inv(data), rtol=1e-9)
    np.testing.assert_allclose(position[0], m + np.linalg.solve(data, (data + prior) @ e),
                               rtol=1e-9)
    # along the rays the data barely know it: there, left out, it sits far from the map
    assert position[0, 1] - m[1] == pytest.approx(0.002 * (1.0 + 1e4 * weight / 1e2), rel=1e-9)


def _still():
    """The checks' drive's odometry (only its shapes matter to :func:`left_out`)."""
    from azgym.mapping.odometry import relative_poses

    return relative_poses(line_drive(WORLD), SETTINGS)


def test_a_moved_beacons_guess_is_where_most_of_its_rays_meet_not_its_mirror_image():
    """A straight 10 m drive sees a beacon at (6, 4) 21 times, exactly, and its mirror image at
    (8, -2) 20 times; the map had the beacon at (5, 3). Reweighted from the least-squares point
    of all 41 rays, the intersection falls to the image (20 rays pass through it); the map
    position agrees with none; where two of the rays meet, the most (21) agree at (6, 4), and
    their meeting point is it exactly."""
    from azgym.localize.bearings import intersect_robustly
    from azgym.mapping.first_guess import first_guess

    beacon, image = np.array([6.0, 4.0]), np.array([8.0, -2.0])
    x = np.linspace(0.0, 10.0, 21)
    poses = np.column_stack([x, np.zeros(21), np.zeros(21)])
    twenty = np.linspace(0, 20, 20).round().astype(int)
    poses = np.vstack([poses, poses[twenty]])
    azimuths = np.concatenate([np.arctan2(beacon[1], beacon[0] - x),
                               np.arctan2(image[1], image[0] - x[twenty])])
    reweighted, _ = intersect_robustly(poses[:, :2], azimuths)
    assert math.dist(reweighted, image) < 0.05
    guess, reason = first_guess(poses, azimuths, np.array([5.0, 3.0]))
    assert reason == ""
    np.testing.assert_allclose(guess, beacon, atol=1e-9)


def test_map_sigma_is_checked():
    for bad in (0.0, 1e-9, math.nan, math.inf):
        with pytest.raises(InvalidInputError, match="map_sigma must be a number of at least "
                                                    "0.001 m"):
            Settings(map_sigma=bad)
    assert Settings(map_sigma=0.001).map_sigma == 0.001

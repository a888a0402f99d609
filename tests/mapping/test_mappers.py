"""The built-in mappers on drives built by hand: where they place beacons, how sure they are."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from azgym.core import BeaconMap
from azgym.errors import InvalidInputError
from azgym.mapping import Drive, MapAnswer, Prior, Settings, make_mapper
from azgym.mapping.checks import line_drive
from azgym.mapping.graph import START_STD
from azgym.mapping.mappers import RaysMapper, SurveyMapper
from azgym.site.error_model import ErrorModel
from azgym.track.unicycle import MotionNoise

THREE = BeaconMap([7, 8, 9], [[3.0, 3.0, 3.0], [6.0, -3.5, 3.0], [8.0, 5.0, 3.0]], 0.03)
"""Three beacons beside a 10 m straight drive along the x axis (the camera from (0, 0) to
(10, 0), heading 0, 101 frames)."""
STILL = {name: 0.0 for name in ("speed_noise", "speed_scale", "scale_walk", "turn_rate_noise",
                                "bias_walk", "position_walk", "heading_walk", "start_bias")}
"""Hyperparameters of motion sensors without error: the poses' covariance is the start's."""


def errors(answer: MapAnswer, truth: BeaconMap) -> dict[int, float]:
    where = dict(zip(truth.ids.tolist(), truth.xyz[:, :2], strict=True))
    return {i: math.dist(xy, where[i]) for i, xy in zip(answer.ids.tolist(), answer.xy,
                                                        strict=True)}


@pytest.mark.parametrize("spec", ["survey", "rays"])
def test_exact_azimuths_from_a_straight_drive_place_every_beacon_within_a_millimetre(spec):
    answer = make_mapper(spec).survey(line_drive(THREE), Prior())
    assert answer.ids.tolist() == [7, 8, 9] and answer.moved == ()
    assert max(errors(answer, THREE).values()) < 1e-3


def test_the_rays_covariance_is_the_rays_information_and_the_poses_shared_error_by_hand():
    """Each ray weighs 1 / (r² σ²) (eq. 1-3 at its range r plus extra_sigma²) across its
    direction n = (−sin θ, cos θ): A = Σ n nᵀ / (r² σ²). The poses' shared error (their mean
    covariance S) moves the point as a shift moves every ray (the identity) and as a turn δ of
    every ray about its start moves their meeting point: nᵀ dp = r δ for each ray, so
    dp/dδ = A⁻¹ Σ n r / (r² σ²). Without motion noise a pose x metres along the drive has the
    start's covariance with the heading's error turned into y: σy² + x² σφ², cross x σφ²."""
    mapper = RaysMapper(**STILL)
    answer = mapper.survey(line_drive(THREE), Prior())
    sx, sy, sphi = START_STD
    x = np.arange(101) * 0.1  # the camera's positions along the drive
    shared = np.array([[sx**2, 0.0, 0.0],
                       [0.0, sy**2 + np.mean(x**2) * sphi**2, np.mean(x) * sphi**2],
                       [0.0, np.mean(x) * sphi**2, sphi**2]])
    model = ErrorModel(mapper.delta_alpha_d, mapper.coverage)
    for k, beacon in enumerate(THREE.xyz[:, :2]):
        offsets = beacon - np.column_stack([x, np.zeros_like(x)])
        r = np.hypot(*offsets.T)
        theta = np.arctan2(offsets[:, 1], offsets[:, 0])
        n = np.column_stack([-np.sin(theta), np.cos(theta)])
        w = 1.0 / (r**2 * (model.variance(r, 0.03) + mapper.extra_sigma**2))
        information = (n * w[:, None]).T @ n
        turn = np.linalg.solve(information, (n * (w * r)[:, None]).sum(axis=0))
        jacobian = np.column_stack([np.eye(2), turn])
        expected = np.linalg.inv(information) + jacobian @ shared @ jacobian.T
        np.testing.assert_allclose(answer.covariances[k], expected, rtol=1e-6, atol=1e-12)


def test_the_survey_is_as_sure_as_the_rays_geometry_lets_it_be():
    """With exact motion sensors the survey knows what the rays know: its covariance has its
    long axis where the rays' (by hand above) has it, and as long (within a quarter)."""
    rays = RaysMapper(**STILL).survey(line_drive(THREE), Prior())
    slam = SurveyMapper(**STILL).survey(line_drive(THREE), Prior())
    for a, b in zip(rays.covariances, slam.covariances, strict=True):
        (_, long_a), (_, long_b) = np.linalg.eigh(a)[1].T, np.linalg.eigh(b)[1].T
        assert abs(long_a @ long_b) > math.cos(math.radians(20))
        assert np.linalg.eigvalsh(b)[1] == pytest.approx(np.linalg.eigvalsh(a)[1], rel=0.25)


def test_the_rays_do_not_know_the_gyro_bias_the_survey_estimates():
    """Dead reckoning alone cannot tell the gyro's bias (0.005 rad/s at the start, as shipped):
    over the 10 s drive it turns the poses by up to 0.05 rad, and the rays' covariance says so;
    the survey estimates the bias from the azimuths and is surer."""
    rays = make_mapper("rays").survey(line_drive(THREE), Prior())
    slam = make_mapper("survey").survey(line_drive(THREE), Prior())
    assert (np.linalg.eigvalsh(rays.covariances)[:, 1] >
            np.linalg.eigvalsh(slam.covariances)[:, 1]).all()


@pytest.mark.parametrize("mapper", [SurveyMapper(), RaysMapper(**STILL)], ids=["survey", "rays"])
def test_a_beacon_moved_half_a_metre_is_found_moved_and_placed_where_it_is(mapper):
    """(The rays' without motion noise: with the gyro's bias unknown their covariance spans
    half a metre, and the move is within it.)"""
    stale = THREE.xyz.copy()
    stale[1, :2] += (0.3, 0.4)
    prior = Prior(BeaconMap(THREE.ids, stale, 0.03))
    answer = mapper.survey(line_drive(THREE), prior)
    assert answer.moved == (8,) and max(errors(answer, THREE).values()) < 1e-3
    assert mapper.survey(line_drive(THREE), Prior(THREE)).moved == ()


def test_rays_without_a_start_are_placed_on_the_map_by_two_anchors():
    """The map's frame is the drive's turned by 30° and shifted by (5, -2): the anchors' map
    positions carry the drive's beacons into it."""
    world = BeaconMap([1, 2, 7, 8, 9], np.vstack([[[0.0, 4.0, 3.0], [10.0, -4.0, 3.0]],
                                                   THREE.xyz]), 0.03)
    turn = math.radians(30.0)
    rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    mapped = world.xyz.copy()
    mapped[:, :2] = world.xyz[:, :2] @ rotation.T + (5.0, -2.0)
    drive = dataclasses.replace(line_drive(world), start=None)
    prior = Prior(BeaconMap(world.ids[:2], mapped[:2], 0.03), (1, 2))
    answer = make_mapper("rays").survey(drive, prior)
    assert answer.ids.tolist() == [7, 8, 9]
    np.testing.assert_allclose(answer.xy, mapped[2:, :2], atol=1e-6)


def test_a_beacon_on_the_line_of_travel_is_not_placed():
    """Every ray to a beacon straight ahead lies on one line: no spread, nothing to place."""
    ahead = BeaconMap([7, 8, 9, 10], np.vstack([THREE.xyz, [[15.0, 0.0, 3.0]]]), 0.03)
    for spec in ("rays", "survey"):
        assert 10 not in make_mapper(spec).survey(line_drive(ahead), Prior()).ids.tolist()


def test_prior_places_nothing_and_the_map_goes_on_as_it_was():
    answer = make_mapper("prior").survey(line_drive(THREE), Prior(THREE))
    assert answer.ids.size == 0
    assert answer.updated(THREE).xyz.tobytes() == THREE.xyz.tobytes()


def test_repair_finds_the_moved_beacon_and_puts_it_where_it_is():
    world = BeaconMap([1, 2, 7, 8, 9], np.vstack([[[0.0, 4.0, 3.0], [10.0, -4.0, 3.0]],
                                                   THREE.xyz]), 0.03)
    stale = world.xyz.copy()
    stale[4, 1] -= 1.0
    answer = make_mapper("repair").survey(line_drive(world), Prior(BeaconMap(world.ids, stale,
                                                                               0.03)))
    assert answer.ids.tolist() == [9] and answer.moved == (9,)
    assert errors(answer, world)[9] < 0.01
    assert make_mapper("repair").survey(line_drive(world), Prior(world)).ids.size == 0


@pytest.mark.parametrize(("spec", "drive", "prior", "message"), [
    ("survey", "no start", Prior(), "the map frame is free: give the start pose or at least two "
                                    "anchors"),
    ("rays", "no start", Prior(THREE, (7,)), "the map frame is free"),
    ("rays", "no start", Prior(BeaconMap([1, 2], [[0, 9, 3], [9, 9, 3]]), (1, 2)),
     "the checks' drive has no known start pose and observes 0 anchors"),
    ("rays", "no frames", Prior(), "the drive has no frames"),
    ("survey", "no frames", Prior(), "the drive has no frames"),
    ("prior", "no frames", Prior(), "the drive has no frames"),
    ("repair", "no start", Prior(THREE), "repair: the checks' drive has no start pose"),
    ("repair", "with start", Prior(), "repair: no prior map"),
])
def test_a_drive_a_mapper_cannot_place_is_refused_by_name(spec, drive, prior, message):
    made = {"no start": dataclasses.replace(line_drive(THREE, seconds=1.0), start=None),
            "no frames": Drive(()), "with start": line_drive(THREE, seconds=1.0)}[drive]
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        make_mapper(spec).survey(made, prior)


def test_the_settings_mappers_take_every_setting_as_a_hyperparameter():
    """Each field of the survey's settings (the motion noise's spelled out) is a hyperparameter
    of ``survey`` (``rays``: but the graph's loss and the map's accuracy, which only a graph
    weighs), so a profile or a spec reaches it."""
    settings = {f.name for f in dataclasses.fields(Settings)} - {"noise"}
    settings |= {f.name for f in dataclasses.fields(MotionNoise)}
    assert set(SurveyMapper().get_params()) == settings
    assert set(RaysMapper().get_params()) == settings - {"loss", "loss_scale", "map_sigma"}
    with pytest.raises(InvalidInputError, match="map_sigma"):
        SurveyMapper(map_sigma=0.0)

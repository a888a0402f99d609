"""The Sensor protocol: both camera models answer alike, seeded by the caller, bit for bit."""

from __future__ import annotations

import re

import numpy as np
import pytest

import azgym
from azgym.errors import InvalidInputError
from azgym.sensing.catalog import make_sensor
from azgym.sensing.labels import GHOST
from azgym.sensing.protocol import Observation, Sensor

POSE = (15.0, 10.0, 0.3)
KINDS = [("geometry", "oracle"), ("image", "oracle"), ("image", "blink")]


@pytest.fixture(scope="module")
def scenario():
    return azgym.load_scenario("warehouse-small")


@pytest.mark.parametrize(("kind", "ids"), KINDS)
def test_every_sensor_returns_one_observation_type_index_for_index(scenario, kind, ids):
    sensor = make_sensor(scenario, kind, ids)
    assert isinstance(sensor, Sensor)
    assert len(sensor.quality_high) == len(sensor.quality_names)
    sensor.reset(0)
    observation = sensor.observe(POSE, np.random.default_rng(0))
    assert isinstance(observation, Observation)
    size = len(observation.measurements)
    truth = observation.truth
    assert size > 0
    for column in (truth.label, truth.beacon, truth.azimuth, truth.visible, truth.mirrored):
        assert column.shape == (size,)
    quality = observation.measurements.quality
    assert quality.reshape(size, -1).shape[1] == len(sensor.quality_names)
    assert (observation.image is None) == (kind == "geometry")
    assert set(observation.in_view) <= set(range(len(scenario.beacons)))


@pytest.mark.parametrize(("kind", "ids"), KINDS)
def test_the_same_seeds_give_the_same_frame_bit_for_bit(scenario, kind, ids):
    frames = []
    for _ in range(2):
        sensor = make_sensor(scenario, kind, ids)
        sensor.reset(7)
        rng = np.random.default_rng(3)
        frames.append([sensor.observe(POSE, rng) for _ in range(3)])
    for first, again in zip(*frames, strict=True):
        assert np.array_equal(first.measurements.ids, again.measurements.ids)
        assert np.array_equal(first.measurements.azimuth, again.measurements.azimuth)
        assert np.array_equal(first.truth.label, again.truth.label)
        if first.image is not None:
            assert np.array_equal(first.image, again.image)


def test_reset_seeds_the_image_sensors_noise_and_blinking_phases(scenario):
    sensor = make_sensor(scenario, "image", "blink")
    sensor.reset(1)
    phases, image = sensor.phases.copy(), sensor.observe(POSE, np.random.default_rng(0)).image
    sensor.reset(1)
    assert np.array_equal(sensor.phases, phases)
    assert np.array_equal(sensor.observe(POSE, np.random.default_rng(0)).image, image)
    sensor.reset(2)
    assert not np.array_equal(sensor.phases, phases)
    assert not np.array_equal(sensor.observe(POSE, np.random.default_rng(0)).image, image)


def test_an_image_sensor_refuses_to_look_before_it_is_seeded(scenario):
    with pytest.raises(InvalidInputError, match=r"call reset\(seed\) before the first observe"):
        make_sensor(scenario, "image").observe(POSE, np.random.default_rng(0))


def test_mirror_images_are_flagged_and_are_not_beacons_in_view(scenario):
    import dataclasses

    bright = dataclasses.replace(scenario, walls=tuple(
        dataclasses.replace(wall, reflectivity=0.9) for wall in scenario.walls))
    sensor = make_sensor(bright, "geometry")
    rng = np.random.default_rng(0)
    observation = sensor.observe(POSE, rng)
    truth = observation.truth
    assert truth.mirrored.any()
    assert np.array_equal(truth.mirrored, truth.label == GHOST)  # no misreads in this scenario
    assert sorted(observation.in_view) == sorted(truth.beacon[~truth.mirrored])


@pytest.mark.parametrize(("kind", "ids", "error", "message"), [
    ("imag", "oracle", azgym.UnknownNameError, "unknown sensor 'imag'. Did you mean 'image'?"),
    ("image", "blnk", azgym.UnknownNameError, "unknown ids 'blnk'. Did you mean 'blink'?"),
    ("geometry", "blink", InvalidInputError, 'ids="blink" needs the image path'),
])
def test_sensor_names_are_checked(scenario, kind, ids, error, message):
    with pytest.raises(error, match=message):
        make_sensor(scenario, kind, ids)


def columns(**changes):
    base = dict(ids=[3, 1], azimuth=[0.5, -0.2], quality=[[1.0, 2.0], [3.0, 4.0]],
                label=[0, 2], beacon=[2, 0], true_azimuth=[0.5, np.nan], visible=[1.0, 0.0],
                mirrored=[False, True])
    return {**base, **changes}


def test_an_observation_from_columns_is_listed_by_azimuth_without_blobs():
    observation = Observation.from_columns(**columns())
    assert list(observation.measurements.ids) == [1, 3]
    assert observation.measurements.quality.tolist() == [[3.0, 4.0], [1.0, 2.0]]
    assert list(observation.truth.mirrored) == [True, False]
    assert observation.blobs == () and list(observation.in_view) == [2]


@pytest.mark.parametrize(("change", "message"), [
    ({"ids": [1.5, 2]}, "Measurements.ids must hold integers, got 1.5"),
    ({"azimuth": [np.nan, 0.1]}, "Measurements.azimuth must be finite"),
    ({"label": [0]}, "Observation.label must have shape (2,), got (1,)"),
    ({"beacon": [0.5, 1.0]}, "Observation.beacon must hold integers"),
    ({"visible": [np.inf, 0.0]}, "Observation.visible must be finite, got inf at index 0"),
    ({"true_azimuth": [np.inf, 0.0]}, "Observation.true_azimuth must be finite"),
    ({"blobs": (None,)}, "Observation.blobs must be empty or hold 2 blobs, got 1"),
])
def test_a_bad_column_is_named(change, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        Observation.from_columns(**columns(**change))


@pytest.mark.parametrize("pose", [(np.nan, 5.0, 0.0), (1.0, 2.0), ("a", 1.0, 0.0), None])
def test_a_sensor_refuses_a_pose_that_is_not_three_finite_numbers(scenario, pose):
    for kind, ids in KINDS[:2]:
        sensor = make_sensor(scenario, kind, ids)
        sensor.reset(0)
        with pytest.raises(InvalidInputError, match="pose must be"):
            sensor.observe(pose, np.random.default_rng(0))


def test_an_empty_frame_keeps_its_quality_columns():
    empty = Observation.from_columns(**columns(
        ids=[], azimuth=[], quality=np.empty((0, 3)), label=[], beacon=[], true_azimuth=[],
        visible=[], mirrored=[]))
    assert len(empty) == 0 and empty.measured.shape == (4, 0)

"""Fisheye frames: blobs rendered from the geometry are detected where the geometry says."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.sensing.image._match import nearest_lights
from azgym.sensing.image.detect import detect
from azgym.sensing.image.render import render
from azgym.site.fisheye import FisheyeCamera

CAMERA = FisheyeCamera(focal_px=150.0, principal_point=(240.0, 240.0),
                       distortion=(-0.01, 0.002, 0.0, 0.0))


def direction(azimuth, elevation):
    c = math.cos(elevation)
    return [c * math.cos(azimuth), c * math.sin(azimuth), math.sin(elevation)]



def seeded(sensor):
    """The sensor, reset with seed 0 (its noise bank and blinking phases drawn)."""
    sensor.reset(0)
    return sensor


@pytest.mark.parametrize(("azimuth_deg", "elevation_deg"), [(30.0, 10.0), (-135.0, 25.0),
                                                            (91.0, 2.0)])
def test_a_single_blob_is_detected_within_a_twentieth_of_a_degree(azimuth_deg, elevation_deg):
    azimuth, elevation = math.radians(azimuth_deg), math.radians(elevation_deg)
    half = math.atan2(0.015, 10.0)  # a 3 cm LED 10 m away
    image = render(CAMERA, np.array([azimuth - half]), np.array([azimuth + half]),
                   np.array([elevation]), np.array([5.0]))
    [blob] = detect(image, CAMERA)
    error = math.degrees(abs(math.remainder(blob.azimuth - azimuth, 2 * math.pi)))
    assert error < 0.05
    assert blob.area >= 4 and blob.elongation < 1.5


def test_a_half_covered_beacon_is_detected_at_its_visible_halfs_centroid():
    # A beacon whose extent spans 0.1 rad (about 20 px on the image), its lower half covered: the
    # geometry (see test_sensor) puts the azimuth at the visible half's centroid, h / 2.
    azimuth, elevation, half = math.radians(40.0), math.radians(8.0), 0.05
    full = detect(render(CAMERA, np.array([azimuth - half]), np.array([azimuth + half]),
                         np.array([elevation]), np.array([5.0])), CAMERA)
    cut = detect(render(CAMERA, np.array([azimuth]), np.array([azimuth + half]),
                        np.array([elevation]), np.array([5.0])), CAMERA)
    predicted = CAMERA.project([direction(azimuth + half / 2, elevation)])[0]
    [blob] = cut
    assert math.hypot(blob.u - predicted[0], blob.v - predicted[1]) < 0.5
    assert blob.azimuth > full[0].azimuth  # shifted toward the visible half


def test_an_empty_frame_has_no_blobs_and_two_lights_give_two():
    empty = render(CAMERA, np.array([]), np.array([]), np.array([]), np.array([]))
    assert detect(empty, CAMERA) == []
    two = render(CAMERA, np.array([0.0, 2.0]), np.array([0.001, 2.001]), np.array([0.1, 0.2]),
                 np.array([3.0, 3.0]))
    assert len(detect(two, CAMERA)) == 2


def test_the_image_sensor_finds_the_geometrys_lights_with_their_ids():
    import azgym
    from azgym.sensing.geometry.sensor import GeometrySensor
    from azgym.sensing.image.sensor import ImageSensor
    from azgym.sensing.labels import DISTRACTOR

    scenario = azgym.load_scenario("warehouse-small")
    pose = (15.0, 10.0, 0.3)
    frame = seeded(ImageSensor(scenario, noise_sigma=0.0)).observe(pose, np.random.default_rng(0))
    truth = GeometrySensor(scenario).observe(pose, np.random.default_rng(0)).truth
    beacons = np.flatnonzero(frame.truth.label != DISTRACTOR)  # the lamps' blobs aside
    assert len(beacons) == len(truth.label)
    assert np.all(frame.measurements.ids[frame.truth.label == DISTRACTOR] == -1)
    for k in beacons:
        nearest = np.argmin(np.abs(np.angle(np.exp(1j * (truth.azimuth
                                                         - frame.measurements.azimuth[k])))))
        error = abs(math.remainder(truth.azimuth[nearest] - frame.measurements.azimuth[k],
                                   2 * math.pi))
        assert math.degrees(error) < 0.05
        assert frame.truth.label[k] == truth.label[nearest]
    assert frame.measurements.quality.shape == (len(frame.measurements), 3)


def test_no_visible_beacon_gives_an_empty_frame_not_an_error():
    import dataclasses

    import azgym
    from azgym.sensing.image.sensor import ImageSensor
    from azgym.site.elements import Camera

    high = dataclasses.replace(azgym.load_scenario("warehouse-small"), camera=Camera(height=9.0))
    frame = seeded(ImageSensor(high)).observe((15.0, 10.0, 0.0), np.random.default_rng(0))
    assert len(frame.measurements) == 0 and frame.blobs == ()


def test_ransac_on_detected_blobs_localizes_to_centimetres():
    import azgym
    from azgym.sensing.image.sensor import ImageSensor

    scenario = azgym.load_scenario("warehouse-small")
    sensor, ransac = seeded(ImageSensor(scenario)), azgym.make_localizer("ransac")
    rng = np.random.default_rng(1)
    errors = []
    for x, y in [(2.0, 6.0), (15.0, 10.0), (28.0, 14.0), (8.0, 1.7), (22.0, 18.3)]:
        frame = sensor.observe((x, y, float(rng.uniform(-3, 3))), rng)
        estimate = ransac.localize(frame.measurements, scenario.beacons)
        if estimate.ok:
            errors.append(math.hypot(estimate.x - x, estimate.y - y))
    assert len(errors) >= 4 and np.median(errors) < 0.05


def test_a_lamp_is_drawn_as_a_patch_centred_where_it_projects():
    azimuth, elevation, half = math.radians(-60.0), math.radians(50.0), math.radians(3.0)
    image = render(CAMERA, np.array([azimuth - half]), np.array([azimuth + half]),
                   np.array([elevation]), np.array([300.0]), half_tall=np.array([half]))
    [blob] = detect(image, CAMERA)
    centre = CAMERA.project([direction(azimuth, elevation)])[0]
    assert math.hypot(blob.u - centre[0], blob.v - centre[1]) < 0.5
    assert blob.peak == 255 and blob.area > 50  # a bright, extended light saturates


def test_lamps_and_windows_are_blobs_no_beacon_explains():
    import azgym
    from azgym.sensing.image.sensor import ImageSensor
    from azgym.sensing.labels import DISTRACTOR

    scenario = azgym.load_scenario("warehouse-small")
    assert [light.name for light in scenario.lights].count("ceiling lamp") == 2
    frame = seeded(ImageSensor(scenario)).observe((15.0, 10.0, 0.3), np.random.default_rng(0))
    lamps = frame.truth.label == DISTRACTOR
    assert lamps.any() and (frame.measurements.ids[lamps] == -1).all()
    # A lamp's blob has no beacon, but its light's true azimuth.
    assert (frame.truth.beacon[lamps] == -1).all() and np.isfinite(frame.truth.azimuth[lamps]).all()
    # The lamps' blobs are bigger than the beacons' (quality column 0: area).
    area = frame.measurements.quality[:, 0]
    assert np.median(area[lamps]) > 2 * np.median(area[~lamps])


def test_the_error_model_study_measures_what_eq_1_and_2_assume():
    import azgym
    from azgym.experiments.error_model import measure_detections, summarize

    scenario = azgym.load_scenario("warehouse-small")
    errors = measure_detections(scenario, frames=120, calibration_px=1.0, seed=1)
    summary = summarize(scenario, errors, 1.0)
    # Centroids of ideal blobs at sigma = 2 grey levels are far better than eq. 1's 1 px ...
    assert summary["centre_error_px"]["p95"] < 0.2
    assert summary["azimuth_error_within_model"] > 0.99
    # ... while a principal point 1 px off gives azimuth errors of about 1 px / r (times
    # |sin| of the offset's direction, 2 / pi on average), as eq. 1 has it near the horizon.
    whole = errors["visible"] == 1.0
    ratio = np.abs(errors["azimuth_calibrated"][whole]) * errors["radius_px"][whole]
    assert 0.5 < np.mean(ratio) < 0.8
    # Coverage errors of partly covered beacons stay within eq. 2's bound.
    assert summary["partly_covered"] > 0 and summary["coverage_within_eq2_bound"] == 1.0


def test_the_frame_is_the_drawing_plus_noise_clipped_and_cast_as_numpy_does() -> None:
    """The 8-bit frame is numpy's (drawing + noise in float32).clip(0, 255).astype(uint8)."""
    from azgym.sensing.image.render import _to_grey

    rng = np.random.default_rng(3)
    drawing = rng.uniform(-60.0, 320.0, (48, 64)).astype(np.float32)
    drawing[0, :6] = [0.0, 255.0, 254.99998, -0.0, 0.99999994, 255.00002]  # the edges
    noise = rng.normal(0.0, 30.0, (48, 64)).astype(np.float32)
    noise[0, :6] = 0.0
    for added, expected in ((True, drawing + noise), (False, drawing)):
        grey = np.empty((48, 64), dtype=np.uint8)
        _to_grey(drawing, noise, added, grey)
        assert np.array_equal(grey, np.clip(expected, 0, 255).astype(np.uint8))
    assert grey[0, :6].tolist() == [0, 255, 254, 0, 0, 255]


def test_noise_of_the_wrong_shape_is_refused_by_name() -> None:
    from azgym.errors import InvalidInputError

    camera = FisheyeCamera()
    with pytest.raises(InvalidInputError, match="noise must be one frame of 480 x 480"):
        render(camera, np.zeros(1), np.full(1, 0.01), np.full(1, 0.3), np.full(1, 3.0),
               np.zeros(480))


def test_a_blobs_centroid_weighs_its_pixels_above_the_threshold_by_hand() -> None:
    # A 3 x 2 blob at column 10, row 20; its weights above a threshold of 25: (0, 5, 0) in its
    # first row, (1, 3, 2) in its second.
    image = np.zeros((40, 40), dtype=np.uint8)
    image[20, 10:13] = [20, 30, 25]  # 20 and 25 are not above the threshold: weight 0
    image[21, 10:13] = [26, 28, 27]
    (blob,) = detect(image, FisheyeCamera(), threshold=25)
    # m00 = 5 + 1 + 3 + 2 = 11; m10 = 1·5 + 0·1 + 1·3 + 2·2 = 12; m01 = 1·(1 + 3 + 2) = 6
    assert blob.u == 10 + 12 / 11 and blob.v == 20 + 6 / 11
    assert blob.area == 4 and blob.peak == 30.0
    cx, cy = FisheyeCamera().principal_point
    assert blob.azimuth == math.atan2(blob.v - cy, blob.u - cx)


def test_the_blob_moments_are_opencvs() -> None:
    # The compiled pass sums what cv2.moments sums: whole numbers, so equal to the last bit; the
    # central moments by OpenCV's formula (an OpenCV built with Intel's IPP rounds its own way).
    import cv2

    from azgym.sensing.image.detect import _box_moments

    rng = np.random.default_rng(8)
    for _ in range(300):
        height, width = rng.integers(1, 70, 2)
        image = (rng.random((80, 80)) * 255 * (rng.random((80, 80)) < 0.7)).astype(np.uint8)
        x, y = rng.integers(0, 80 - width), rng.integers(0, 80 - height)
        threshold = int(rng.integers(1, 255))
        stats = np.empty((1, 8))
        _box_moments(image, np.array([[x, y, width, height]]), threshold, stats)
        box = image[y:y + height, x:x + width]
        weights = cv2.subtract(box, np.full(box.shape, threshold, np.uint8))
        moments = cv2.moments(weights, binaryImage=False)
        m00, m10, m01, mu20, mu11, mu02, area, peak = stats[0]
        assert (m00, m10, m01) == (moments["m00"], moments["m10"], moments["m01"])
        assert area == cv2.countNonZero(weights) and peak == weights.max()
        if m00 > 0:
            for ours, key in ((mu20, "mu20"), (mu11, "mu11"), (mu02, "mu02")):
                assert ours == pytest.approx(moments[key], rel=1e-12, abs=1e-9 * moments["m20"])


@pytest.mark.parametrize(("image", "threshold", "problem"), [
    (np.zeros((8, 8), dtype=np.float32), 25, "image must be a 2-D 8-bit grey frame"),
    (np.zeros((8, 8, 3), dtype=np.uint8), 25, "image must be a 2-D 8-bit grey frame"),
    ([[0, 1], [2, 3]], 25, "image must be a 2-D 8-bit grey frame"),
    (np.zeros((8, 8), dtype=np.uint8), 0, "threshold must be a grey level in"),
    (np.zeros((8, 8), dtype=np.uint8), 255, "threshold must be a grey level in"),
    (np.zeros((8, 8), dtype=np.uint8), 25.5, "threshold must be a grey level in"),
    (np.zeros((8, 8), dtype=np.uint8), True, "threshold must be a grey level in"),
])
def test_detect_refuses_what_is_not_a_grey_frame_or_level_by_name(image, threshold,
                                                                   problem) -> None:
    from azgym.errors import InvalidInputError

    with pytest.raises(InvalidInputError, match=problem):
        detect(image, FisheyeCamera(), threshold)


def test_a_light_whose_extent_is_not_finite_is_refused_by_name() -> None:
    from azgym.errors import InvalidInputError

    with pytest.raises(InvalidInputError, match="a light's extent is not finite"):
        render(FisheyeCamera(), np.zeros(1), np.full(1, 0.1), np.full(1, math.nan),
               np.full(1, 50.0), None, np.full(1, 0.05))


def numpy_nearest_lights(camera, pixels, azimuth, elevation, half_width, half_tall, match_px):
    """Each blob's light as numpy calls: the centres through ``camera.project``, then a table."""
    c = np.cos(elevation)
    centres = camera.project(np.column_stack([c * np.cos(azimuth), c * np.sin(azimuth),
                                              np.sin(elevation)]))
    radius = np.hypot(centres[:, 0] - camera.principal_point[0],
                      centres[:, 1] - camera.principal_point[1])
    reach = match_px + np.maximum(radius * half_width, camera.focal_px * half_tall)
    distance = np.hypot(pixels[:, None, 0] - centres[None, :, 0],
                        pixels[:, None, 1] - centres[None, :, 1])
    nearest = distance.argmin(axis=1)
    close = distance[np.arange(len(pixels)), nearest] <= reach[nearest]
    return np.where(close, nearest, -1)


@pytest.mark.parametrize("seed", range(20))
def test_each_blob_takes_the_nearest_light_within_its_reach_as_numpy_finds_it(seed):
    rng = np.random.default_rng(seed)
    camera = FisheyeCamera(distortion=(0.02, -0.01, 0.003, -0.0005))
    lights = int(rng.integers(1, 16))
    azimuth = rng.uniform(-math.pi, math.pi, lights)
    elevation = rng.uniform(0.0, 1.3, lights)
    half_width = rng.uniform(0.0, 0.02, lights)
    half_tall = np.where(rng.random(lights) < 0.3, rng.uniform(0.0, 0.05, lights), 0.0)
    c = np.cos(elevation)
    centres = camera.project(np.column_stack([c * np.cos(azimuth), c * np.sin(azimuth),
                                              np.sin(elevation)]))
    # blobs near the lights (some out of reach), blobs anywhere, two at one light
    near = centres[rng.integers(0, lights, 10)] + rng.normal(0.0, 4.0, (10, 2))
    pixels = np.concatenate([near, rng.uniform(0.0, 480.0, (5, 2)), centres[:1], centres[:1]])
    expected = numpy_nearest_lights(camera, pixels, azimuth, elevation, half_width, half_tall,
                                    3.0)
    source = np.full(len(pixels), -2, dtype=np.int64)
    cx, cy = camera.principal_point
    nearest_lights(pixels, azimuth, elevation, half_width, half_tall, float(cx), float(cy),
                   float(camera.focal_px), np.array(camera.distortion, dtype=np.float64), 3.0,
                   source)
    assert source.tolist() == expected.tolist()
    assert source[-1] == source[-2] >= 0  # a blob at a light's centre is within its reach

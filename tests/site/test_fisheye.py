"""The fisheye camera model against OpenCV's cv2.fisheye, and its validation."""

from __future__ import annotations

import math
import re

import cv2
import numpy as np
import pytest

from azgym import InvalidInputError
from azgym.site.fisheye import MAX_IMAGE_SIDE, FisheyeCamera

CAMERA = FisheyeCamera(focal_px=152.0, principal_point=(241.5, 238.25), image_size=(480, 480),
                       distortion=(-0.02, 0.004, -0.0005, 0.00002))


NEAR_HORIZON = math.radians(89.0)


def directions(count=500, seed=0, max_polar=NEAR_HORIZON):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, max_polar, count)
    phi = rng.uniform(-math.pi, math.pi, count)
    return np.column_stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                            np.cos(theta)])


def test_projection_matches_opencv_to_a_micro_pixel():
    d = directions()
    ours = CAMERA.project(d)
    theirs, _ = cv2.fisheye.projectPoints(d.reshape(-1, 1, 3), np.zeros(3), np.zeros(3),
                                          CAMERA.camera_matrix, CAMERA.distortion_vector)
    assert np.abs(ours - theirs.reshape(-1, 2)).max() < 1e-6


def test_unprojection_matches_opencv_and_round_trips():
    d = directions(seed=1)
    pixels = CAMERA.project(d)
    back = CAMERA.unproject(pixels)
    assert np.abs(back - d).max() < 1e-9
    undistorted = cv2.fisheye.undistortPoints(
        pixels.reshape(-1, 1, 2), CAMERA.camera_matrix, CAMERA.distortion_vector,
        criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)).reshape(-1, 2)
    ours = back[:, :2] / back[:, 2:3]  # normalised image coordinates, as OpenCV returns
    assert np.abs(CAMERA.project(np.column_stack([undistorted, np.ones(len(d))])) - pixels).max() \
        < 1e-6
    assert np.abs(ours - undistorted).max() < 1e-6


def test_the_azimuth_of_a_pixel_does_not_depend_on_focal_length_or_distortion():
    d = directions(seed=2)
    truth = np.arctan2(d[:, 1], d[:, 0])
    for camera in (CAMERA, FisheyeCamera(focal_px=90.0, principal_point=(241.5, 238.25))):
        assert np.abs(np.angle(np.exp(1j * (camera.azimuth(camera.project(d)) - truth)))).max() \
            < 1e-12


def test_the_horizon_radius_is_f_times_distorted_ninety_degrees():
    plain = FisheyeCamera(focal_px=150.0)
    assert plain.horizon_radius_px == pytest.approx(150.0 * math.pi / 2)
    assert plain.project([[1.0, 0.0, 0.0]])[0] == pytest.approx([240.0 + 150 * math.pi / 2,
                                                                 240.0])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"focal_px": 0.0}, "FisheyeCamera.focal_px must be > 0"),
        ({"focal_px": -5.0}, "FisheyeCamera.focal_px must be > 0"),
        ({"image_size": (0, 480)}, "FisheyeCamera.image_size must be two integers in [1, "),
        # refused before any image is allocated (the image sensor keeps 8 noise frames)
        ({"image_size": (200_000, 200_000), "principal_point": (100_000.0, 100_000.0)},
         f"FisheyeCamera.image_size must be two integers in [1, {MAX_IMAGE_SIDE}] px, got "
         "(200000, 200000)"),
        ({"image_size": (True, 480)}, "FisheyeCamera.image_size must be two integers"),
        ({"principal_point": (500.0, 240.0)}, "FisheyeCamera.principal_point (500.0, 240.0) is "
                                              "off the 480 x 480 image"),
        ({"distortion": (-0.5, 0.0, 0.0, 0.0)}, "makes the projection non-monotonic"),
        ({"distortion": (0.0, math.nan, 0.0, 0.0)}, "must be four finite numbers"),
    ],
)
def test_bad_intrinsics_are_refused_naming_the_field(kwargs, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        FisheyeCamera(**kwargs)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"focal_px": -1.0}, "fisheye.focal_px: must be > 0, got -1.0"),
        ({"principal_point": [600.0, 10.0]}, "fisheye.principal_point: (600.0, 10.0) is off"),
        ({"image_size": [480]}, "fisheye.image_size: must be [width, height] in pixels"),
        ({"image_size": [480.5, 480]}, "fisheye.image_size[0]: must be an integer in [1, 4096]"),
        ({"image_size": [480, True]}, "fisheye.image_size[1]: must be an integer in [1, 4096]"),
        ({"image_size": [200_000, 200_000]},
         "fisheye.image_size[0]: must be an integer in [1, 4096], got 200000"),
        ({"focal_px": 1e300}, "fisheye.focal_px: must be in [-100000, 100000], got 1e+300"),
        ({"distortion": [-0.5, 0.0, 0.0, 0.0]}, "fisheye.distortion: (-0.5, 0.0, 0.0, 0.0) makes"),
        ({"focal": 150.0}, "fisheye: unknown key 'focal'. Did you mean 'focal_px'?"),
    ],
)
def test_bad_fisheye_sections_are_reported_with_file_and_field(table, message):
    from azgym import ScenarioError
    from azgym.site import parse_scenario

    data = {"name": "cam", "description": "camera test", "version": 1,
            "room": {"bounds": [0.0, 0.0, 10.0, 10.0]}, "fisheye": table,
            "beacons": [{"id": k, "xy": [float(k), 0.0]} for k in range(3)]}
    with pytest.raises(ScenarioError, match=re.escape(f"cam.toml: {message}")):
        parse_scenario(data, "cam.toml")


def test_scenarios_carry_a_fisheye_camera():
    from azgym import load_scenario

    camera = load_scenario("warehouse-small").fisheye
    assert camera.image_size == (480, 480) and camera.horizon_radius_px > 0

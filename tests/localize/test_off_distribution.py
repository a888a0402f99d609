"""learned and ng-ransac off their training distribution: refused with the reason, not answered.

The shipped models were trained on all-round cameras in generated warehouses at Δα_d = 0.4°.
They used to answer a narrow forward view metres off (a fifth of MRCLAM's snapshots), and
ng-ransac's network took a 2-4° camera's good azimuths for outliers (it refused two thirds of
Roh's frames).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame, pose_error_of

import azgym
from azgym import Measurements
from azgym.errors import ModelFileError
from azgym.localize.learned.distribution import GENERATED_WAREHOUSES, TrainingDistribution
from azgym.localize.learned.features import CONSENSUS_TOLERANCE
from azgym.localize.learned.ng_ransac import SHIPPED_WEIGHTS as NG_WEIGHTS
from azgym.localize.learned.pose_regression import SET_GATE, Learned
from azgym.localize.learned.pose_regression import SHIPPED_WEIGHTS as LEARNED_WEIGHTS
from azgym.localize.learned.weights import load_weights

LEARNED = ("learned", "ng-ransac")
ROOM = beacon_map([(0.0, 0.0), (6.0, 0.0), (6.0, 6.0), (0.0, 6.0), (3.0, 7.0), (7.0, 3.0),
                   (-1.0, 3.0), (3.0, -1.0)])
INSIDE = [(1.5, 1.5, 0.3), (3.0, 4.5, 2.0), (4.5, 3.0, -1.2), (2.2, 2.9, 3.0)]


def forward_view(x: float, y: float, heading: float, half_view: float) -> Measurements:
    """The beacons a forward camera of ±``half_view`` sees from the pose, noise-free."""
    frame = ideal_frame(x, y, heading, ROOM)
    ahead = np.abs(frame.azimuth) <= half_view
    return Measurements(frame.ids[ahead], frame.azimuth[ahead])


def noisy(frame: Measurements, half_width: float, rng: np.random.Generator) -> Measurements:
    """Eq. 1's uniform centre-detection error of half-width ``half_width`` added."""
    azimuth = frame.azimuth + rng.uniform(-half_width, half_width, len(frame))
    return Measurements(frame.ids, np.angle(np.exp(1j * azimuth)))


@pytest.mark.parametrize("name", LEARNED)
@pytest.mark.parametrize(("x", "y", "heading"), INSIDE)
def test_in_distribution_frames_are_still_answered(name, x, y, heading):
    estimate = azgym.make_localizer(name).localize(ideal_frame(x, y, heading, ROOM), ROOM)
    assert estimate.ok, estimate.reason
    assert pose_error_of(estimate, x, y, heading)[0] < 0.01
    assert "off_distribution" not in estimate.diagnostics


@pytest.mark.parametrize("name", LEARNED)
def test_a_stated_narrow_field_of_view_is_refused_with_the_reason(name):
    # A 68° forward camera (MRCLAM's): 99 % of the training frames span over 120°.
    frame = forward_view(-3.0, 3.0, 0.0, math.radians(34.0))
    assert len(frame) >= 3
    estimate = azgym.make_localizer(name, field_of_view=math.radians(68.0)).localize(frame, ROOM)
    assert not estimate.ok
    assert estimate.reason.startswith("off the model's training distribution: field_of_view "
                                      "68° is narrower than the azimuth spread of 99% of the "
                                      "training frames (12")
    assert estimate.diagnostics["off_distribution"] is True
    wide = azgym.make_localizer(name, field_of_view=2 * math.pi)
    assert wide.localize(ideal_frame(1.5, 1.5, 0.3, ROOM), ROOM).ok


@pytest.mark.parametrize("name", LEARNED)
def test_a_frame_narrower_than_any_training_frame_is_refused(name):
    # Three beacons within 5°, seen from far off: no training frame was this narrow.
    beacons = beacon_map([(20.0, -0.4), (20.5, 0.0), (20.0, 0.4), (0.0, 10.0)])
    frame = ideal_frame(0.0, 0.0, 0.0, beacons)
    near = np.abs(frame.azimuth) < 0.1
    estimate = azgym.make_localizer(name).localize(
        Measurements(frame.ids[near], frame.azimuth[near]), beacons)
    assert not estimate.ok
    assert "the azimuths span 2.29°, narrower than any training frame's" in estimate.reason


@pytest.mark.parametrize("name", LEARNED)
@pytest.mark.parametrize("degrees", [0.0, 20.0])
def test_a_noise_outside_the_served_range_is_refused(name, degrees):
    estimate = azgym.make_localizer(name, delta_alpha_d=math.radians(degrees)).localize(
        ideal_frame(1.5, 1.5, 0.3, ROOM), ROOM)
    assert not estimate.ok
    assert f"delta_alpha_d {degrees:.3g}° is outside the noise the model was trained for " \
           "(0.1°-12°)" in estimate.reason


@pytest.mark.parametrize("name", LEARNED)
def test_fewer_beacons_than_training_had_is_refused(name):
    localizer = azgym.make_localizer(name)
    localizer._distribution = dataclasses.replace(localizer._distribution, min_beacons=5)
    every = ideal_frame(1.5, 1.5, 0.3, ROOM)
    assert localizer.localize(every, ROOM).ok  # all eight in view
    four = Measurements(every.ids[:4], every.azimuth[:4])
    refused = localizer.localize(four, ROOM)
    assert not refused.ok and refused.diagnostics["off_distribution"]
    assert "4 beacons in view, fewer than any training frame had (5)" in refused.reason


@pytest.mark.parametrize("name", LEARNED)
def test_a_noisy_camera_stated_is_answered_as_well_as_ransac(name):
    # Roh's rig: 4 beacons round the camera, eq. 1's noise 3.8° (2.2° standard deviation).
    # ng-ransac's network used to score these good azimuths as outliers and refuse the frame.
    corners = beacon_map([(0.0, 0.0), (6.0, 0.0), (6.0, 6.0), (0.0, 6.0)])
    rng = np.random.default_rng(5)
    half_width = math.radians(3.8)
    localizer = azgym.make_localizer(name, delta_alpha_d=half_width, coverage=False)
    ransac = azgym.make_localizer("ransac", delta_alpha_d=half_width, coverage=False)
    answered, errors, reference = 0, [], []
    for k in range(60):
        x, y = 1.5 + 1.5 * (k % 3), 1.5 + 1.5 * (k // 3 % 3)
        frame = noisy(ideal_frame(x, y, math.pi / 2, corners), half_width, rng)
        estimate = localizer.localize(frame, corners)
        answered += estimate.ok
        if estimate.ok:
            errors.append(pose_error_of(estimate, x, y, math.pi / 2)[0])
        reference.append(pose_error_of(ransac.localize(frame, corners), x, y, math.pi / 2)[0])
    assert answered == 60
    assert np.median(errors) <= 1.1 * np.median(reference)


def test_the_shipped_weights_record_their_training_distribution():
    for path, model in ((LEARNED_WEIGHTS, "learned"), (NG_WEIGHTS, "ng-ransac")):
        distribution = TrainingDistribution.of_manifest(load_weights(path, model)[1])
        assert distribution.trained_delta_alpha_d == math.radians(0.4)
        assert math.radians(115.0) < distribution.view_spread < math.radians(130.0)
        assert math.radians(5.0) < distribution.min_azimuth_spread < math.radians(10.0)
        assert distribution.min_beacons == 3
        assert distribution.delta_alpha_d == GENERATED_WAREHOUSES.delta_alpha_d


def test_a_weight_file_without_a_record_stands_for_the_generated_warehouses():
    assert TrainingDistribution.of_manifest({"training": {"data": {}}}) is GENERATED_WAREHOUSES
    with pytest.raises(ModelFileError, match="manifest field 'distribution' is not a training"):
        TrainingDistribution.of_manifest({"training": {"data": {"distribution": {"x": 1}}}})
    bad = GENERATED_WAREHOUSES.to_manifest() | {"delta_alpha_d": [0.2, 0.1]}
    with pytest.raises(ModelFileError, match="impossible values"):
        TrainingDistribution.of_manifest({"training": {"data": {"distribution": bad}}})


def test_learned_gate_defaults_to_the_consensus_tolerance_scaled_with_the_noise():
    assert Learned()._settings[SET_GATE] == CONSENSUS_TOLERANCE  # 1° at the training noise
    assert Learned(delta_alpha_d=math.radians(2.0))._settings[SET_GATE] == pytest.approx(
        5 * CONSENSUS_TOLERANCE)
    assert Learned(gate=0.01, delta_alpha_d=math.radians(2.0))._settings[SET_GATE] == 0.01

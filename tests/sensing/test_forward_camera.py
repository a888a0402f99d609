"""A robot's sensors: a forward camera's view, markers the map lacks, odometry a logger stamps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.errors import InvalidInputError
from azgym.sensing.catalog import make_sensor
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.sensing.labels import DIRECT, DISTRACTOR
from azgym.sensing.motion import DifferentialOdometer, DifferentialOdometryModel
from azgym.site import parse_scenario


def ring(view_deg: float = 60.0, max_range: float = 5.0):
    """Landmarks every 10° round the origin at 2 m, and one unmapped marker dead ahead at 1 m."""
    beacons = [{"id": k + 1, "xy": [2.0 * math.cos(math.radians(10 * k)),
                                    2.0 * math.sin(math.radians(10 * k))]} for k in range(36)]
    return parse_scenario({
        "name": "ring", "description": "landmarks round the robot", "version": 1,
        "room": {"bounds": [-3.0, -3.0, 3.0, 3.0]},
        "vehicle": {"kind": "differential-drive"},
        "error_model": {"delta_alpha_d_deg": 0.5, "coverage": False},
        "camera": {"height": 0.4, "min_elevation_deg": -30.0, "max_range": max_range,
                   "field_of_view_deg": view_deg},
        "beacon_defaults": {"z": 0.4, "width": 0.1},
        "beacons": beacons, "unmapped": [{"id": 99, "xy": [1.0, 0.0]}]})


@pytest.mark.parametrize("heading", [0.0, 1.0, -2.5, math.pi])
def test_a_forward_camera_sees_only_its_view_and_everything_in_it(heading):
    scenario = ring()
    observation = GeometrySensor(scenario).observe((0.0, 0.0, heading), np.random.default_rng(1))
    measured = observation.measurements
    assert (np.abs(measured.azimuth) <= math.radians(30.0)).all()
    mapped = measured.ids[measured.ids != 99]
    # Every landmark whose true bearing is inside the view by more than the noise is seen.
    bearings = np.angle(np.exp(1j * (np.radians(10 * (mapped - 1)) - heading)))
    assert (np.abs(bearings) <= math.radians(30.5)).all()
    inside = [k + 1 for k in range(36) if abs(math.remainder(math.radians(10 * k) - heading,
                                                             2 * math.pi)) < math.radians(29.4)]
    assert set(inside) <= set(mapped.tolist())
    assert np.all(np.diff(measured.azimuth) >= 0)  # still listed by azimuth


def test_an_all_round_camera_sees_the_whole_ring():
    observation = GeometrySensor(ring(360.0)).observe((0.0, 0.0, 0.3), np.random.default_rng(1))
    assert len(observation.measurements) == 37


def test_a_marker_the_map_lacks_reports_its_code_with_a_distractors_truth():
    observation = GeometrySensor(ring()).observe((0.0, 0.0, 0.0), np.random.default_rng(2))
    ids, truth = observation.measurements.ids, observation.truth
    marker = int(np.flatnonzero(ids == 99)[0])
    assert truth.label[marker] == DISTRACTOR and truth.beacon[marker] == -1
    others = np.flatnonzero(ids != 99)
    assert (truth.label[others] == DIRECT).all()
    assert (ring().beacons.ids[truth.beacon[others]] == ids[others]).all()


def test_range_limits_a_forward_camera_too():
    observation = GeometrySensor(ring(max_range=1.5)).observe((0.0, 0.0, 0.0),
                                                             np.random.default_rng(1))
    assert observation.measurements.ids.tolist() == [99]


def test_the_image_sensor_refuses_a_forward_camera():
    with pytest.raises(InvalidInputError, match="forward camera .* use sensor=\"geometry\""):
        make_sensor(ring(), "image")


def odometry(model: DifferentialOdometryModel, seconds: float = 60.0, seed: int = 0):
    """The samples of ``seconds`` at 0.4 m/s and 0.3 rad/s, stepped every 10 ms."""
    odometer = DifferentialOdometer(model, np.random.default_rng(seed))
    for step in range(1, round(seconds / 0.01) + 1):
        odometer.update(step * 0.01, 0.4, 0.3)
    return odometer.take()


def test_the_odometry_is_stamped_as_a_busy_logger_stamps_it():
    samples = odometry(DifferentialOdometryModel())
    intervals = np.diff(samples.time)
    assert samples.reports_yaw_rate and np.isnan(samples.steer).all()
    assert samples.time[0] > 0 and (intervals >= 0).all()
    assert np.median(intervals) == pytest.approx(0.010, abs=1e-9)
    assert 0.2 < np.mean((intervals >= 0.02) & (intervals <= 0.05)) < 0.3
    assert 0.01 < np.mean(intervals == 0) < 0.05  # repeated stamps
    assert 1 <= np.count_nonzero(intervals > 0.1) <= 30  # occasional gaps
    ticks = samples.time / 0.001
    assert np.allclose(ticks, np.round(ticks), atol=1e-6)  # millisecond stamps


def test_exact_odometry_reads_the_velocity_and_a_noisy_one_errs_as_modelled():
    exact = DifferentialOdometryModel(speed_factor=1.0, speed_scale=0.0, speed_noise=0.0,
                                      turn_rate_noise=0.0, turn_rate_bias=0.0, bias_walk=0.0)
    samples = odometry(exact)
    assert (samples.speed == 0.4).all() and (samples.yaw_rate == 0.3).all()
    noisy = [odometry(DifferentialOdometryModel(), 30.0, seed) for seed in range(20)]
    scale = np.array([np.mean(s.speed) / 0.4 for s in noisy])
    assert np.mean(scale) == pytest.approx(1 / 1.1, abs=0.01)  # reads about 9 % short
    bias = np.array([np.mean(s.yaw_rate) - 0.3 for s in noisy])
    assert 0.005 < np.std(bias) < 0.03  # a bias of its own per run


@pytest.mark.parametrize(("change", "field"), [
    ({"period": 0.0}, "period must be > 0"),
    ({"period_jitter": 0.02}, "period_jitter must be less than its period"),
    ({"busy_share": 0.7, "gap_share": 0.2, "repeat_share": 0.2}, "must be >= 0 and sum to < 1"),
    ({"gap": (0.3, 0.1)}, "gap must be a range"),
    ({"turn_rate_noise": -1.0}, "turn_rate_noise must be >= 0"),
    ({"speed_factor": math.nan}, "speed_factor must be > 0"),
])
def test_a_bad_odometry_model_is_named(change, field):
    with pytest.raises(InvalidInputError, match=f"DifferentialOdometryModel.*{field}"):
        DifferentialOdometryModel(**change)

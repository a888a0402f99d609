"""The survey: the bearing factor and the observability rule by hand; a drive with known answer."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from azgym.core import Measurements
from azgym.errors import InvalidInputError
from azgym.localize.bearings import MIN_SPREAD, intersect_robustly, spread
from azgym.mapping import Drive, Prior, Settings, SurveyFrame, simulated_drive, survey
from azgym.mapping.factors import odometry_error
from azgym.mapping.first_guess import first_guess
from azgym.mapping.graph import Graph, residuals
from azgym.mapping.moves import MIN_MOVE
from azgym.mapping.odometry import COVARIANCE_FLOOR, compose, relative_poses
from azgym.mapping.survey import MAX_STRAIN, _strain
from azgym.sensing.motion import DifferentialOdometryModel, ImuSamples, Motion, OdometrySamples
from azgym.site import load_scenario
from azgym.world.drive import simulate

gtsam = pytest.importorskip("gtsam")


def test_import_azgym_leaves_gtsam_alone() -> None:
    import subprocess

    code = "import azgym, azgym.mapping, sys; print('gtsam' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize(("pose", "jacobian"), [
    # camera at the origin facing east, beacon at (3, 4): local point (3, 4), r² = 25;
    # d/dδx = ly/r², d/dδy = −lx/r², d/dδφ = −1; d/d(point) = (−dy, dx)/r² in the world.
    ((0.0, 0.0, 0.0), [0.16, -0.12, -1.0, -0.16, 0.12]),
    # at (1, 2) facing 0.5 rad, beacon at (4, 6): the local point is R(−0.5) (3, 4).
    ((1.0, 2.0, 0.5), [(-3 * math.sin(0.5) + 4 * math.cos(0.5)) / 25,
                       -(3 * math.cos(0.5) + 4 * math.sin(0.5)) / 25, -1.0, -0.16, 0.12]),
])
def test_bearing_factor_by_hand(pose: tuple[float, float, float], jacobian: list[float]) -> None:
    """The bearing factor is azgym's azimuth α = atan2(dy, dx) − φ; residual and Jacobian."""
    measured = 0.4
    point = np.array([pose[0] + 3.0, pose[1] + 4.0])
    factor = gtsam.BearingFactor2D(1, 2, gtsam.Rot2(measured),
                                   gtsam.noiseModel.Isotropic.Sigma(1, 1.0))
    values = gtsam.Values()
    values.insert(1, gtsam.Pose2(*pose))
    values.insert(2, gtsam.Point2(*point))
    predicted = math.atan2(4.0, 3.0) - pose[2]
    assert factor.unwhitenedError(values)[0] == pytest.approx(predicted - measured, abs=1e-12)
    a, _ = factor.linearize(values).jacobian()
    np.testing.assert_allclose(a[0], jacobian, atol=1e-12)
    # azgym's residual (measured − predicted) is GTSAM's error with the other sign
    graph = Graph(poses=np.array([pose]), links=np.zeros((0, 2), np.int64),
                  moves=np.zeros((0, 3)), move_cov=np.zeros((0, 3, 3)),
                  move_jac=np.zeros((0, 3, 2)), walks=np.zeros((0, 2)),
                  sensor_std=np.ones(2), starts=np.zeros(0, np.int64),
                  start_poses=np.zeros((0, 3)), beacons=point[None],
                  anchors=np.zeros(0, np.int64), priors=np.zeros(0, np.int64),
                  prior_xy=np.zeros((0, 2)), rows=np.array([[0, 0]]),
                  azimuths=np.array([measured]), sigmas=np.array([1.0]))
    assert residuals(np.array([pose]), point[None], graph)[0] == \
        pytest.approx(measured - predicted, abs=1e-12)


def test_odometry_factor_by_hand() -> None:
    """Δ = move + J (b, k); the error is Δ⁻¹ first⁻¹ second in Δ's frame; its derivatives with
    respect to the poses GTSAM's own between factor's for Δ, to (b, k) finite differences'."""
    move = np.array([1.0, 0.0, 0.0])
    jacobian = np.array([[0.0, 1.0], [0.0, 0.0], [-0.1, 0.0]])  # k scales x, b turns by -0.1 b
    sensors = np.array([0.5, 0.1])  # Δ = (1.1, 0, -0.05)
    first, second = gtsam.Pose2(0.0, 0.0, 0.0), gtsam.Pose2(1.0, 0.2, -0.05)
    error, (d_first, d_second, d_sensors) = odometry_error(gtsam, first, second, sensors, move,
                                                           jacobian)
    # second in Δ's frame: (1 − 1.1, 0.2) turned by +0.05, no turn left (so Logmap is itself)
    c, s = math.cos(0.05), math.sin(0.05)
    np.testing.assert_allclose(error, [-0.1 * c - 0.2 * s, -0.1 * s + 0.2 * c, 0.0],
                               atol=1e-12)
    step = 1e-6
    for n in range(2):
        nudged = sensors + step * np.eye(2)[n]
        ahead = odometry_error(gtsam, first, second, nudged, move, jacobian)[0]
        # GTSAM's Pose2 chart derivatives are first-order in the turn (here 0.15 rad apart):
        # its own between factor's differ from finite differences by as much
        np.testing.assert_allclose((ahead - error) / step, d_sensors[:, n], atol=1e-4)
    between = gtsam.BetweenFactorPose2(1, 2, gtsam.Pose2(1.1, 0.0, -0.05),
                                       gtsam.noiseModel.Unit.Create(3))
    values = gtsam.Values()
    values.insert(1, first)
    values.insert(2, second)
    a, b = between.linearize(values).jacobian()
    np.testing.assert_allclose(-b, error, atol=1e-12)
    np.testing.assert_allclose(a, np.hstack([d_first, d_second]), atol=1e-12)


def test_relative_pose_and_its_sensor_derivatives_by_hand() -> None:
    """A differential drive (camera over the axle) at 1 m/s, not turning, for 0.1 s: the move is
    (0.1, 0, 0); a bias b turns it by −0.1 b and, at the step's midpoint heading, moves it by
    −0.5 · 0.1 · 0.1 b sideways; a scale error k lengthens it by 0.1 k; neither counted in its
    covariance, whose heading variance is the turn-rate noise's σ² Σ hold² + the model's."""
    times = np.arange(0.0, 0.1001, 0.01)
    frames = []
    for start, end in ((0, 1), (1, len(times))):
        t = times[start:end]
        odometry = OdometrySamples.turning(t, np.ones(t.size), np.zeros(t.size))
        frames.append(SurveyFrame(float(t[-1]), Measurements([], []),
                                  Motion(float(t[-1]), odometry, ImuSamples.none())))
    settings = Settings(vehicle="differential-drive", camera_ahead=0.0)
    found = relative_poses(Drive(tuple(frames), (0.0, 0.0, 0.0)), settings)
    np.testing.assert_allclose(found.moves[0], [0.1, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(found.jacobians[0], [[0.0, 0.1], [-0.005, 0.0], [-0.1, 0.0]],
                               atol=1e-12)
    noise = settings.noise
    heading = noise.turn_rate_noise**2 * 10 * 0.01**2 + noise.heading_walk**2 * 0.1
    assert found.covariances[0, 2, 2] == pytest.approx(heading + COVARIANCE_FLOOR[2], rel=1e-9)
    np.testing.assert_allclose(found.walks[0], [noise.bias_walk * math.sqrt(0.1),
                                                noise.scale_walk * math.sqrt(0.1)], rtol=1e-9)


def test_strain_is_the_agreeing_azimuths_mean_squared_residual_in_their_variance() -> None:
    """Residuals of ±1 and ±1.5 σ average (1 + 2.25) / 2 = 1.625 times the variance: strained;
    ±0.5 σ average 0.25: not; no agreeing azimuth: not."""
    assert "average 1.62 times" in _strain(np.array([1.0, -1.0, 1.5, -1.5]))
    assert _strain(np.array([0.5, -0.5])) == ""
    assert _strain(np.zeros(0)) == ""
    assert MAX_STRAIN == 1.0


def test_spread_of_two_rays_is_their_angle() -> None:
    """λ = sin²(Δ/2) for two rays Δ apart, so the spread 2 asin √λ gives Δ back."""
    for angle in (0.0, 0.05, MIN_SPREAD, 1.0, math.pi / 2):
        assert spread(np.array([0.3, 0.3 + angle])) == pytest.approx(angle, abs=1e-9)
    assert spread(np.array([0.3, 0.3 + math.pi])) == pytest.approx(0.0, abs=1e-7)  # one line


def test_observability_threshold_and_the_covariance_along_the_rays() -> None:
    """The position along the rays' mean direction: variance ∝ 1 / sin²(Δ/2); narrow refused."""
    beacon = np.array([10.0, 0.0])
    for angle in (0.2, 0.4):
        origins = np.array([[0.0, 0.0], [0.0, 0.0]])
        directions = np.array([-angle / 2, angle / 2])
        # rays from two places seeing the beacon at ±angle/2
        origins = beacon - 10.0 * np.column_stack([np.cos(directions), np.sin(directions)])
        normals = np.column_stack([-np.sin(directions), np.cos(directions)])
        information = normals.T @ normals
        along = np.linalg.inv(information)[0, 0]
        assert along == pytest.approx(1.0 / (2 * math.sin(angle / 2) ** 2), rel=1e-9)
        point, _ = intersect_robustly(origins, directions)
        np.testing.assert_allclose(point, beacon, atol=1e-9)
    poses = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]])
    narrow = np.arctan2(0.0 - poses[:, 1], 20.0 - poses[:, 0]) + 0.001 * np.arange(3)
    point, reason = first_guess(poses, narrow)
    assert np.isnan(point).all() and "too narrow a baseline" in reason


def test_compose_is_dead_reckoning() -> None:
    poses = compose(np.array([1.0, 1.0, math.pi / 2]), np.array([[1.0, 0.0, math.pi / 2]] * 2))
    np.testing.assert_allclose(poses[-1], [0.0, 2.0, -math.pi / 2], atol=1e-12)


@pytest.fixture(scope="module")
def aisle_loop() -> tuple:
    scenario = load_scenario("warehouse-small")
    frames = list(simulate(scenario, "aisle-loop", seed=3))
    return scenario, frames


def test_survey_recovers_a_known_map(aisle_loop: tuple) -> None:
    """A simulated drive from a known start with two anchors: every beacon within centimetres,
    the beacon moved after the map was made found moved, its true place surveyed."""
    scenario, frames = aisle_loop
    prior = Prior(scenario.beacons, (1, 2))
    result = survey(simulated_drive(frames, frames[0].pose), prior)
    truth = {int(i): scenario.beacon_positions[k, :2] for k, i in enumerate(scenario.beacons.ids)}
    errors = [math.dist(result.xy[b], truth[i]) for b, i in enumerate(result.ids.tolist())
              if result.observable[b] and i not in prior.anchors]
    assert len(errors) >= 12
    assert np.median(errors) < 0.03 and max(errors) < 0.10
    assert result.moved == (9,)  # moved 1.5 m after the map was made (MIN_MOVE far less)
    assert 1.5 > MIN_MOVE
    sigma = np.sqrt(result.covariances[result.observable][:, [0, 1], [0, 1]])
    assert (sigma < 0.05).all() and (sigma > 0).all()
    assert survey(simulated_drive(frames, frames[0].pose), prior).xy.tobytes() == \
        result.xy.tobytes()  # deterministic


def test_start_bias_is_checked() -> None:
    with pytest.raises(InvalidInputError, match="start_bias must be a number >= 0"):
        Settings(start_bias=-0.01)
    assert Settings(start_bias=0.02).turn_rate_bias == 0.02
    assert Settings(vehicle="differential-drive").turn_rate_bias == \
        DifferentialOdometryModel().turn_rate_bias


def test_huber_is_a_choice(aisle_loop: tuple) -> None:
    scenario, frames = aisle_loop
    result = survey(simulated_drive(frames[:200], frames[0].pose), Prior(scenario.beacons, (1, 2)),
                    Settings(loss="huber"))
    assert result.observable.any()

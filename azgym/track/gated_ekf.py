"""``gated-ekf``: an extended Kalman filter on raw azimuths, each gated by its Mahalanobis distance.

The filter follows the camera pose, the turn rate's bias and the odometry's scale error
(:mod:`azgym.track.unicycle`): each frame it predicts with the odometry's speed and the turn rate
(a forklift's gyro, a differential drive's odometry: ``vehicle`` and ``yaw_source``), then
corrects with the frame's
azimuths that pass the chi-square gate and then agree with each other (a leave-one-out test: a
moved beacon passes the gate of a wide prediction, not the test against the beacons beside it;
both in :mod:`azgym.track.azimuth_update`). It starts from the pose given to ``reset`` or, without
one, from the first frame a per-frame localizer (ransac or loo) solves, with that fix's
covariance; until then it answers ``ok=False``. This is the textbook filter: once started it
never doubts itself. :class:`~azgym.track.robust.Robust` adds
hold-over limits and relocalization on top.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

from azgym.core import BeaconMap, Estimate, FloatArray, IntArray, Measurements, Pose, wrap_scalar
from azgym.hyperparameters import check_flag, check_range
from azgym.localize.base import ROW_BEACON_INDEX, ROW_SOURCE, Problem
from azgym.localize.registry import build
from azgym.profile import FORKLIFT, VEHICLE_KINDS
from azgym.sensing.motion import ImuModel, Motion, OdometryModel
from azgym.site.error_model import check_azimuth_noise
from azgym.track.azimuth_update import gated_update
from azgym.track.base import Tracker, check_choice
from azgym.track.kinematics import WHEELBASE
from azgym.track.unicycle import (
    IBIAS,
    IPHI,
    ISCALE,
    IX,
    IY,
    STATE_SIZE,
    VEHICLE_DEFAULTS,
    YAW_SOURCES,
    MotionNoise,
    MotionSteps,
)

__all__ = ["DEFAULT_NOISE", "GatedEkf", "subset"]

INITIALIZERS = ("ransac", "loo")
"""The per-frame localizers a tracker may start from."""
INITIAL_STD = (0.05, 0.05, math.radians(1.0))
"""Floor on the standard deviations of a start pose (x, y [m], heading [rad]): a per-frame
fix's covariance assumes its inliers are clean, and a pose given to ``reset`` is never exact."""
DEFAULT_PERIOD = 1.0 / OdometryModel().rate_hz
"""Sample period assumed for a motion stream until its samples show their own [s]."""
DEFAULT_NOISE = MotionNoise()
"""The motion noise a tracker assumes by default: the simulated forklift's sensors."""


class GatedEkf(Tracker):
    """An EKF on raw azimuths, gated one by one and then leave-one-out (module docstring).

    Every hyperparameter a sensor, vehicle and motion profile sets has its name
    (:mod:`azgym.profile`).

    Args:
        gate_probability: Share of good azimuths the gate lets through: the threshold is the
            chi-square quantile (one degree of freedom) of this probability, for the gate and
            for the leave-one-out test alike.
        delta_alpha_d: Δα_d, half-width of the centre-detection error [rad] (eq. 1).
        coverage: Whether the azimuth noise includes eq. 2's coverage term (half a beacon's
            width seen from the camera).
        extra_sigma: Azimuth noise beyond the error model (camera sway, rendering) [rad].
        vehicle: ``"forklift"`` or ``"differential-drive"``: what turns the vehicle and where
            the camera sits by default.
        yaw_source: Where the turn rate comes from: ``"gyro"`` (the IMU) or ``"odometry"`` (a
            reported ``yaw_rate``, or a forklift's speed · tan(steer) / ``wheelbase``); None:
            the vehicle's (:data:`VEHICLE_DEFAULTS`).
        camera_ahead: The camera's offset ahead of the turning axis [m] (negative: behind it);
            None: the vehicle's.
        wheelbase: A forklift's wheelbase [m] (its turn rate from the steering angle).
        speed_factor: True over read distance of the odometry [1].
        speed_noise: White noise of one odometry speed sample [m/s].
        speed_scale: Standard deviation of the odometry's scale error at the start [1].
        scale_walk: Random walk of that scale error [1/√s].
        turn_rate_noise: White noise of one turn-rate sample [rad/s].
        bias_walk: Random walk of the turn rate's bias [rad/s/√s].
        heading_walk: Model error of the heading [rad/√s].
        position_walk: Model error of the position [m/√s].
        initializer: The per-frame localizer that gives the first fix: "ransac" or "loo".
        min_init_inliers: Fewest inliers a first fix needs.
    """

    name = "gated-ekf"

    def __init__(self, *, gate_probability: float = 0.999,
                 delta_alpha_d: float = math.radians(0.4), coverage: bool = True,
                 extra_sigma: float = math.radians(0.1), vehicle: str = FORKLIFT,
                 yaw_source: str | None = None, camera_ahead: float | None = None,
                 wheelbase: float = WHEELBASE, speed_factor: float = 1.0,
                 speed_noise: float = DEFAULT_NOISE.speed_noise,
                 speed_scale: float = DEFAULT_NOISE.speed_scale,
                 scale_walk: float = DEFAULT_NOISE.scale_walk,
                 turn_rate_noise: float = DEFAULT_NOISE.turn_rate_noise,
                 bias_walk: float = DEFAULT_NOISE.bias_walk,
                 heading_walk: float = DEFAULT_NOISE.heading_walk,
                 position_walk: float = DEFAULT_NOISE.position_walk, initializer: str = "ransac",
                 min_init_inliers: int = 4) -> None:
        self.gate_probability = gate_probability
        self.delta_alpha_d = delta_alpha_d
        self.coverage = coverage
        self.extra_sigma = extra_sigma
        self.vehicle = vehicle
        self.yaw_source = yaw_source
        self.camera_ahead = camera_ahead
        self.wheelbase = wheelbase
        self.speed_factor = speed_factor
        self.speed_noise = speed_noise
        self.speed_scale = speed_scale
        self.scale_walk = scale_walk
        self.turn_rate_noise = turn_rate_noise
        self.bias_walk = bias_walk
        self.heading_walk = heading_walk
        self.position_walk = position_walk
        self.initializer = initializer
        self.min_init_inliers = min_init_inliers
        self._validate_once()

    def _check_params(self) -> None:
        name = type(self).__name__
        check_range(name, "gate_probability", self.gate_probability, low=0.0, high=1.0,
                    low_open=True, high_open=True)
        check_range(name, "delta_alpha_d", self.delta_alpha_d, low=0.0, high=math.pi / 2,
                    high_open=True)
        check_flag(name, "coverage", self.coverage)
        check_range(name, "extra_sigma", self.extra_sigma, low=0.0, high=math.pi / 2)
        check_choice(name, "vehicle", self.vehicle, VEHICLE_KINDS)
        if self.yaw_source is not None:
            check_choice(name, "yaw_source", self.yaw_source, YAW_SOURCES)
        if self.camera_ahead is not None:
            check_range(name, "camera_ahead", self.camera_ahead, low=-10.0, high=10.0)
        check_range(name, "wheelbase", self.wheelbase, low=0.0, low_open=True)
        check_range(name, "speed_factor", self.speed_factor, low=0.0, low_open=True)
        for field in ("speed_noise", "speed_scale", "scale_walk", "turn_rate_noise",
                      "bias_walk", "heading_walk", "position_walk"):
            check_range(name, field, getattr(self, field), low=0.0)
        check_range(name, "min_init_inliers", self.min_init_inliers, low=3, integer=True)
        check_choice(name, "initializer", self.initializer, INITIALIZERS)
        check_azimuth_noise(name, self.delta_alpha_d, self.extra_sigma)
        self._threshold = NormalDist().inv_cdf(0.5 + 0.5 * self.gate_probability) ** 2
        coverage = {"coverage": self.coverage} if self.initializer == "ransac" else {}
        self._localizer = build(self.initializer, delta_alpha_d=self.delta_alpha_d, **coverage)
        self._noise = MotionNoise(
            speed_noise=self.speed_noise, speed_scale=self.speed_scale,
            scale_walk=self.scale_walk, turn_rate_noise=self.turn_rate_noise,
            bias_walk=self.bias_walk, position_walk=self.position_walk,
            heading_walk=self.heading_walk)
        yaw_source, lever = VEHICLE_DEFAULTS[self.vehicle]
        self._yaw_source = yaw_source if self.yaw_source is None else self.yaw_source
        self._lever = float(lever if self.camera_ahead is None else self.camera_ahead)

    # -- the sequence ------------------------------------------------------------------------

    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        self._steps = MotionSteps(DEFAULT_PERIOD, self._yaw_source, self.vehicle,
                                  float(self.wheelbase), float(self.speed_factor))
        self._state = np.zeros(STATE_SIZE)
        self._cov = np.zeros((STATE_SIZE, STATE_SIZE))
        self._running = initial is not None
        if initial is not None:
            self._start(np.array(initial), np.diag(np.square(INITIAL_STD)))

    def _start(self, pose: np.ndarray, cov: np.ndarray) -> None:
        """Start (or restart) the filter at ``pose`` with covariance ``cov`` (3 × 3).

        Beacons kept in the state past its first :data:`STATE_SIZE` entries keep their
        positions and covariance; their ties to the old pose are cut.
        """
        self._state[:STATE_SIZE] = (pose[0], pose[1], pose[2], 0.0, 0.0)
        self._cov[:STATE_SIZE] = 0.0
        self._cov[:, :STATE_SIZE] = 0.0
        self._cov[:3, :3] = cov + np.diag(np.square(INITIAL_STD))
        self._cov[IBIAS, IBIAS] = ImuModel().gyro_bias ** 2
        self._cov[ISCALE, ISCALE] = self._noise.speed_scale ** 2
        self._running = True

    def _predict(self, motion: Motion) -> None:
        self._steps.advance(motion, self._state, self._cov, self._lever, self._noise,
                            self._running)

    def _update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        if not self._running:
            found = self._fix(measurements, beacons)
            if found is None:
                return Estimate.failure(f"not initialized: {self._why}", len(measurements))
            fix, covariance = found
            self._start(np.array(fix.pose), covariance)
            return self._estimate(fix.inliers, {"initialized": True})
        inliers, _ = self._correct(measurements, beacons)
        return self._estimate(inliers)

    # -- the steps ---------------------------------------------------------------------------

    def _fix(self, measurements: Measurements,
             beacons: BeaconMap) -> tuple[Estimate, FloatArray] | None:
        """The initializer's fix of this frame and its (finite) covariance.

        None (with ``_why`` set) if the fix is unfit.
        """
        fix = self._localizer.localize(measurements, beacons)
        if not fix.ok:
            self._why = f"{self.initializer}: {fix.reason}"
            return None
        covariance = fix.covariance
        if fix.n_inliers < self.min_init_inliers or covariance is None \
                or not np.isfinite(covariance).all():
            self._why = (f"{self.initializer}'s fix has {fix.n_inliers} inliers, fewer than "
                         f"min_init_inliers={self.min_init_inliers}, or no covariance")
            return None
        return fix, covariance

    def _correct(self, measurements: Measurements,
                 beacons: BeaconMap) -> tuple[np.ndarray, int]:
        """Gate and apply the frame's azimuths; the inlier mask (M,) and the usable count."""
        problem = Problem.from_frame(measurements, beacons)
        inliers = np.zeros(len(measurements), dtype=bool)
        if problem.size == 0:
            return inliers, 0
        passed, _ = gated_update(self._state, self._cov, problem.floats,
                                 problem.ints[ROW_BEACON_INDEX], self.delta_alpha_d,
                                 self.coverage, self.extra_sigma, self._threshold,
                                 self._state_columns(problem, beacons))
        inliers[problem.ints[ROW_SOURCE][passed]] = True
        return inliers, problem.n_distinct

    def _state_columns(self, problem: Problem, beacons: BeaconMap) -> IntArray | None:
        """Where the state keeps each measured beacon: ``gated_update``'s ``columns``.

        None here (every beacon at its map position); a tracker that keeps beacons in its
        state says where.
        """
        return None

    def _estimate(self, inliers: np.ndarray, diagnostics: dict | None = None) -> Estimate:
        state = self._state
        return Estimate._filled(float(state[IX]), float(state[IY]),
                                wrap_scalar(float(state[IPHI])), inliers, True, "",
                                self._cov[:3, :3].copy(), diagnostics or {})


def subset(measurements: Measurements, rows: np.ndarray) -> Measurements:
    """The measurements at ``rows`` (indices), their quality columns with them."""
    quality = None if measurements.quality is None else measurements.quality[rows]
    return Measurements(measurements.ids[rows], measurements.azimuth[rows], quality)


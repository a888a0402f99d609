"""Plotter's Kalman trackers (Dang et al. 2015, Sec. IV): ``tkf``, and ``lpkf`` with a low-pass IMU.

The state is the IMU's position, velocity and heading and the gyro's bias (x, y, vₓ, v_y, φ, b).
Between frames the IMU predicts it (:mod:`azgym.track.inertial_steps`): the body-frame
acceleration, turned into the world frame by the heading, integrated twice; the heading by the
gyro's yaw rate less the bias and, when the IMU has an orientation sensor
(``ImuModel.orientation_noise``), corrected by each of its readings. Plotter predicts from the
accelerometer and the orientation sensor only; azgym's IMU always has a gyro and an orientation
sensor only when asked, so the gyro carries the heading and the fixes' headings (and the sensor,
when there is one) keep it and the bias in check.

Wheel odometry can correct the velocity: each speed sample (times ``speed_factor``) observes the
velocity along the heading, with ``speed_noise``. By default (``odometry_speed`` None) it does so
when the IMU reports no accelerations (a log without them, NaN throughout, or no IMU at all),
where the odometry is all that holds the velocity: the acceleration is then taken as zero with
the variance of a vehicle's (``UNMEASURED_ACCEL_SD``) and the velocity across the heading is
observed as zero too. With the accelerometer it is left out by default: the simulated
forklift's odometry reads the commanded speed, which the body lags, and using it made tkf's p75
on warehouse-routes 4.40 cm instead of 1.87. The heading turns at the gyro's rate or, with
``yaw_source="odometry"`` (a differential drive's default), at the odometry's.

Loosely coupled: the observation is the frame's fix from a per-frame localizer (``ransac`` by
default) with its covariance (Rátosi–Simon eq. 28-33) as R, in place of Plotter's tracked key
points. The fix sees the camera, ``camera_from_imu`` ahead of the IMU, so the observation is
h(x) = (x + r cos φ, y + r sin φ, φ), linearised. A frame without a fix, or with a fix the
filter refuses as an outlier (a χ² gate on the innovation: ransac can be wrong by metres), is a
hold-over: the estimate is the prediction, with its growing covariance. After ``max_holdover``
seconds without a fix the tracker answers ``ok=False`` ("no fix for N s") until a fix passes the
gate again (which widens as the covariance grows), so a long gap never ends in a silent jump.

``lpkf`` passes the accelerations through a first-order low-pass filter (1 Hz, the paper's
Sec. IV-B) before they reach the filter. docs/plotter.md gives the gap each bridges and why the
1 Hz filter suits a hand-held phone better than a forklift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from azgym.core import BeaconMap, Estimate, FloatArray, Measurements, Pose
from azgym.errors import InvalidInputError
from azgym.hyperparameters import check_flag, check_range
from azgym.localize.base import Localizer
from azgym.localize.registry import SupportsLocalize, build
from azgym.profile import FORKLIFT, VEHICLE_KINDS
from azgym.sensing.motion import ImuModel, Motion, OdometryModel
from azgym.track.base import Tracker, check_choice
from azgym.track.inertial_steps import (
    ACCEL_VAR,
    BIAS_WALK_VAR,
    HEADING,
    HEADING_VAR,
    LOW_PASS_RC,
    NOISE_SIZE,
    SIZE,
    SPEED_FACTOR,
    SPEED_VAR,
    UNMEASURED_ACCEL_VAR,
    YAW_RATE_VAR,
    camera_estimate,
    fix_update,
    new_held,
    predict_samples,
)
from azgym.track.kinematics import CAMERA_FROM_IMU, WHEELBASE, odometry_yaw_rates
from azgym.track.unicycle import VEHICLE_DEFAULTS, YAW_SOURCES

__all__ = ["Lpkf", "Tkf"]

CHI2_3DOF_999 = 16.27
"""The 99.9 % point of χ² with 3 degrees of freedom: a fix this far off (x, y, φ) is an outlier."""
FALLBACK_FIX_SD = (0.1, 0.1, math.radians(2.0))
"""Standard deviations (x, y, φ) [m, m, rad] of a fix whose localizer gives no covariance."""
_FALLBACK_FIX_COVARIANCE = np.diag(np.square(FALLBACK_FIX_SD))
START_SD = (0.05, 0.05, 0.05, 0.05, math.radians(1.0))
"""Uncertainty of a start pose given to ``reset`` (x, y [m], vₓ, v_y [m/s], φ [rad]): a forklift
at its dock, at rest, trusted without a fix to confirm it."""
GYRO_BIAS_SD = 0.01
"""Prior uncertainty of the gyro's bias [rad/s] (azgym's default IMU draws it with 0.005)."""
GYRO_BIAS_WALK = 1e-3
"""How fast the bias may wander by default [rad/s/√s] (the default IMU's walks at 1e-4)."""
UNMEASURED_ACCEL_SD = 1.0
"""Standard deviation of the acceleration [m/s²] when the IMU reports none: a vehicle's."""
_POSE = np.array([0, 1, HEADING])
_GYRO_YAW = np.zeros(0)
"""The odometry's turn rates when the turn rate is the gyro's: unused."""
FIX_START_SPEED_SD = 1.0
"""Velocity uncertainty [m/s] when a fix starts the filter: the forklift may be moving."""


@dataclass(slots=True)
class _Run:
    """What a :class:`Tkf` knows of the sequence besides the filter's state, set frame by frame.

    Plain attributes of their own: set on the tracker, each would pass through the check that
    notices a changed hyperparameter.
    """

    time: float | None = None
    """The time the state is at [s]; None before the first prediction."""
    last_fix: float | None = None
    """When a fix, or the start pose, last corrected the state [s]."""
    live: bool = False
    """Whether the filter has started (from a start pose or a fix)."""
    confirmed: bool = False
    """Whether a second fix passed the gate after the first (or the start pose was given)."""
    accelerometer: bool = False
    """Whether the IMU reports accelerations (the last frame with IMU samples)."""


class Tkf(Tracker):
    """Plotter's traditional Kalman filter, loosely coupled to a per-frame fix (module docstring).

    Args:
        accel_variance: Variance of each accelerometer axis [(m/s²)²] (the paper's 0.011).
        orientation_variance: Variance of the orientation sensor's heading [deg²] (the paper's
            0.235); used only when the IMU reports a heading.
        turn_rate_noise: White noise of one gyro sample [rad/s] (its bias is a state).
        bias_walk: Random walk of the gyro's bias [rad/s/√s].
        speed_factor: True over read distance of the odometry [1].
        speed_noise: White noise of one odometry speed sample [m/s].
        odometry_speed: Whether the odometry's speed samples correct the velocity; None: only
            when the IMU reports no accelerations (module docstring).
        yaw_source: Where the turn rate comes from: ``"gyro"`` (the IMU) or ``"odometry"`` (a
            reported ``yaw_rate``, or a forklift's speed · tan(steer) / ``wheelbase``); None:
            the vehicle's, a forklift's gyro or a differential drive's odometry.
        vehicle: ``"forklift"`` or ``"differential-drive"``, for the odometry's turn rate.
        wheelbase: A forklift's wheelbase [m], likewise.
        localizer: Spec of the per-frame localizer whose fix is the observation.
        max_holdover: Longest time without a fix before ``ok=False`` [s].
        gate: Largest squared Mahalanobis distance of a fix's innovation (χ², 3 degrees of
            freedom) accepted; ``inf`` accepts every fix.
        camera_from_imu: How far the camera is ahead of the IMU along the heading [m].
    """

    name = "tkf"

    def __init__(self, *, accel_variance: float = 0.011, orientation_variance: float = 0.235,
                 turn_rate_noise: float = ImuModel().gyro_noise,
                 bias_walk: float = GYRO_BIAS_WALK, speed_factor: float = 1.0,
                 speed_noise: float = OdometryModel().speed_noise,
                 odometry_speed: bool | None = None, yaw_source: str | None = None,
                 vehicle: str = FORKLIFT, wheelbase: float = WHEELBASE,
                 localizer: str = "ransac", max_holdover: float = 2.0,
                 gate: float = CHI2_3DOF_999, camera_from_imu: float = CAMERA_FROM_IMU) -> None:
        self.accel_variance = accel_variance
        self.orientation_variance = orientation_variance
        self.turn_rate_noise = turn_rate_noise
        self.bias_walk = bias_walk
        self.speed_factor = speed_factor
        self.speed_noise = speed_noise
        self.odometry_speed = odometry_speed
        self.yaw_source = yaw_source
        self.vehicle = vehicle
        self.wheelbase = wheelbase
        self.localizer = localizer
        self.max_holdover = max_holdover
        self.gate = gate
        self.camera_from_imu = camera_from_imu
        self._validate_once()

    def _check_params(self) -> None:
        name = type(self).__name__
        for field in ("accel_variance", "orientation_variance", "max_holdover", "gate",
                      "speed_factor", "speed_noise", "turn_rate_noise"):
            check_range(name, field, getattr(self, field), low=0.0, low_open=True,
                        infinite=field == "gate")
        check_range(name, "bias_walk", self.bias_walk, low=0.0)
        if self.odometry_speed is not None:
            check_flag(name, "odometry_speed", self.odometry_speed)
        if self.yaw_source is not None:
            check_choice(name, "yaw_source", self.yaw_source, YAW_SOURCES)
        check_choice(name, "vehicle", self.vehicle, VEHICLE_KINDS)
        check_range(name, "wheelbase", self.wheelbase, low=0.0, low_open=True)
        self._yaw_source = VEHICLE_DEFAULTS[self.vehicle][0] if self.yaw_source is None \
            else self.yaw_source
        check_range(name, "camera_from_imu", self.camera_from_imu)
        if not isinstance(self.localizer, str):
            raise InvalidInputError(f"{type(self).__name__}.localizer must be a localizer "
                                    f"spec (a string), got {self.localizer!r}")
        fixer = build(self.localizer)
        if not isinstance(fixer, SupportsLocalize):
            raise InvalidInputError(f"{type(self).__name__}.localizer must name a per-frame "
                                    f"localizer, got {self.localizer!r} (a tracker)")
        # Tracker.update checked the frame as Localizer.localize would, and the fixer's
        # hyperparameters were checked as it was built (no one else holds it): a localizer of
        # azgym's base class takes the frame straight to its solver.
        self._fix = fixer._localize_frame if isinstance(fixer, Localizer) else fixer.localize
        self._noise = self._noise_constants()  # the prediction's constants, as now set
        # and the correction's, as floats (read every frame)
        self._ahead, self._gate = float(self.camera_from_imu), float(self.gate)
        self._max_holdover = float(self.max_holdover)

    def _low_pass_rc(self) -> float:
        """The RC [s] of the accelerometer's low-pass prefilter; none (0) for tkf."""
        return 0.0

    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        self._x = np.zeros(SIZE)
        self._P = np.zeros((SIZE, SIZE))
        self._held = new_held()
        self._run = _Run()
        if initial is not None:
            self._start(initial, np.diag(np.square(START_SD)[_POSE]), START_SD[2])
            self._run.confirmed = True

    def _predict(self, motion: Motion) -> None:
        """Step through the frame's samples in time order (:mod:`azgym.track.inertial_steps`).

        An IMU sample starts the acceleration (and the gyro's yaw rate) held until the next one
        (its heading, when it has one, corrects the state first); an odometry sample observes
        the velocity along the heading and, with ``yaw_source="odometry"``, starts the turn
        rate held. On a repeated time stamp the IMU's sample comes first.
        """
        imu, odometry, run = motion.imu, motion.odometry, self._run
        if run.time is None:
            first = imu.time if imu.time.size else odometry.time
            run.time = float(first[0]) if first.size else motion.time
            if run.live:
                run.last_fix = run.time
        clock, run.time = run.time, motion.time
        if not run.live:
            return
        if imu.time.size:
            run.accelerometer = math.isfinite(imu.accel[0, 0])
        use_speed = self.odometry_speed if self.odometry_speed is not None \
            else not run.accelerometer
        from_odometry = self._yaw_source == "odometry"
        used = odometry.time.size if use_speed or from_odometry else 0
        # A new array either way (a run's frames arrive read-only): one specialization.
        rates = np.array(odometry_yaw_rates(odometry, self.vehicle, float(self.wheelbase),
                                            self._columns("odometry")),
                         dtype=np.float64) if from_odometry else _GYRO_YAW
        predict_samples(self._x, self._P, imu.time, imu.accel, imu.yaw_rate, imu.heading,
                        odometry.time, odometry.speed, rates, used, clock, motion.time,
                        self._held, self._noise, run.accelerometer, bool(use_speed),
                        not from_odometry)

    def _noise_constants(self) -> FloatArray:
        """The constants :func:`predict_samples` takes, from the hyperparameters."""
        noise = np.empty(NOISE_SIZE)
        noise[ACCEL_VAR] = float(self.accel_variance)
        noise[YAW_RATE_VAR] = float(self.turn_rate_noise) ** 2
        noise[BIAS_WALK_VAR] = float(self.bias_walk) ** 2
        noise[HEADING_VAR] = math.radians(1.0) ** 2 * float(self.orientation_variance)
        noise[SPEED_VAR] = float(self.speed_noise) ** 2
        noise[SPEED_FACTOR] = float(self.speed_factor)
        noise[LOW_PASS_RC] = self._low_pass_rc()
        noise[UNMEASURED_ACCEL_VAR] = UNMEASURED_ACCEL_SD ** 2
        return noise

    def _update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        fix = self._fix(measurements, beacons)
        run = self._run
        now = run.time if run.time is not None else 0.0
        used = fix.ok and self._correct(fix)
        if used:
            run.last_fix = now
        since = 0.0 if run.last_fix is None else now - run.last_fix
        if not run.confirmed or since > self._max_holdover:
            reason = ("no fix yet" if not run.live else
                      "a first fix, waiting for a second to confirm it" if not run.confirmed
                      else f"no fix for {since:.1f} s (max_holdover {self.max_holdover} s)")
            return Estimate.failure(reason, len(measurements), {"fix": _fix_state(fix, used)})
        x = self._x
        covariance = np.empty((3, 3))
        camera_x, camera_y, heading = camera_estimate(x, self._P, self._ahead, covariance)
        return Estimate._filled(
            camera_x, camera_y, heading,
            fix.inliers if used else np.zeros(len(measurements), bool), True, "", covariance,
            {"fix": _fix_state(fix, used), "holdover": since, "speed": math.hypot(x[2], x[3])})

    def _correct(self, fix: Estimate) -> bool:
        """Start or correct the filter with a fix; False if the gate refused it.

        A fix that starts the filter is only tentative (it may be an outlier): the next fix
        confirms it by passing the gate, or, refused, starts the filter again in its place. Once
        confirmed, the filter never restarts: after a long gap its covariance has grown, and the
        gate with it, so a fix that agrees with the prediction brings it back, while a wrong one
        (ransac can be wrong for several frames running) cannot capture it.
        """
        x, y, heading = fix.x, fix.y, fix.heading
        R = np.array(fix.covariance if fix.covariance is not None else _FALLBACK_FIX_COVARIANCE,
                     dtype=np.float64)  # a new array: one specialization of the kernel
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(heading)):
            return False
        run = self._run
        if run.live:
            gate = self._gate
            distance = fix_update(self._x, self._P, x, y, heading, R, self._ahead, gate)
            if distance < 0.0:  # R is not finite
                return False
            if distance <= gate:
                run.confirmed = True
                return True
            if run.confirmed:
                return False
        elif not np.isfinite(R).all():
            return False
        self._start((x, y, heading), R, FIX_START_SPEED_SD)
        return True

    def _start(self, camera: Pose, R: np.ndarray, speed_sd: float) -> None:
        """Start the filter from the camera's pose (covariance ``R``), its velocity unknown."""
        ahead = self._ahead
        c, s = math.cos(camera[2]), math.sin(camera[2])
        self._x[:] = (camera[0] - ahead * c, camera[1] - ahead * s, 0.0, 0.0, camera[2], 0.0)
        self._P[:] = 0.0
        self._P[np.ix_(_POSE, _POSE)] = R
        self._P[2, 2] = self._P[3, 3] = speed_sd ** 2
        self._P[-1, -1] = GYRO_BIAS_SD ** 2
        self._run.live, self._run.confirmed = True, False


class Lpkf(Tkf):
    """Plotter's low-pass filtered Kalman filter: :class:`Tkf` with its IMU prefiltered.

    Args:
        cutoff_hz: Cut-off of the first-order low-pass on the accelerations [Hz] (the paper's 1).
        **params: The hyperparameters of :class:`Tkf`.
    """

    name = "lpkf"

    def __init__(self, *, cutoff_hz: float = 1.0, accel_variance: float = 0.011,
                 orientation_variance: float = 0.235,
                 turn_rate_noise: float = ImuModel().gyro_noise,
                 bias_walk: float = GYRO_BIAS_WALK, speed_factor: float = 1.0,
                 speed_noise: float = OdometryModel().speed_noise,
                 odometry_speed: bool | None = None, yaw_source: str | None = None,
                 vehicle: str = FORKLIFT, wheelbase: float = WHEELBASE,
                 localizer: str = "ransac", max_holdover: float = 2.0,
                 gate: float = CHI2_3DOF_999, camera_from_imu: float = CAMERA_FROM_IMU) -> None:
        self.cutoff_hz = cutoff_hz
        super().__init__(accel_variance=accel_variance, orientation_variance=orientation_variance,
                         turn_rate_noise=turn_rate_noise, bias_walk=bias_walk,
                         speed_factor=speed_factor, speed_noise=speed_noise,
                         odometry_speed=odometry_speed, yaw_source=yaw_source,
                         vehicle=vehicle, wheelbase=wheelbase, localizer=localizer,
                         max_holdover=max_holdover, gate=gate, camera_from_imu=camera_from_imu)

    def _check_params(self) -> None:
        check_range(type(self).__name__, "cutoff_hz", self.cutoff_hz, low=0.0, low_open=True)
        super()._check_params()

    def _low_pass_rc(self) -> float:
        return 1.0 / (2.0 * math.pi * float(self.cutoff_hz))


def _fix_state(fix: Estimate, used: bool) -> str:
    """What became of the frame's fix: used, refused by the gate, or none."""
    return "used" if used else "refused" if fix.ok else "none"

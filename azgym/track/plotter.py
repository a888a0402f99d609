"""Plotter's Kalman trackers (Dang et al. 2015, Sec. IV): ``tkf``, and ``lpkf`` with a low-pass IMU.

The state is the IMU's position, velocity and heading and the gyro's bias (x, y, vₓ, v_y, φ, b).
Between frames the IMU predicts it (:func:`azgym.track.kalman.inertial_step`): the body-frame
acceleration, turned into the world frame by the heading, integrated twice; the heading by the
gyro's yaw rate less the bias and, when the IMU has an orientation sensor
(``ImuModel.orientation_noise``), corrected by each of its readings. Plotter predicts from the
accelerometer and the orientation sensor only; azgym's IMU always has a gyro and an orientation
sensor only when asked, so the gyro carries the heading and the fixes' headings (and the sensor,
when there is one) keep it and the bias in check.

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

import numpy as np

from azgym.core import BeaconMap, Estimate, Measurements, Pose, wrap_scalar
from azgym.errors import InvalidInputError
from azgym.hyperparameters import check_range
from azgym.localize.registry import SupportsLocalize, build
from azgym.sensing.motion import Motion
from azgym.track.base import Tracker
from azgym.track.kalman import HEADING, SIZE, camera_observation, inertial_step, update
from azgym.track.kinematics import CAMERA_FROM_IMU, LowPass, held_spans

CHI2_3DOF_999 = 16.27
"""The 99.9 % point of χ² with 3 degrees of freedom: a fix this far off (x, y, φ) is an outlier."""
FALLBACK_FIX_SD = (0.1, 0.1, math.radians(2.0))
"""Standard deviations (x, y, φ) [m, m, rad] of a fix whose localizer gives no covariance."""
START_SD = (0.05, 0.05, 0.05, 0.05, math.radians(1.0))
"""Uncertainty of a start pose given to ``reset`` (x, y [m], vₓ, v_y [m/s], φ [rad]): a forklift
at its dock, at rest, trusted without a fix to confirm it."""
GYRO_BIAS_SD = 0.01
"""Prior uncertainty of the gyro's bias [rad/s] (azgym's default IMU draws it with 0.005)."""
GYRO_BIAS_WALK = 1e-3
"""How fast the bias may wander [rad/s/√s] (the default IMU's walks at 1e-4)."""
_HEADING_ROW = np.eye(SIZE)[[HEADING]]
_POSE = np.array([0, 1, HEADING])
FIX_START_SPEED_SD = 1.0
"""Velocity uncertainty [m/s] when a fix starts the filter: the forklift may be moving."""


class Tkf(Tracker):
    """Plotter's traditional Kalman filter, loosely coupled to a per-frame fix (module docstring).

    Args:
        accel_variance: Variance of each accelerometer axis [(m/s²)²] (the paper's 0.011).
        orientation_variance: Variance of the orientation sensor's heading [deg²] (the paper's
            0.235); used only when the IMU reports a heading.
        yaw_rate_variance: Variance of the gyro's white noise [(rad/s)²] (its bias is a state).
        localizer: Spec of the per-frame localizer whose fix is the observation.
        max_holdover: Longest time without a fix before ``ok=False`` [s].
        gate: Largest squared Mahalanobis distance of a fix's innovation (χ², 3 degrees of
            freedom) accepted; ``inf`` accepts every fix.
        camera_from_imu: How far the camera is ahead of the IMU along the heading [m].
    """

    name = "tkf"

    def __init__(self, *, accel_variance: float = 0.011, orientation_variance: float = 0.235,
                 yaw_rate_variance: float = 2.5e-5, localizer: str = "ransac",
                 max_holdover: float = 2.0, gate: float = CHI2_3DOF_999,
                 camera_from_imu: float = CAMERA_FROM_IMU) -> None:
        self.accel_variance = accel_variance
        self.orientation_variance = orientation_variance
        self.yaw_rate_variance = yaw_rate_variance
        self.localizer = localizer
        self.max_holdover = max_holdover
        self.gate = gate
        self.camera_from_imu = camera_from_imu
        self._validate_once()

    def _check_params(self) -> None:
        name = type(self).__name__
        for field in ("accel_variance", "orientation_variance", "yaw_rate_variance",
                      "max_holdover", "gate"):
            check_range(name, field, getattr(self, field), low=0.0, low_open=True,
                        infinite=field == "gate")
        check_range(name, "camera_from_imu", self.camera_from_imu)
        if not isinstance(self.localizer, str):
            raise InvalidInputError(f"{type(self).__name__}.localizer must be a localizer "
                                    f"spec (a string), got {self.localizer!r}")
        fixer = build(self.localizer)
        if not isinstance(fixer, SupportsLocalize):
            raise InvalidInputError(f"{type(self).__name__}.localizer must name a per-frame "
                                    f"localizer, got {self.localizer!r} (a tracker)")
        object.__setattr__(self, "_fixer", fixer)

    def _lowpass(self) -> LowPass | None:
        """The accelerometer's prefilter: none for the traditional filter."""
        return None

    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        self._x = np.zeros(SIZE)
        self._P = np.zeros((SIZE, SIZE))
        self._live = self._confirmed = False
        if initial is not None:
            self._start(np.array(initial), np.diag(np.square(START_SD)[_POSE]), START_SD[2])
            self._confirmed = True
        self._time: float | None = None
        self._last_fix: float | None = None
        self._accel_filter = self._lowpass()
        self._last_sample = -math.inf
        self._held: tuple[tuple[float, float], float] = ((0.0, 0.0), 0.0)

    def _predict(self, motion: Motion) -> None:
        imu = motion.imu
        if self._time is None:
            self._time = float(imu.time[0]) if imu.time.size else motion.time
            if self._live:
                self._last_fix = self._time
        spans = held_spans(imu.time, self._time, motion.time).tolist()
        self._time = motion.time
        if not self._live:
            return
        accel_var, rate_var = float(self.accel_variance), float(self.yaw_rate_variance)
        walk = GYRO_BIAS_WALK ** 2
        heading_var = math.radians(1.0) ** 2 * float(self.orientation_variance)
        lowpass = self._accel_filter
        x, P = self._x, self._P
        inertial_step(x, P, *self._held, spans[0], accel_var, rate_var, walk)
        for k, dt in enumerate(spans[1:]):
            heading = float(imu.heading[k])
            if not math.isnan(heading):
                update(x, P, np.array([heading]), x[[HEADING]], _HEADING_ROW,
                       np.array([[heading_var]]), angles=(0,))
            accel = imu.accel[k]
            if lowpass is not None:
                accel = lowpass(accel, float(imu.time[k]) - self._last_sample)
            self._last_sample = float(imu.time[k])
            self._held = ((float(accel[0]), float(accel[1])), float(imu.yaw_rate[k]))
            inertial_step(x, P, *self._held, dt, accel_var, rate_var, walk)

    def _update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        fix = self._fixer.localize(measurements, beacons)
        now = self._time if self._time is not None else 0.0
        used = fix.ok and self._correct(fix)
        if used:
            self._last_fix = now
        since = self._since_fix(now)
        if not self._confirmed or since > float(self.max_holdover):
            reason = ("no fix yet" if not self._live else
                      "a first fix, waiting for a second to confirm it" if not self._confirmed
                      else f"no fix for {since:.1f} s (max_holdover {self.max_holdover} s)")
            return Estimate.failure(reason, len(measurements), {"fix": _fix_state(fix, used)})
        x = self._x
        camera, H = camera_observation(x, float(self.camera_from_imu))
        return Estimate(
            x=float(camera[0]), y=float(camera[1]), heading=wrap_scalar(float(camera[2])),
            inliers=fix.inliers if used else np.zeros(len(measurements), bool),
            covariance=H @ self._P @ H.T,
            diagnostics={"fix": _fix_state(fix, used), "holdover": since,
                         "speed": math.hypot(x[2], x[3])})

    def _since_fix(self, now: float) -> float:
        """Seconds since the last fix used, or since the start pose."""
        return 0.0 if self._last_fix is None else now - self._last_fix

    def _correct(self, fix: Estimate) -> bool:
        """Start or correct the filter with a fix; False if the gate refused it.

        A fix that starts the filter is only tentative (it may be an outlier): the next fix
        confirms it by passing the gate, or, refused, starts the filter again in its place. Once
        confirmed, the filter never restarts: after a long gap its covariance has grown, and the
        gate with it, so a fix that agrees with the prediction brings it back, while a wrong one
        (ransac can be wrong for several frames running) cannot capture it.
        """
        z = np.array(fix.pose, dtype=np.float64)
        R = fix.covariance if fix.covariance is not None else np.diag(np.square(FALLBACK_FIX_SD))
        if not (np.isfinite(z).all() and np.isfinite(R).all()):
            return False
        if self._live:
            predicted, H = camera_observation(self._x, float(self.camera_from_imu))
            gate = float(self.gate)
            if update(self._x, self._P, z, predicted, H, R, angles=(2,), gate=gate) <= gate:
                self._confirmed = True
                return True
            if self._confirmed:
                return False
        self._start(z, R, FIX_START_SPEED_SD)
        return True

    def _start(self, camera: np.ndarray, R: np.ndarray, speed_sd: float) -> None:
        """Start the filter from the camera's pose (covariance ``R``), its velocity unknown."""
        ahead = float(self.camera_from_imu)
        c, s = math.cos(camera[2]), math.sin(camera[2])
        self._x[:] = (camera[0] - ahead * c, camera[1] - ahead * s, 0.0, 0.0, camera[2], 0.0)
        self._P[:] = 0.0
        self._P[np.ix_(_POSE, _POSE)] = R
        self._P[2, 2] = self._P[3, 3] = speed_sd ** 2
        self._P[-1, -1] = GYRO_BIAS_SD ** 2
        self._live, self._confirmed = True, False


class Lpkf(Tkf):
    """Plotter's low-pass filtered Kalman filter: :class:`Tkf` with its IMU prefiltered.

    Args:
        cutoff_hz: Cut-off of the first-order low-pass on the accelerations [Hz] (the paper's 1).
        **params: The hyperparameters of :class:`Tkf`.
    """

    name = "lpkf"

    def __init__(self, *, cutoff_hz: float = 1.0, accel_variance: float = 0.011,
                 orientation_variance: float = 0.235, yaw_rate_variance: float = 2.5e-5,
                 localizer: str = "ransac", max_holdover: float = 2.0,
                 gate: float = CHI2_3DOF_999, camera_from_imu: float = CAMERA_FROM_IMU) -> None:
        self.cutoff_hz = cutoff_hz
        super().__init__(accel_variance=accel_variance, orientation_variance=orientation_variance,
                         yaw_rate_variance=yaw_rate_variance, localizer=localizer,
                         max_holdover=max_holdover, gate=gate, camera_from_imu=camera_from_imu)

    def _check_params(self) -> None:
        check_range(type(self).__name__, "cutoff_hz", self.cutoff_hz, low=0.0, low_open=True)
        super()._check_params()

    def _lowpass(self) -> LowPass:
        return LowPass(float(self.cutoff_hz))


def _fix_state(fix: Estimate, used: bool) -> str:
    """What became of the frame's fix: used, refused by the gate, or none."""
    return "used" if used else "refused" if fix.ok else "none"

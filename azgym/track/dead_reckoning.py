"""Dead reckoning: the start pose moved by wheel odometry alone; the camera is never used.

The baseline every tracker must beat. From the pose given to ``reset(initial=...)`` it integrates
the odometry's speed (times ``speed_factor``) along the heading (:mod:`azgym.track.kinematics`),
turning at the rate the odometry reports (a differential drive's ``yaw_rate``, or a forklift's
steering angle through the bicycle model, ω = v tan δ / L) or at the rate the IMU's gyro
reports. Nothing corrects it, so its error grows without bound: the odometry's scale error makes
the distance drift, and the turn rate's noise and bias the heading, which bends the whole path.
Without a start pose it has nothing to integrate from and answers ``ok=False``.
"""

from __future__ import annotations

import numpy as np

from azgym.core import BeaconMap, Estimate, Measurements, Pose
from azgym.hyperparameters import check_range
from azgym.profile import FORKLIFT, VEHICLE_KINDS
from azgym.sensing.motion import Motion
from azgym.track.base import Tracker, check_choice
from azgym.track.kinematics import WHEELBASE, advance, held_spans, odometry_yaw_rates
from azgym.track.unicycle import VEHICLE_DEFAULTS, YAW_SOURCES

__all__ = ["DeadReckoning"]


class DeadReckoning(Tracker):
    """Integrate wheel odometry from the start pose (module docstring).

    Args:
        yaw_source: Where the turn rate comes from: ``"odometry"`` (its ``yaw_rate``, or a
            forklift's steering angle and speed through the bicycle model) or ``"gyro"`` (the
            IMU's yaw rate).
        vehicle: ``"forklift"`` or ``"differential-drive"``.
        camera_ahead: How far the camera is ahead of the turning axis [m] (negative: behind
            it); None: the vehicle's (the default forklift's camera is 0.5 m behind its front
            axle, a differential drive's is taken over its wheel axle).
        wheelbase: The forklift's wheelbase L [m].
        speed_factor: True over read distance of the odometry [1].
    """

    name = "dead-reckoning"

    def __init__(self, *, yaw_source: str = "odometry", vehicle: str = FORKLIFT,
                 camera_ahead: float | None = None, wheelbase: float = WHEELBASE,
                 speed_factor: float = 1.0) -> None:
        self.yaw_source = yaw_source
        self.vehicle = vehicle
        self.camera_ahead = camera_ahead
        self.wheelbase = wheelbase
        self.speed_factor = speed_factor
        self._validate_once()

    def _check_params(self) -> None:
        check_choice("DeadReckoning", "yaw_source", self.yaw_source, YAW_SOURCES)
        check_choice("DeadReckoning", "vehicle", self.vehicle, VEHICLE_KINDS)
        check_range("DeadReckoning", "wheelbase", self.wheelbase, low=0.0, low_open=True)
        if self.camera_ahead is not None:
            check_range("DeadReckoning", "camera_ahead", self.camera_ahead, low=-10.0, high=10.0)
        check_range("DeadReckoning", "speed_factor", self.speed_factor, low=0.0, low_open=True)
        lever = VEHICLE_DEFAULTS[self.vehicle][1] if self.camera_ahead is None \
            else self.camera_ahead
        self._lever = float(lever)

    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        self._pose = initial
        self._time: float | None = None
        self._speed = 0.0
        self._rate = 0.0
        self._gyro = 0.0
        self._travelled = 0.0

    def _predict(self, motion: Motion) -> None:
        odometry = motion.odometry
        start = self._time
        if start is None:  # the first frame: the start pose holds from the first sample on
            start = float(odometry.time[0]) if odometry.time.size else motion.time
        self._time = motion.time
        if self._pose is None:
            return
        spans = held_spans(odometry.time, start, motion.time)
        speeds = np.append(self._speed, odometry.speed)
        if self.yaw_source == "odometry":
            rates = np.append(self._rate, odometry_yaw_rates(
                odometry, self.vehicle, float(self.wheelbase), self._columns("odometry")))
        else:
            rates = self._gyro_rates(motion, start, spans)
        pose, factor = self._pose, float(self.speed_factor)
        for speed, rate, dt in zip(speeds.tolist(), rates.tolist(), spans.tolist(), strict=True):
            pose = advance(pose, factor * speed, rate, self._lever, dt)
            self._travelled += abs(factor * speed) * dt
        self._pose = pose
        self._speed = float(speeds[-1])
        if self.yaw_source == "odometry":
            self._rate = float(rates[-1])

    def _gyro_rates(self, motion: Motion, start: float, spans: np.ndarray) -> np.ndarray:
        """The gyro's yaw rate held at the start of each odometry span (the latest reading)."""
        imu = motion.imu
        begins = start + np.cumsum(spans) - spans
        latest = np.searchsorted(imu.time, begins + 1e-9, side="right")
        rates = np.append(self._gyro, imu.yaw_rate)[latest]
        if imu.yaw_rate.size:
            self._gyro = float(imu.yaw_rate[-1])
        return rates

    def _update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        if self._pose is None:
            return Estimate.failure(
                "dead reckoning needs a start pose: reset(initial=(x, y, heading))",
                len(measurements))
        x, y, heading = self._pose
        return Estimate(x=x, y=y, heading=heading, inliers=np.zeros(len(measurements), bool),
                        diagnostics={"travelled": self._travelled})

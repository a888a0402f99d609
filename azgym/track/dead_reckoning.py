"""Dead reckoning: the start pose moved by wheel odometry alone; the camera is never used.

The baseline every tracker must beat. From the pose given to ``reset(initial=...)`` it integrates
the odometry's speed along the heading with the forklift's bicycle model
(:mod:`azgym.track.kinematics`), turning at the rate the steering angle gives (ω = v tan δ / L)
or at the rate the IMU's gyro reports. Nothing corrects it, so its error grows without bound: the
odometry's scale error makes the distance drift, and the steering noise or the gyro's bias the
heading, which bends the whole path. Without a start pose it has nothing to integrate from and
answers ``ok=False``.
"""

from __future__ import annotations

import numpy as np

from azgym.core import BeaconMap, Estimate, Measurements, Pose
from azgym.errors import InvalidInputError
from azgym.hyperparameters import check_range
from azgym.sensing.motion import Motion
from azgym.track.base import Tracker
from azgym.track.kinematics import CAMERA_AHEAD, WHEELBASE, advance, held_spans, yaw_rates

YAW_SOURCES = ("odometry", "gyro")


class DeadReckoning(Tracker):
    """Integrate wheel odometry from the start pose (module docstring).

    Args:
        yaw_source: Where the turn rate comes from: ``"odometry"`` (steering angle and speed
            through the bicycle model) or ``"gyro"`` (the IMU's yaw rate).
        wheelbase: The forklift's wheelbase L [m].
        camera_ahead: How far the camera is ahead of the non-steering axle [m] (negative:
            behind it); the default forklift's camera is 0.5 m behind its front axle.
    """

    name = "dead-reckoning"

    def __init__(self, *, yaw_source: str = "odometry", wheelbase: float = WHEELBASE,
                 camera_ahead: float = CAMERA_AHEAD) -> None:
        self.yaw_source = yaw_source
        self.wheelbase = wheelbase
        self.camera_ahead = camera_ahead
        self._validate_once()

    def _check_params(self) -> None:
        if self.yaw_source not in YAW_SOURCES:
            raise InvalidInputError(
                f"DeadReckoning.yaw_source must be one of {', '.join(YAW_SOURCES)}, got "
                f"{self.yaw_source!r}")
        check_range("DeadReckoning", "wheelbase", self.wheelbase, low=0.0, low_open=True)
        check_range("DeadReckoning", "camera_ahead", self.camera_ahead)

    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        self._pose = initial
        self._time: float | None = None
        self._speed = 0.0
        self._steer = 0.0
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
        steers = np.append(self._steer, odometry.steer)
        if self.yaw_source == "odometry":
            rates = yaw_rates(speeds, steers, float(self.wheelbase))
        else:
            rates = self._gyro_rates(motion, start, spans)
        pose = self._pose
        for speed, rate, dt in zip(speeds.tolist(), rates.tolist(), spans.tolist(), strict=True):
            pose = advance(pose, speed, rate, float(self.camera_ahead), dt)
            self._travelled += abs(speed) * dt
        self._pose = pose
        self._speed, self._steer = float(speeds[-1]), float(steers[-1])

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

"""The vehicles' motion sensors in the world: wheel odometry and the IMU, after every physics step.

One rule for what the wheel encoders and the IMU report while the world runs, shared by the
driven routes (:func:`azgym.world.drive.simulate`) and the navigation environment
(:mod:`azgym.nav.estimator`): the odometer reads the drive's speed and steering angle, the IMU
the body's yaw rate, its heading and its acceleration — the change of the body's velocity over
the step, turned into the body frame (forward, left). Each samples at its own rate
(:mod:`azgym.sensing.motion`); the samples wait here until taken, for a tracker's ``predict``.
A differential-drive robot's odometry (:class:`RobotMotionSensors`) reads its speed and turn
rate at its logger's stamps; it has an IMU only when one is asked for.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from azgym.sensing.motion import (
    DifferentialOdometer,
    DifferentialOdometryModel,
    Imu,
    ImuModel,
    ImuSamples,
    Motion,
    Odometer,
    OdometryModel,
    OdometrySamples,
)
from azgym.world.robot import Robot
from azgym.world.world import World

if TYPE_CHECKING:
    from pymunk import Vec2d

__all__ = ["MotionSensors", "RobotMotionSensors"]


class MotionSensors:
    """Wheel odometry and the IMU of a world's forklift, sampled after every physics step.

    Call :meth:`step` once at the start (the velocity the first acceleration is measured from)
    and after every physics step.

    Args:
        odometry: The odometry's errors.
        imu: The IMU's errors.
        odometry_rng: The odometry's own random stream.
        imu_rng: The IMU's own random stream.
        dt: The world's physics step [s].
    """

    def __init__(self, odometry: OdometryModel, imu: ImuModel, odometry_rng: np.random.Generator,
                 imu_rng: np.random.Generator, dt: float) -> None:
        self._odometer = Odometer(odometry, odometry_rng)
        self._imu = Imu(imu, imu_rng)
        self._dt = dt
        self._velocity: Vec2d | None = None

    def step(self, world: World) -> None:
        """Sample the step just taken (nothing at the start, before the first one)."""
        forklift = world.forklift
        velocity = forklift.body.velocity
        if self._velocity is not None:
            ax = (velocity.x - self._velocity.x) / self._dt
            ay = (velocity.y - self._velocity.y) / self._dt
            heading = forklift.body.angle
            c, s = math.cos(heading), math.sin(heading)
            self._odometer.update(world.time, forklift.speed, forklift.steer)
            self._imu.update(world.time, forklift.body.angular_velocity,
                             (c * ax + s * ay, -s * ax + c * ay), heading)
        self._velocity = velocity

    def take(self, until: float = math.inf) -> tuple[OdometrySamples, ImuSamples]:
        """The samples since the last call, up to time ``until`` [s]; later ones wait."""
        return self._odometer.take(until), self._imu.take(until)

    def motion(self, time: float) -> Motion:
        """A tracker's ``predict`` for a frame at ``time`` [s]: the samples untaken up to it."""
        return Motion(time, *self.take(time))


class RobotMotionSensors:
    """A differential-drive robot's odometry, and its IMU if it has one, after every step.

    Call :meth:`step` after every step of the robot (each step's speed and turn rate are held
    over it, so a stamp inside the step reads them).

    Args:
        odometry: The odometry's errors and stamps.
        imu: The IMU's errors, or None: no IMU (its samples are empty).
        odometry_rng: The odometry's own random stream.
        imu_rng: The IMU's own random stream.
    """

    def __init__(self, odometry: DifferentialOdometryModel, imu: ImuModel | None,
                 odometry_rng: np.random.Generator, imu_rng: np.random.Generator) -> None:
        self._odometer = DifferentialOdometer(odometry, odometry_rng)
        self._imu = None if imu is None else Imu(imu, imu_rng)
        self._speed = 0.0

    def step(self, robot: Robot) -> None:
        """Sample the step just taken."""
        self._odometer.update(robot.time, robot.speed, robot.turn_rate)
        if self._imu is not None:  # forward: the speed's change; left: the centripetal part
            accel = ((robot.speed - self._speed) / robot.dt, robot.speed * robot.turn_rate)
            self._imu.update(robot.time, robot.turn_rate, accel, robot.heading)
        self._speed = robot.speed

    def take(self, until: float = math.inf) -> tuple[OdometrySamples, ImuSamples]:
        """The samples since the last call, up to time ``until`` [s]; later ones wait."""
        imu = ImuSamples.none() if self._imu is None else self._imu.take(until)
        return self._odometer.take(until), imu

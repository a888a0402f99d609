"""The forklift: a rigid body with car-like (bicycle-model) steering, driven the pymunk way.

pymunk's top-down vehicles (its ``tank.py`` example) are driven through a kinematic *control body*:
each step the control body gets the velocity the vehicle should have, and a pivot joint and a gear
joint with ``max_bias = 0`` drag the real body after it with at most ``max_force`` and
``max_torque`` — which acts like tyre friction, and lets a rack or a wall stop the forklift.

The wanted velocity comes from a kinematic bicycle model: speed v along the heading at the
reference axle (the one that does not steer) and yaw rate ω = v tan δ / L for steering angle δ
and wheelbase L. Forklifts steer with their rear wheels: then the reference is the front axle and
the tail swings out in turns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from azgym.core import wrap_scalar
from azgym.errors import InvalidInputError

__all__ = ["FORKLIFT_COLLISION_TYPE", "Forklift", "ForkliftSpec"]

FORKLIFT_COLLISION_TYPE = 1
SLIP_TOLERANCE = 0.2
"""Largest gap between commanded and actual speed [m/s] before the command follows the body."""
_SET_VELOCITY = pymunk.Body.__dict__["velocity"].fset
_SET_ANGULAR_VELOCITY = pymunk.Body.__dict__["angular_velocity"].fset
"""The control body's velocity setters, called directly: ``body.velocity = v`` first passes
through pymunk's attribute hook (a Python frame), twice every physics step."""


@dataclass(frozen=True)
class ForkliftSpec:
    """Dimensions and limits of the forklift.

    Attributes:
        length: Body length [m].
        width: Body width [m].
        mass: Mass [kg].
        wheelbase: Distance between the axles [m].
        rear_steer: Whether the rear wheels steer (a forklift's do).
        max_speed: Speed limit, forwards and backwards [m/s].
        max_accel: Acceleration at full throttle [m/s²].
        max_steer: Steering angle at full lock [rad].
        max_force: Largest traction force the tyres transmit [N].
        max_torque: Largest yaw torque the tyres transmit [N m].
        camera_offset: Camera position in the body frame (forward, left) [m].
        sway_hz: Natural frequency of the camera's sway on bumps (the mast's) [Hz].
        sway_damping: Damping ratio of that sway (0 < ζ; a steel mast rings, ζ ≈ 0.3).
    """

    length: float = 2.4
    width: float = 1.2
    mass: float = 3000.0
    wheelbase: float = 1.6
    rear_steer: bool = True
    max_speed: float = 3.0
    max_accel: float = 1.5
    max_steer: float = math.radians(60.0)
    max_force: float = 30_000.0
    max_torque: float = 60_000.0
    camera_offset: tuple[float, float] = (0.3, 0.0)
    sway_hz: float = 2.0
    sway_damping: float = 0.3

    def __post_init__(self) -> None:
        for name in ("length", "width", "mass", "wheelbase", "max_speed", "max_accel",
                     "max_force", "max_torque", "sway_hz", "sway_damping"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InvalidInputError(f"ForkliftSpec.{name} must be > 0, got {value!r}")
        if not 0 < self.max_steer < math.pi / 2:
            raise InvalidInputError(
                f"ForkliftSpec.max_steer must be in (0, π/2) rad, got {self.max_steer!r}"
            )

    @property
    def max_centre_speed(self) -> float:
        """The fastest the body's centre can move [m/s] (3.97 for the defaults).

        The reference axle moves at most ``max_speed``; the centre, half the wheelbase from it,
        also swings round it at the yaw rate v tan δ / wheelbase (:meth:`Forklift.command`), so
        at full lock δ it moves at v · √(1 + tan² δ / 4).
        """
        return self.max_speed * math.hypot(1.0, 0.5 * math.tan(self.max_steer))

    def max_centre_distance(self, seconds: float) -> float:
        """The longest path the body's centre can drive from rest in ``seconds`` [m].

        The reference axle's speed grows at most at ``max_accel`` up to ``max_speed``; the
        centre moves at most :attr:`max_centre_speed` / ``max_speed`` times as fast.
        """
        rise = self.max_speed / self.max_accel  # seconds to top speed
        axle = (0.5 * self.max_accel * seconds**2 if seconds <= rise
                else self.max_speed * (seconds - 0.5 * rise))
        return axle * self.max_centre_speed / self.max_speed


class Forklift:
    """The forklift's body in a pymunk space, with its control body and speed state.

    Args:
        space: The space to add it to.
        spec: Its dimensions and limits.
        x: Start position, east [m].
        y: Start position, north [m].
        heading: Start heading [rad].
    """

    def __init__(self, space: pymunk.Space, spec: ForkliftSpec, x: float, y: float,
                 heading: float) -> None:
        self.spec = spec
        moment = pymunk.moment_for_box(spec.mass, (spec.length, spec.width))
        self.body = pymunk.Body(spec.mass, moment)
        self.body.position = (x, y)
        self.body.angle = heading
        self.shape = pymunk.Poly.create_box(self.body, (spec.length, spec.width), radius=0.02)
        self.shape.collision_type = FORKLIFT_COLLISION_TYPE
        self.shape.friction = 0.5
        self.control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.control.position = self.body.position
        pivot = pymunk.PivotJoint(self.control, self.body, (0, 0), (0, 0))
        pivot.max_bias = 0.0  # no position correction: the joint only transmits velocity
        pivot.max_force = spec.max_force
        gear = pymunk.GearJoint(self.control, self.body, 0.0, 1.0)
        gear.error_bias = 0.0
        gear.max_bias = 0.0
        gear.max_force = spec.max_torque
        space.add(self.body, self.shape, self.control, pivot, gear)
        self.speed = 0.0
        self.steer = 0.0
        # Body centre relative to the reference (non-steering) axle, along the heading [m].
        self._centre_offset = 0.5 * spec.wheelbase if not spec.rear_steer else -0.5 * spec.wheelbase

    def command(self, throttle: float, steer: float, dt: float) -> None:
        """Set the control body's velocity for the next ``dt`` from throttle and steering.

        Args:
            throttle: In [-1, 1]: the share of ``max_accel`` to apply (negative: brake/reverse).
            steer: In [-1, 1]: the share of ``max_steer``, positive turns left.
            dt: The step [s].
        """
        spec = self.spec
        body = self.body
        heading = body.angle
        c, s = math.cos(heading), math.sin(heading)
        # The speed state integrates the throttle; when the body lags it by more than the tyres
        # would slip (a rack or a wall holds the forklift), it falls back to the body's speed.
        vx, vy = body.velocity
        speed = self.speed
        actual = vx * c + vy * s
        if abs(actual - speed) > SLIP_TOLERANCE:
            speed = actual
        limit = spec.max_speed
        speed = max(-limit, min(limit, speed + throttle * spec.max_accel * dt))
        self.speed = speed
        self.steer = steer * spec.max_steer
        omega = speed * math.tan(self.steer) / spec.wheelbase
        # Velocity of the body centre: v along the heading at the reference axle, plus ω × r.
        turn = omega * self._centre_offset
        _SET_VELOCITY(self.control, (speed * c - turn * s, speed * s + turn * c))
        _SET_ANGULAR_VELOCITY(self.control, omega)

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, heading) of the body centre [m, m, rad], the heading wrapped to (−π, π]."""
        x, y = self.body.position
        return x, y, wrap_scalar(self.body.angle)

    def camera_position(self) -> tuple[float, float]:
        """Where the camera is in the world (x, y) [m]."""
        x, y, _ = self.camera_pose_at(self.pose)
        return x, y

    def camera_pose_at(self, pose: tuple[float, float, float]) -> tuple[float, float, float]:
        """The camera's pose (x, y, heading) [m, m, rad] with the body centre at ``pose``."""
        x, y, heading = pose
        forward, left = self.spec.camera_offset
        c, s = math.cos(heading), math.sin(heading)
        return x + forward * c - left * s, y + forward * s + left * c, heading

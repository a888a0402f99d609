"""The scripted baseline: pure pursuit of the planned path, driven from the observation alone.

Pure pursuit (Coulter 1992) steers the axle that does not steer (a forklift's front axle: its
rear wheels steer) along the arc through a point on the path a look-ahead distance ahead: for the
point (x, y) in that axle's frame the arc's curvature is κ = 2y / (x² + y²), and the bicycle
model's steering angle δ = atan(κ L) for wheelbase L. Speed follows a target that falls in tight
turns (lateral acceleration ≤ :data:`LATERAL_ACCEL`) and when the pose has been dead-reckoned
for a while. A point behind the
forklift (a start facing the wrong way) is turned towards in a three-point turn: reversing with
opposite lock, then forward with full lock, switching whenever the range readings behind or
ahead come within :data:`REAR_CLEARANCE` or :data:`FRONT_CLEARANCE` of the body, until the point
is ahead again. A forklift held by a rack (pushing forward for a second without moving) backs off
straight for a second.

It reads only what a trained policy reads (:mod:`azgym.nav.guidance`), so the two are compared
on equal terms.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.nav.controls import CONTROL_STEPS, nearest_discrete
from azgym.nav.guidance import AHEAD_SCALE, FIX_AGE_SCALE, fields
from azgym.world.forklift import ForkliftSpec
from azgym.world.world import PHYSICS_DT

__all__ = ["PurePursuit", "SPEED"]

CRUISE_SPEED = 2.0
"""Target speed on straight path [m/s]."""
LATERAL_ACCEL = 1.0
"""Largest lateral acceleration the speed target allows in a turn [m/s²]."""
STALE_AFTER = 1.0
"""A pose dead-reckoned for longer than this [s] slows the forklift to :data:`CREEP_SPEED`."""
CREEP_SPEED = 1.0
"""Target speed on a dead-reckoned pose [m/s]."""
REVERSE_SPEED = 0.8
"""Target speed while reversing in a three-point turn [m/s]."""
TURN_BACK = math.radians(70.0)
"""A look-ahead point more than this off the heading starts a three-point turn."""
TURN_DONE = math.radians(30.0)
"""...which ends once the point is within this of the heading."""
REAR_CLEARANCE = 0.4
"""Room left behind the body (along the rays behind it) before a reverse turns forward [m]."""
FRONT_CLEARANCE = 0.4
"""Room left ahead of the body before a forward turn reverses again [m]."""
STUCK_AFTER = 10
"""Control steps pushing forward at under :data:`STUCK_SPEED` before backing off."""
STUCK_SPEED = 0.3
"""Drive speed below which a forklift pushing forward is held by something [m/s] (the drive's
speed state lags a held body by up to the tyres' slip, 0.2 m/s)."""
BACK_OFF = 10
"""Control steps reversing straight to get free."""
FIX_AGE, POINT, SPEED = (fields(0).index(name) for name in ("fix_age", "ahead_forward_2", "speed"))
RANGES = len(fields(0))
"""Where the pursuit's inputs are in the observation (it pursues the path's point 3 m ahead);
the range readings come last, from ``RANGES`` on."""


class PurePursuit:
    """Pure pursuit as a policy: ``act(observation)`` gives the action (module docstring).

    Args:
        discrete: Give the nearest of the discrete actions instead of (throttle, steer).
        spec: The forklift's dimensions and limits (the default forklift's).
    """

    def __init__(self, discrete: bool = False, spec: ForkliftSpec | None = None,
                 ray_range: float = 10.0) -> None:
        self.discrete = discrete
        self.spec = spec or ForkliftSpec()
        self.ray_range = ray_range
        self.reset()

    def reset(self) -> None:
        """Forget the manoeuvre in progress: a new episode."""
        self.turning = ""  # "", "back" or "forward": the legs of a three-point turn
        self.pushing = 0
        self.backing_off = 0

    def act(self, observation: np.ndarray) -> np.ndarray | int:
        """The action for one observation."""
        spec = self.spec
        fix_age = float(observation[FIX_AGE]) * FIX_AGE_SCALE
        speed = float(observation[SPEED]) * spec.max_speed
        point = observation[POINT:POINT + 2]
        # The body's reference point is its centre; the front axle is half a wheelbase ahead.
        axle_offset = 0.5 * spec.wheelbase if spec.rear_steer else -0.5 * spec.wheelbase
        x = float(point[0]) * AHEAD_SCALE - axle_offset
        y = float(point[1]) * AHEAD_SCALE
        bearing = math.atan2(y, x)
        if not point.any():  # no pose yet: wait for one
            return self._command(self._throttle_to(0.0, speed), 0.0)
        if self.backing_off:
            self.backing_off -= 1
            return self._command(self._throttle_to(-REVERSE_SPEED, speed), 0.0)
        if self._turn(bearing, observation[RANGES:] * self.ray_range):
            # Reversing with opposite lock or going forward with full lock: either way the
            # nose swings towards the point.
            direction = -1.0 if self.turning == "back" else 1.0
            return self._command(self._throttle_to(direction * REVERSE_SPEED, speed),
                                 direction * math.copysign(1.0, y))
        curvature = 2.0 * y / max(x * x + y * y, 1e-6)
        steer = math.atan(curvature * spec.wheelbase) / spec.max_steer
        target = min(CRUISE_SPEED, math.sqrt(LATERAL_ACCEL / max(abs(curvature), 1e-6)))
        if fix_age > STALE_AFTER:
            target = min(target, CREEP_SPEED)
        self.pushing = self.pushing + 1 if abs(speed) < STUCK_SPEED else 0
        if self.pushing >= STUCK_AFTER:
            self.pushing, self.backing_off = 0, BACK_OFF
        return self._command(self._throttle_to(target, speed), steer)

    def _turn(self, bearing: float, ranges: np.ndarray) -> bool:
        """Update the three-point turn's leg; whether one is under way."""
        n = ranges.size
        half_length, half_width = 0.5 * self.spec.length, 0.5 * self.spec.width
        # Distance from the centre to the body's outline along each ray, then the room left.
        angles = 2.0 * np.pi * np.arange(n) / n
        outline = np.minimum(half_length / np.maximum(np.abs(np.cos(angles)), 1e-9),
                             half_width / np.maximum(np.abs(np.sin(angles)), 1e-9))
        room = ranges - outline
        diagonal = math.cos(math.pi / 4) - 1e-9  # the rays within 45° of straight back or ahead
        behind, ahead = room[np.cos(angles) < -diagonal], room[np.cos(angles) > diagonal]
        rear_blocked = behind.size > 0 and behind.min() < REAR_CLEARANCE
        front_blocked = ahead.size > 0 and ahead.min() < FRONT_CLEARANCE
        if abs(bearing) < TURN_DONE:
            self.turning = ""
        elif not self.turning and abs(bearing) > TURN_BACK:
            self.turning = "forward" if rear_blocked else "back"
        elif self.turning == "back" and rear_blocked:
            self.turning = "forward"
        elif self.turning == "forward" and front_blocked:
            self.turning = "back"
        return bool(self.turning)

    def _command(self, throttle: float, steer: float) -> np.ndarray | int:
        throttle = max(-1.0, min(1.0, throttle))
        steer = max(-1.0, min(1.0, steer))
        if self.discrete:
            return nearest_discrete(throttle, steer)
        return np.array([throttle, steer], dtype=np.float32)

    def _throttle_to(self, target: float, speed: float) -> float:
        """The throttle that brings ``speed`` to ``target`` within one control period."""
        return (target - speed) / (self.spec.max_accel * CONTROL_STEPS * PHYSICS_DT)

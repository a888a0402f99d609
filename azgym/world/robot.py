"""A differential-drive robot: a unicycle with speed, turn-rate and acceleration limits.

The robot turns on the spot and drives forwards; its state is the pose of its turning axis, its
forward speed and its turn rate. Each step the commanded speed and turn rate are reached as fast
as the acceleration limits allow, and then held over the step, which moves the robot along an
exact arc: what the odometry samples in that step is exactly the motion the step made. No
physics engine and no random draw: the same route gives the same trajectory, bit for bit.

:class:`RobotDriver` follows a route's waypoints: it turns toward a point ``lookahead`` ahead on
the route, slowing (to a turn on the spot) as the heading error grows, and stops at the end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from azgym.core import wrap_scalar
from azgym.errors import InvalidInputError
from azgym.site.elements import Route
from azgym.world._polyline import nearest_on_legs, point_at

__all__ = ["Robot", "RobotDriver", "RobotSpec"]


@dataclass(frozen=True)
class RobotSpec:
    """Limits of the robot (defaults: a small wheeled research robot).

    Attributes:
        max_speed: Forward speed limit [m/s].
        max_accel: Forward acceleration limit [m/s²].
        max_turn_rate: Turn-rate limit [rad/s].
        max_turn_accel: Turn-rate change limit [rad/s²].
    """

    max_speed: float = 0.5
    max_accel: float = 0.5
    max_turn_rate: float = 1.2
    max_turn_accel: float = 3.0

    def __post_init__(self) -> None:
        for name in ("max_speed", "max_accel", "max_turn_rate", "max_turn_accel"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InvalidInputError(f"RobotSpec.{name} must be > 0, got {value!r}")


class Robot:
    """The robot's state: the pose of its turning axis, its speed and turn rate, the time.

    Args:
        start: The start pose (x, y, heading) [m, m, rad].
        spec: Its limits.
        dt: The step [s].
        camera_ahead: The camera's offset ahead of the turning axis [m].
    """

    def __init__(self, start: tuple[float, float, float], spec: RobotSpec, dt: float,
                 camera_ahead: float) -> None:
        if not (math.isfinite(dt) and dt > 0):
            raise InvalidInputError(f"dt must be > 0 [s], got {dt}")
        self.spec = spec
        self.dt = dt
        self.camera_ahead = camera_ahead
        self.x, self.y, self.heading = (float(v) for v in start)
        self.speed = 0.0
        self.turn_rate = 0.0
        self.steps = 0

    @property
    def time(self) -> float:
        """Time since the start [s]."""
        return self.steps * self.dt

    def step(self, speed: float, turn_rate: float) -> None:
        """Move one step toward the commanded speed [m/s] and turn rate [rad/s], within limits."""
        spec, dt = self.spec, self.dt
        wanted = max(-spec.max_speed, min(spec.max_speed, speed))
        change = spec.max_accel * dt
        self.speed += max(-change, min(change, wanted - self.speed))
        wanted = max(-spec.max_turn_rate, min(spec.max_turn_rate, turn_rate))
        change = spec.max_turn_accel * dt
        self.turn_rate += max(-change, min(change, wanted - self.turn_rate))
        turn = self.turn_rate * dt
        if abs(turn) < 1e-9:
            forward, left = self.speed * dt, 0.5 * self.speed * dt * turn
        else:
            radius = self.speed / self.turn_rate
            forward, left = radius * math.sin(turn), radius * (1.0 - math.cos(turn))
        c, s = math.cos(self.heading), math.sin(self.heading)
        self.x += forward * c - left * s
        self.y += forward * s + left * c
        self.heading = wrap_scalar(self.heading + turn)
        self.steps += 1

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, heading) of the turning axis [m, m, rad]."""
        return self.x, self.y, self.heading

    def camera_pose(self) -> tuple[float, float, float]:
        """(x, y, heading) of the camera [m, m, rad]."""
        c, s = math.cos(self.heading), math.sin(self.heading)
        return self.x + self.camera_ahead * c, self.y + self.camera_ahead * s, self.heading


class RobotDriver:
    """Follows a route forwards: turn toward a point ahead, slow down as the heading error grows.

    Args:
        route: The route (all legs forwards).
        spec: The robot's limits.
        lookahead: Distance of the target point ahead on the route [m].
        tolerance: Distance to the route's end that counts as arrived [m].
        turn_gain: Turn rate per radian of heading error [1/s].
    """

    def __init__(self, route: Route, spec: RobotSpec, lookahead: float = 0.4,
                 tolerance: float = 0.05, turn_gain: float = 2.5) -> None:
        self.route = route
        self.spec = spec
        self.lookahead = lookahead
        self.tolerance = tolerance
        self.turn_gain = turn_gain
        self._points = route.waypoints
        self._lengths = np.hypot(*np.diff(route.waypoints, axis=0).T)
        self._starts = np.concatenate([[0.0], np.cumsum(self._lengths)[:-1]])
        self._ends = self._starts + self._lengths
        self._total = float(self._lengths.sum())
        self._progress = 0.0
        self.done = False

    def command(self, x: float, y: float, heading: float) -> tuple[float, float]:
        """(speed [m/s], turn rate [rad/s]) for the robot's turning axis at (x, y, heading)."""
        if self.done:
            return 0.0, 0.0
        self._progress = max(self._progress, self._project(x, y))
        remaining = self._total - self._progress
        end = self._points[-1]
        near_end = (remaining < self.lookahead
                    and math.hypot(end[0] - x, end[1] - y) < self.tolerance)
        if remaining < self.tolerance or near_end:
            self.done = True
            return 0.0, 0.0
        target = point_at(self._points, self._lengths,
                          min(self._total, self._progress + self.lookahead))
        error = wrap_scalar(math.atan2(target[1] - y, target[0] - x) - heading)
        # Slow for the route's end (v² = 2 a d) and for a heading error (on the spot past 60°).
        speed = min(self.route.speed, math.sqrt(max(0.0, remaining) * self.spec.max_accel))
        speed *= max(0.0, math.cos(min(abs(error) * 1.5, 0.5 * math.pi)))
        return speed, self.turn_gain * error

    def _project(self, x: float, y: float) -> float:
        """Arc length of the nearest route point within the lookahead past the progress.

        Only the legs reaching into (progress − lookahead, progress + 2 lookahead) are searched,
        so a route that crosses itself is not skipped ahead at a crossing.
        """
        low, high = self._progress - self.lookahead, self._progress + 2.0 * self.lookahead
        # The legs that start by ``high`` and end from ``low`` on: a run of them, as the legs'
        # starts and ends only grow along the route.
        first = int(self._ends.searchsorted(low, side="left"))
        stop = int(self._starts.searchsorted(high, side="right"))
        leg, t = nearest_on_legs(self._points, self._lengths, first, stop, x, y)
        return float(min(high, self._starts[leg] + t * self._lengths[leg]))

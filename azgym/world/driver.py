"""A waypoint driver (pure pursuit) that makes a scenario's routes reproducible trajectories."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from azgym.core import FloatArray, wrap_scalar
from azgym.site.elements import Route
from azgym.world._polyline import nearest_on_legs, point_at
from azgym.world.forklift import ForkliftSpec

__all__ = ["PurePursuit"]


class PurePursuit:
    """Steers toward a point one lookahead distance ahead on the route (pure pursuit).

    The route is split into stretches of constant direction (forwards or backwards); the driver
    stops at the end of each stretch before changing direction. In a stretch, the target is the
    route point ``lookahead`` metres beyond the one nearest the reference axle, and the path's
    curvature toward it, κ = 2 sin α / L_d, sets the steering: tan δ = ±κ · wheelbase.

    Args:
        route: The route.
        spec: The forklift (wheelbase, steering and speed limits).
        lookahead: L_d [m].
        tolerance: Distance to a stretch's end that counts as arrived [m].
    """

    def __init__(self, route: Route, spec: ForkliftSpec, lookahead: float = 2.0,
                 tolerance: float = 0.25) -> None:
        self.route = route
        self.spec = spec
        self.lookahead = lookahead
        self.tolerance = tolerance
        self._stretches = self._split(route)
        self._stretch = 0
        self._progress = 0.0
        self.done = False

    @staticmethod
    def _split(route: Route) -> list[_Stretch]:
        """The stretches of one direction."""
        stretches, start = [], 0
        for leg in range(1, len(route.reverse) + 1):
            if leg == len(route.reverse) or route.reverse[leg] != route.reverse[start]:
                points = route.waypoints[start:leg + 1]
                lengths = np.hypot(*np.diff(points, axis=0).T)
                stretches.append(_Stretch(points, lengths, float(lengths.sum()),
                                          bool(route.reverse[start])))
                start = leg
        return stretches

    def command(self, x: float, y: float, heading: float, speed: float) -> tuple[float, float]:
        """(throttle, steer) in [-1, 1] for the forklift at pose (x, y, heading) and speed."""
        brake = max(-1.0, min(1.0, -speed / (self.spec.max_accel * 0.1)))
        if self.done:
            return brake, 0.0
        points, lengths, total, backwards = self._stretches[self._stretch]
        direction = -1.0 if backwards else 1.0
        reference = self._reference(x, y, heading)
        self._progress = max(self._progress, _project(points, lengths, *reference))
        remaining = total - self._progress
        end_distance = math.hypot(points[-1, 0] - reference[0], points[-1, 1] - reference[1])
        if remaining < self.tolerance or end_distance < self.tolerance:
            if abs(speed) < 0.05:
                self._stretch += 1
                self._progress = 0.0
                self.done = self._stretch == len(self._stretches)
            return brake, 0.0
        target = point_at(points, lengths, min(total, self._progress + self.lookahead))
        travel = heading + (math.pi if backwards else 0.0)
        alpha = wrap_scalar(math.atan2(target[1] - reference[1], target[0] - reference[0])
                            - travel)
        curvature = 2.0 * math.sin(alpha) / max(self.lookahead, 1e-6)
        steer = math.atan(direction * curvature * self.spec.wheelbase) / self.spec.max_steer
        # Slow down for the end of the stretch: v² = 2 a d with a margin.
        wanted = direction * min(self.route.speed,
                                 math.sqrt(max(0.0, remaining - 0.5 * self.tolerance)
                                           * self.spec.max_accel))
        throttle = max(-1.0, min(1.0, (wanted - speed) / (self.spec.max_accel * 0.2)))
        return throttle, max(-1.0, min(1.0, steer))

    def _reference(self, x: float, y: float, heading: float) -> tuple[float, float]:
        """The non-steering axle's position (the point pure pursuit steers)."""
        offset = 0.5 * self.spec.wheelbase * (1.0 if self.spec.rear_steer else -1.0)
        return x + offset * math.cos(heading), y + offset * math.sin(heading)


class _Stretch(NamedTuple):
    """A stretch of a route driven in one direction."""

    points: FloatArray
    lengths: FloatArray
    """Its legs' lengths [m]."""
    total: float
    """Its length [m] (the legs' sum)."""
    backwards: bool


def _project(points: FloatArray, lengths: FloatArray, x: float, y: float) -> float:
    """Arc length of the polyline point nearest to (x, y), searching every leg."""
    leg, t = nearest_on_legs(points, lengths, 0, lengths.size, x, y)
    return float(lengths[:leg].sum() + t * lengths[leg])

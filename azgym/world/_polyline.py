"""A route's polyline for the drivers, compiled: they ask where they are on it every physics step.

:func:`nearest_on_legs` is the projection both route drivers make (the forklift's pure pursuit,
:mod:`azgym.world.driver`, and the robot's, :mod:`azgym.world.robot`): each leg's nearest point
clamped to the leg, the nearest of them, the first on a tie. :func:`point_at` is the point a
given distance along the route, the one they steer toward. Their arithmetic is the numpy and
Python expressions' they replace, operation for operation (``np.hypot`` is the C library's
``hypot``, which numba calls too), so the routes are driven the same to the last bit, without
a dozen numpy calls on a few legs each physics step.
"""

from __future__ import annotations

import math

from azgym.jit import jit

__all__ = ["nearest_on_legs", "point_at"]


@jit
def nearest_on_legs(points, lengths, first, stop, x, y):
    """(leg, t) of the point nearest to (x, y) on legs ``first`` to ``stop − 1``.

    Leg k runs from ``points[k]`` to ``points[k + 1]`` and is ``lengths[k]`` long; its point
    nearest to (x, y) is ``points[k] + t (points[k + 1] − points[k])``, t clamped to [0, 1].
    Returns (−1, NaN) when there is no leg to search.
    """
    best_leg = -1
    best_t = math.nan
    best_distance = math.inf
    for k in range(first, stop):
        ax = points[k, 0]
        ay = points[k, 1]
        abx = points[k + 1, 0] - ax
        aby = points[k + 1, 1] - ay
        squared = lengths[k] * lengths[k]
        t = ((x - ax) * abx + (y - ay) * aby) / (1e-300 if squared < 1e-300 else squared)
        if t <= 0.0:  # np.clip's comparisons: NaN stays NaN, −0 becomes 0
            t = 0.0
        elif t > 1.0:
            t = 1.0
        distance = math.hypot(ax + t * abx - x, ay + t * aby - y)
        if math.isnan(distance):  # numpy's argmin stops at the first NaN
            return k, t
        if best_leg < 0 or distance < best_distance:
            best_leg = k
            best_t = t
            best_distance = distance
    return best_leg, best_t


@jit
def point_at(points, lengths, s):
    """The point (x, y) of the polyline at arc length ``s`` (``lengths``: its legs' lengths).

    The legs' lengths are taken off ``s`` one after the other until it falls within one (past
    the end: the last point); a leg of no length is its start.
    """
    last = lengths.size - 1
    for k in range(lengths.size):
        length = lengths[k]
        if s <= length or k == last:
            t = 0.0
            if length != 0.0:
                t = s / length
                if 1.0 < t:  # Python's min(t, 1.0): NaN stays NaN
                    t = 1.0
            return (points[k, 0] + t * (points[k + 1, 0] - points[k, 0]),
                    points[k, 1] + t * (points[k + 1, 1] - points[k, 1]))
        s -= length
    return points[-1, 0], points[-1, 1]

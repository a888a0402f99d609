"""The occluders and the rays through them: the segment arithmetic every geometry kernel shares.

Occluders are vertical segments standing on the floor — the faces of shelf racks and the walls —
each a row (x1, y1, x2, y2, height, reflectivity) of the table
:func:`azgym.site.elements.occluder_table` makes. A ray from the camera (height z_c) to a point
at height z crosses an occluder at a fraction t of its horizontal length; it is blocked there only
if its height z_c + t (z − z_c) is below the occluder's top.

This module holds that arithmetic: where two segments cross (:func:`crossing`, which the direct
views and the mirror images inline into their loops), whether a ray is blocked (:func:`blocked`)
and the range sensor's rays (:func:`ray_ranges`, for the Navigate environment). The helpers the
beacon × occluder loops call take scalars, never arrays: numba counts the references to an array
passed to a function, an atomic operation per call even when the call is inlined, and that
doubled the time of a frame.
"""

from __future__ import annotations

import math

from azgym.jit import jit
from azgym.site.elements import SEG_HEIGHT, SEG_X1, SEG_X2, SEG_Y1, SEG_Y2

__all__ = ["CROSSING_EPS", "blocked", "crossing", "ray_ranges"]

CROSSING_EPS = 1e-9
"""Tolerance of the crossing tests: a touch at a ray's or segment's very end counts as none."""


@jit(inline="always")
def crossing(px, py, qx, qy, ax, ay, bx, by):
    """Where segment P→Q crosses segment A→B: (t along PQ, u along AB), or (-1, -1) if not."""
    rx = qx - px
    ry = qy - py
    sx = bx - ax
    sy = by - ay
    den = rx * sy - ry * sx
    if den == 0.0:
        return -1.0, -1.0
    wx = ax - px
    wy = ay - py
    t = (wx * sy - wy * sx) / den
    u = (wx * ry - wy * rx) / den
    return t, u


@jit
def blocked(px, py, pz, qx, qy, qz, seg, skip):
    """Whether the straight ray from P to Q (with heights) is blocked by an occluder.

    ``seg`` rows are an occluder table's (``SEG_*`` columns); row ``skip`` is ignored (the mirror of
    a reflection). Crossings at the ray's very ends do not count, so a beacon mounted on a wall is
    not hidden by that wall.
    """
    for s in range(seg.shape[0]):
        if s == skip:
            continue
        t, u = crossing(px, py, qx, qy, seg[s, SEG_X1], seg[s, SEG_Y1], seg[s, SEG_X2],
                        seg[s, SEG_Y2])
        if CROSSING_EPS < t < 1.0 - CROSSING_EPS and -CROSSING_EPS <= u <= 1.0 + CROSSING_EPS:
            if pz + t * (qz - pz) < seg[s, SEG_HEIGHT]:
                return True
    return False


@jit
def ray_ranges(x, y, heading, seg, count, max_range, out):
    """Distances to the nearest occluder along ``count`` rays around (x, y): a range sensor.

    The rays are evenly spaced, the first along ``heading``; ranges are capped at ``max_range``.
    """
    for r in range(count):
        angle = heading + 2.0 * math.pi * r / count
        qx = x + max_range * math.cos(angle)
        qy = y + max_range * math.sin(angle)
        nearest = 1.0
        for s in range(seg.shape[0]):
            t, u = crossing(x, y, qx, qy, seg[s, SEG_X1], seg[s, SEG_Y1], seg[s, SEG_X2],
                            seg[s, SEG_Y2])
            if 0.0 <= t < nearest and 0.0 <= u <= 1.0:
                nearest = t
        out[r] = nearest * max_range

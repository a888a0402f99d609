"""Mirror images (ghosts): beacons seen in the reflective faces of racks and walls.

A reflective occluder (reflectivity > 0) shows a mirror image of a beacon where the law of
reflection puts it, if the reflection point lies on the segment (below its top) and both legs,
camera to mirror and mirror to beacon, are clear
(:func:`~azgym.sensing.geometry.occluders.blocked`). The ghost carries the real beacon's id and
row, labelled GHOST. :func:`mirror_view` loops over mirrors × beacons with the cheap tests of
:func:`_mirror_image` first, scalars only, and appends its detections to the list of
:mod:`azgym.sensing.geometry.detections` after the direct views.
"""

from __future__ import annotations

import math

from azgym.jit import jit
from azgym.sensing.geometry.detections import list_detection
from azgym.sensing.geometry.occluders import CROSSING_EPS, blocked, crossing
from azgym.sensing.labels import GHOST
from azgym.site.elements import SEG_HEIGHT, SEG_REFLECTIVITY, SEG_X1, SEG_X2, SEG_Y1, SEG_Y2

__all__ = ["mirror_view"]


@jit(inline="always")
def _mirror_image(cx, cy, cz, px, py, pz, ax, ay, bx, by, top, reflectivity, limit2,
                  min_elevation):
    """Where the camera would see the beacon at P in the mirror A→B: (whether, mx, my, t).

    The beacon's mirror image B' = (mx, my) in the mirror's line gives the reflection point R at
    the fraction t of C→B' where it crosses the line. Seen when camera and beacon are in front of
    the mirror, R lies on the segment and below its ``top`` (heights vary linearly along the
    unfolded path), the elevation is at least ``min_elevation`` and the reflected flux,
    ``reflectivity`` / path², is at least that of a direct beacon at the range √``limit2``.
    Whether both legs C→R and R→P are clear is left to the caller.
    """
    sx = bx - ax
    sy = by - ay
    length2 = sx * sx + sy * sy
    if length2 == 0.0:
        return False, 0.0, 0.0, 0.0  # a mirror of no length
    side_c = sx * (cy - ay) - sy * (cx - ax)
    side_b = sx * (py - ay) - sy * (px - ax)
    if side_c * side_b <= 0.0:
        return False, 0.0, 0.0, 0.0  # not both in front of the mirror
    k = ((px - ax) * sx + (py - ay) * sy) / length2
    mx = 2.0 * (ax + k * sx) - px
    my = 2.0 * (ay + k * sy) - py
    dx = mx - cx
    dy = my - cy
    path2 = dx * dx + dy * dy
    dz = pz - cz
    if reflectivity * limit2 < path2 + dz * dz:
        return False, 0.0, 0.0, 0.0  # too faint
    path = math.sqrt(path2)
    if path < CROSSING_EPS or math.atan2(dz, path) < min_elevation:
        return False, 0.0, 0.0, 0.0
    t, u = crossing(cx, cy, mx, my, ax, ay, bx, by)
    if not (0.0 < t < 1.0 and 0.0 <= u <= 1.0):
        return False, 0.0, 0.0, 0.0  # the reflection point is off the segment (its extension)
    if cz + t * dz >= top:
        return False, 0.0, 0.0, 0.0  # the ray would pass over the mirror's top
    return True, mx, my, t


@jit
def mirror_view(eye, lens, beacon_xyz, beacon_width, seg, found, found_ints, count):
    """List the ghosts, mirror images of beacons in reflective occluders, after ``count`` others.

    A ghost is seen in the direction of the beacon's mirror image (:func:`_mirror_image`) when
    both legs of its path, camera to mirror and mirror to beacon, are clear; it is as bright as a
    direct beacon over the unfolded path, times the mirror's reflectivity. Listed mirror by
    mirror, beacon by beacon, into ``found`` and ``found_ints`` (rows ``FOUND_*``) from column
    ``count`` on, as far as they reach; returns the new count.
    """
    cx, cy, cz = eye
    min_elevation, max_range = lens
    limit2 = max_range * max_range
    for s in range(seg.shape[0]):
        reflectivity = seg[s, SEG_REFLECTIVITY]
        if reflectivity <= 0.0:
            continue  # not a mirror
        ax, ay, bx, by = seg[s, SEG_X1], seg[s, SEG_Y1], seg[s, SEG_X2], seg[s, SEG_Y2]
        top = seg[s, SEG_HEIGHT]
        for b in range(beacon_xyz.shape[0]):
            px, py, pz = beacon_xyz[b, 0], beacon_xyz[b, 1], beacon_xyz[b, 2]
            seen, mx, my, t = _mirror_image(cx, cy, cz, px, py, pz, ax, ay, bx, by, top,
                                            reflectivity, limit2, min_elevation)
            if not seen or count >= found.shape[1]:
                continue
            dx = mx - cx
            dy = my - cy
            dz = pz - cz
            rx, ry, rz = cx + t * dx, cy + t * dy, cz + t * dz  # the reflection point
            if blocked(cx, cy, cz, rx, ry, rz, seg, s) or blocked(rx, ry, rz, px, py, pz, seg, s):
                continue
            path2 = dx * dx + dy * dy
            path = math.sqrt(path2)
            list_detection(found, found_ints, count, math.atan2(dy, dx), math.atan2(dz, path),
                           1.0, reflectivity * limit2 / (path2 + dz * dz),
                           math.atan2(0.5 * beacon_width[b], path), b, GHOST)
            count += 1
    return count

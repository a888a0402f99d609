"""Beacons seen directly, with partial occlusion: their covers and the visible part's centroid.

A beacon has a horizontal width W and so an angular extent ±atan(W / 2D) at horizontal distance
D. Occluders in front of it (:mod:`azgym.sensing.geometry.occluders`) cover parts of that extent,
and the measured azimuth is the centroid of what stays visible: the paper's coverage error,
eq. 2, arising from geometry. :func:`direct_view` loops over beacons × occluders with cheap
rejection tests first (:func:`_cover`); angles come from ``atan2`` only for the few candidates
that survive, and the helpers the loop calls take scalars, never arrays (see the occluders
module). Its detections go into the list of :mod:`azgym.sensing.geometry.detections`.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit, wrap_compiled
from azgym.sensing.geometry.detections import list_detection
from azgym.sensing.geometry.occluders import CROSSING_EPS, crossing
from azgym.sensing.geometry.ordering import stable_order
from azgym.sensing.labels import DIRECT, MOVED, PARTIAL
from azgym.site.elements import SEG_HEIGHT, SEG_X1, SEG_X2, SEG_Y1, SEG_Y2

__all__ = ["direct_view"]

# Rows of the scratch array of one beacon's covers: the angular interval each occluder hides.
_COVER_LO = 0
_COVER_HI = 1
_COVER_ROWS = 2
# Rows of the scratch array of the occluders' end points as the camera sees them (_ends_from).
_EX1, _EY1, _R1, _T1, _EX2, _EY2, _R2, _T2 = range(8)
_END_ROWS = 8

_BEFORE_BEACON = 1e-7
"""An occluder covers a beacon only if it crosses the ray before this share short of the beacon
(a beacon mounted on a face is not covered by that face)."""
_SIDE_MARGIN = 1e-12
"""Slack of the cheap side test against rounding, so that a touching occluder is examined."""
_HIDDEN_SHARE = 1e-12
"""A beacon whose visible part is at most this share of its half-extent counts as hidden."""


@jit(inline="always")
def _cover(cx, cy, cz, dx, dy, dz, dist, alpha, half, x1, y1, x2, y2, top, ex1, ey1, r1, t1,
           ex2, ey2, r2, t2):
    """The part of a beacon's angular extent an occluder hides: (whether any, lo, hi).

    The beacon is seen from the camera (cx, cy, cz) at the offset (dx, dy, dz), horizontal
    distance ``dist``, in the direction ``alpha`` with half-extent ``half`` [rad]; the occluder
    stands from (x1, y1) to (x2, y2), ``top`` high. It hides the interval between its end points'
    directions, lo and hi relative to ``alpha`` and cut to [−half, half], if it stands in front
    of the beacon and the ray passes below its top, both checked at the middle of the overlap.
    """
    # Both end points strictly on one side of the beacon's extent: no overlap. The side is the
    # sign of the cross product with the centre direction, compared with sin(h).
    c1 = dx * ey1 - dy * ex1
    c2 = dx * ey2 - dy * ex2
    n1 = r1 * dist
    n2 = r2 * dist
    margin = math.sin(half) + _SIDE_MARGIN
    if (c1 > margin * n1 and c2 > margin * n2) or (c1 < -margin * n1 and c2 < -margin * n2):
        return False, 0.0, 0.0
    if dx * ex1 + dy * ey1 <= 0.0 and dx * ex2 + dy * ey2 <= 0.0:
        return False, 0.0, 0.0  # entirely behind the camera
    a1 = wrap_compiled(t1 - alpha)
    a2 = wrap_compiled(t2 - alpha)
    if max(a1, a2) - min(a1, a2) >= math.pi:
        return False, 0.0, 0.0  # the segment passes behind the camera
    lo = max(min(a1, a2), -half)
    hi = min(max(a1, a2), half)
    if hi <= lo:
        return False, 0.0, 0.0
    mid = alpha + 0.5 * (lo + hi)
    t, u = crossing(cx, cy, cx + math.cos(mid) * dist, cy + math.sin(mid) * dist, x1, y1, x2, y2)
    if not (CROSSING_EPS < t < 1.0 - _BEFORE_BEACON and -CROSSING_EPS <= u <= 1.0 + CROSSING_EPS):
        return False, 0.0, 0.0  # not between the camera and the beacon
    if cz + t * dz >= top:
        return False, 0.0, 0.0  # the ray passes over the occluder
    return True, lo, hi


@jit(inline="always")
def _ends_from(cx, cy, seg):
    """Each occluder's end points from the camera: rows ``_EX1`` … ``_T2`` (offset, length, angle).

    The same for every beacon of a frame, so worked out once per frame, not per beacon.
    """
    ends = np.empty((_END_ROWS, seg.shape[0]))
    for s in range(seg.shape[0]):
        ex1 = seg[s, SEG_X1] - cx
        ey1 = seg[s, SEG_Y1] - cy
        ex2 = seg[s, SEG_X2] - cx
        ey2 = seg[s, SEG_Y2] - cy
        ends[_EX1, s] = ex1
        ends[_EY1, s] = ey1
        ends[_R1, s] = math.sqrt(ex1 * ex1 + ey1 * ey1)
        ends[_T1, s] = math.atan2(ey1, ex1)
        ends[_EX2, s] = ex2
        ends[_EY2, s] = ey2
        ends[_R2, s] = math.sqrt(ex2 * ex2 + ey2 * ey2)
        ends[_T2, s] = math.atan2(ey2, ex2)
    return ends


@jit(inline="always")
def _visible_part(covers, n_covers, half):
    """(length, first moment) of [−half, half] minus the union of the first ``n_covers`` covers.

    A sweep over the covers sorted by their start; the visible part's centroid is
    moment / length.
    """
    order = stable_order(covers[_COVER_LO], n_covers)  # ties: the union is the same
    cursor = -half
    length = 0.0
    moment = 0.0
    for k in range(n_covers):
        lo = covers[_COVER_LO, order[k]]
        hi = covers[_COVER_HI, order[k]]
        if lo > cursor:
            length += lo - cursor
            moment += 0.5 * (lo * lo - cursor * cursor)
        cursor = max(cursor, hi)
    if half > cursor:
        length += half - cursor
        moment += 0.5 * (half * half - cursor * cursor)
    return length, moment


@jit
def direct_view(eye, lens, beacon_xyz, beacon_width, moved, seg, found, found_ints):
    """List the beacons seen directly (rows ``FOUND_*``, see ``frame.collect``); returns how many.

    For a beacon at horizontal distance D the extent is ±h, h = atan(W / 2D), around its centre
    direction α. Every occluder in front of it covers part of the extent (:func:`_cover`); the
    azimuth is the centroid of the visible part (exact for a beacon of uniform brightness across
    its width) and the label DIRECT, PARTIAL or MOVED. A beacon fully covered, below the lens'
    lowest elevation or beyond its range is not listed.
    """
    cx, cy, cz = eye
    min_elevation, max_range = lens
    covers = np.empty((_COVER_ROWS, seg.shape[0]))  # an occluder covers a beacon at most once
    ends = _ends_from(cx, cy, seg)
    count = 0
    for b in range(beacon_xyz.shape[0]):
        dx = beacon_xyz[b, 0] - cx
        dy = beacon_xyz[b, 1] - cy
        dz = beacon_xyz[b, 2] - cz
        dist = math.sqrt(dx * dx + dy * dy)
        if dist < CROSSING_EPS or dist * dist + dz * dz > max_range * max_range:
            continue
        if math.atan2(dz, dist) < min_elevation:
            continue
        alpha = math.atan2(dy, dx)
        half = math.atan2(0.5 * beacon_width[b], dist)
        n_covers = 0
        for s in range(seg.shape[0]):
            covered, lo, hi = _cover(cx, cy, cz, dx, dy, dz, dist, alpha, half, seg[s, SEG_X1],
                                     seg[s, SEG_Y1], seg[s, SEG_X2], seg[s, SEG_Y2],
                                     seg[s, SEG_HEIGHT], ends[_EX1, s], ends[_EY1, s],
                                     ends[_R1, s], ends[_T1, s], ends[_EX2, s], ends[_EY2, s],
                                     ends[_R2, s], ends[_T2, s])
            if covered:
                covers[_COVER_LO, n_covers] = lo
                covers[_COVER_HI, n_covers] = hi
                n_covers += 1
        azimuth, visible, label = alpha, 1.0, DIRECT
        if n_covers > 0:
            length, moment = _visible_part(covers, n_covers, half)
            if length <= _HIDDEN_SHARE * half:
                continue  # fully covered: hidden
            azimuth, visible, label = alpha + moment / length, length / (2.0 * half), PARTIAL
        brightness = max(1.0, visible * max_range * max_range / (dx * dx + dy * dy + dz * dz))
        list_detection(found, found_ints, count, azimuth, math.atan2(dz, math.hypot(dx, dy)),
                       visible, brightness, math.atan2(0.5 * beacon_width[b], math.hypot(dx, dy)),
                       b, MOVED if moved[b] else label)
        count += 1
    return count

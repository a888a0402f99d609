"""What the upward camera sees, from geometry: line of sight in 2.5-D, partial occlusion, mirrors.

Occluders are vertical segments standing on the floor — the faces of shelf racks and the walls —
each with a height and a reflectivity. A ray from the camera (height z_c) to a point at height z
crosses an occluder at a fraction t of its horizontal length; it is blocked there only if its
height z_c + t (z − z_c) is below the occluder's top. A beacon has a horizontal width W and so an
angular extent ±atan(W / 2D); occluders in front of it cover parts of that extent, and the
measured azimuth is the centroid of what stays visible (the paper's coverage error, eq. 2, arising
from geometry). A reflective occluder shows a mirror image of a beacon where the law of reflection
puts it, if the reflection point lies on the segment (below its top) and both legs are clear.

All kernels are compiled (numba) loops over beacons × occluders with cheap rejection tests first;
angles come from ``atan2`` only for the few candidates that survive. The helpers those loops call
per beacon-occluder pair take scalars, never arrays: numba counts the references to an array
passed to a function, an atomic operation per call even when the call is inlined, and that
doubled the time of a frame.

A frame passes through two kernels, each writing packed arrays (one float and one integer array,
so that the sensor hands them over whole) whose rows are named by the constants below:
:func:`collect` lists the frame's detections (rows ``FOUND_*``) and :func:`finish` turns them into
the camera's measurements, sorted by azimuth (rows ``FRAME_*``, which
:class:`~azgym.sensing.geometry.sensor.FrameBuffers` reads).
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit, wrap_compiled
from azgym.sensing.labels import DIRECT, GHOST, MISIDENTIFIED, MOVED, PARTIAL
from azgym.sensing.misread import misread_row
from azgym.sensing.protocol import AZIMUTH, BEACON, ID, LABEL, MIRRORED, TRUE_AZIMUTH, VISIBLE

# Rows of the detections :func:`collect` lists, before noise (``found`` floats, ``found_ints``).
FOUND_AZIMUTH = 0
"""Azimuth in the world frame [rad]."""
FOUND_ELEVATION = 1
"""Elevation above the horizon [rad]."""
FOUND_VISIBLE = 2
"""Visible share of the beacon's width (1 for a ghost)."""
FOUND_BRIGHTNESS = 3
"""Received flux over the detection threshold (>= 1)."""
FOUND_HALF_WIDTH = 4
"""Angular half-width of the whole beacon [rad]."""
FOUND_FLOAT_ROWS = 5
"""Rows of ``found``."""
FOUND_BEACON = 0
"""Map row of the beacon."""
FOUND_LABEL = 1
"""Cause of the detection (:mod:`azgym.sensing.labels`)."""
FOUND_INT_ROWS = 2
"""Rows of ``found_ints``."""

# Rows of a finished frame, sorted by measured azimuth (``FrameBuffers.floats`` and ``.ints``).
# They are laid out as an Observation's packed arrays (azgym.sensing.protocol): rows 0-1 are its
# ``measured``, rows 2-3 its ``true``, and the int rows its ``ints``, so that a frame becomes an
# observation by copying row blocks, not by rearranging them.
FRAME_AZIMUTH = AZIMUTH
"""Measured azimuth in the camera frame [rad]."""
FRAME_QUALITY = AZIMUTH + 1
"""log10 of the brightness over the detection threshold (>= 0)."""
FRAME_TRUE_AZIMUTH = 2 + TRUE_AZIMUTH
"""Noise-free azimuth in the camera frame [rad]."""
FRAME_VISIBLE = 2 + VISIBLE
"""Visible share of the beacon's width."""
FRAME_ELEVATION = 4
"""Elevation above the horizon [rad]."""
FRAME_HALF_WIDTH = 5
"""Angular half-width of the whole beacon [rad]."""
FRAME_FLOAT_ROWS = 6
"""Rows of ``FrameBuffers.floats``."""
FRAME_ID = ID
"""Decoded id, −1 for padding."""
FRAME_BEACON = BEACON
"""Map row of the true beacon."""
FRAME_LABEL = LABEL
"""Cause of the detection."""
FRAME_MIRRORED = MIRRORED
"""1 for a mirror image, else 0."""
FRAME_INT_ROWS = 4
"""Rows of ``FrameBuffers.ints``."""

# Rows of the scratch array of one beacon's covers: the angular interval each occluder hides.
_COVER_LO = 0
_COVER_HI = 1
_COVER_ROWS = 2

_EPS = 1e-9
"""Tolerance of the crossing tests: a touch at a ray's or segment's very end counts as none."""
_BEFORE_BEACON = 1e-7
"""An occluder covers a beacon only if it crosses the ray before this share short of the beacon
(a beacon mounted on a face is not covered by that face)."""
_SIDE_MARGIN = 1e-12
"""Slack of the cheap side test against rounding, so that a touching occluder is examined."""
_HIDDEN_SHARE = 1e-12
"""A beacon whose visible part is at most this share of its half-extent counts as hidden."""


@jit(inline="always")
def _crossing(px, py, qx, qy, ax, ay, bx, by):
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

    ``seg`` rows are (x1, y1, x2, y2, height, reflectivity); row ``skip`` is ignored (the mirror of
    a reflection). Crossings at the ray's very ends do not count, so a beacon mounted on a wall is
    not hidden by that wall.
    """
    for s in range(seg.shape[0]):
        if s == skip:
            continue
        t, u = _crossing(px, py, qx, qy, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3])
        if _EPS < t < 1.0 - _EPS and -_EPS <= u <= 1.0 + _EPS:
            if pz + t * (qz - pz) < seg[s, 4]:
                return True
    return False


@jit(inline="always")
def _cover(cx, cy, cz, dx, dy, dz, dist, alpha, half, x1, y1, x2, y2, top):
    """The part of a beacon's angular extent an occluder hides: (whether any, lo, hi).

    The beacon is seen from the camera (cx, cy, cz) at the offset (dx, dy, dz), horizontal
    distance ``dist``, in the direction ``alpha`` with half-extent ``half`` [rad]; the occluder
    stands from (x1, y1) to (x2, y2), ``top`` high. It hides the interval between its end points'
    directions, lo and hi relative to ``alpha`` and cut to [−half, half], if it stands in front
    of the beacon and the ray passes below its top, both checked at the middle of the overlap.
    """
    ex1 = x1 - cx
    ey1 = y1 - cy
    ex2 = x2 - cx
    ey2 = y2 - cy
    # Both end points strictly on one side of the beacon's extent: no overlap. The side is the
    # sign of the cross product with the centre direction, compared with sin(h).
    c1 = dx * ey1 - dy * ex1
    c2 = dx * ey2 - dy * ex2
    n1 = math.sqrt(ex1 * ex1 + ey1 * ey1) * dist
    n2 = math.sqrt(ex2 * ex2 + ey2 * ey2) * dist
    margin = math.sin(half) + _SIDE_MARGIN
    if (c1 > margin * n1 and c2 > margin * n2) or (c1 < -margin * n1 and c2 < -margin * n2):
        return False, 0.0, 0.0
    if dx * ex1 + dy * ey1 <= 0.0 and dx * ex2 + dy * ey2 <= 0.0:
        return False, 0.0, 0.0  # entirely behind the camera
    a1 = wrap_compiled(math.atan2(ey1, ex1) - alpha)
    a2 = wrap_compiled(math.atan2(ey2, ex2) - alpha)
    if max(a1, a2) - min(a1, a2) >= math.pi:
        return False, 0.0, 0.0  # the segment passes behind the camera
    lo = max(min(a1, a2), -half)
    hi = min(max(a1, a2), half)
    if hi <= lo:
        return False, 0.0, 0.0
    mid = alpha + 0.5 * (lo + hi)
    t, u = _crossing(cx, cy, cx + math.cos(mid) * dist, cy + math.sin(mid) * dist, x1, y1, x2, y2)
    if not (_EPS < t < 1.0 - _BEFORE_BEACON and -_EPS <= u <= 1.0 + _EPS):
        return False, 0.0, 0.0  # not between the camera and the beacon
    if cz + t * dz >= top:
        return False, 0.0, 0.0  # the ray passes over the occluder
    return True, lo, hi


@jit(inline="always")
def _visible_part(covers, n_covers, half):
    """(length, first moment) of [−half, half] minus the union of the first ``n_covers`` covers.

    A sweep over the covers sorted by their start; the visible part's centroid is
    moment / length.
    """
    order = np.argsort(covers[_COVER_LO, :n_covers])
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


@jit(inline="always")
def _list_detection(found, found_ints, k, azimuth, elevation, visible, brightness, half_width,
                    beacon, label):
    """Write detection ``k`` into the packed arrays of :func:`collect` (rows ``FOUND_*``)."""
    found[FOUND_AZIMUTH, k] = azimuth
    found[FOUND_ELEVATION, k] = elevation
    found[FOUND_VISIBLE, k] = visible
    found[FOUND_BRIGHTNESS, k] = brightness
    found[FOUND_HALF_WIDTH, k] = half_width
    found_ints[FOUND_BEACON, k] = beacon
    found_ints[FOUND_LABEL, k] = label


@jit
def direct_view(eye, lens, beacon_xyz, beacon_width, moved, seg, found, found_ints):
    """List the beacons seen directly (rows ``FOUND_*``, see :func:`collect`); returns how many.

    For a beacon at horizontal distance D the extent is ±h, h = atan(W / 2D), around its centre
    direction α. Every occluder in front of it covers part of the extent (:func:`_cover`); the
    azimuth is the centroid of the visible part (exact for a beacon of uniform brightness across
    its width) and the label DIRECT, PARTIAL or MOVED. A beacon fully covered, below the lens'
    lowest elevation or beyond its range is not listed.
    """
    cx, cy, cz = eye
    min_elevation, max_range = lens
    covers = np.empty((_COVER_ROWS, seg.shape[0]))  # an occluder covers a beacon at most once
    count = 0
    for b in range(beacon_xyz.shape[0]):
        dx = beacon_xyz[b, 0] - cx
        dy = beacon_xyz[b, 1] - cy
        dz = beacon_xyz[b, 2] - cz
        dist = math.sqrt(dx * dx + dy * dy)
        if dist < _EPS or dist * dist + dz * dz > max_range * max_range:
            continue
        if math.atan2(dz, dist) < min_elevation:
            continue
        alpha = math.atan2(dy, dx)
        half = math.atan2(0.5 * beacon_width[b], dist)
        n_covers = 0
        for s in range(seg.shape[0]):
            covered, lo, hi = _cover(cx, cy, cz, dx, dy, dz, dist, alpha, half, seg[s, 0],
                                     seg[s, 1], seg[s, 2], seg[s, 3], seg[s, 4])
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
        _list_detection(found, found_ints, count, azimuth, math.atan2(dz, math.hypot(dx, dy)),
                        visible, brightness, math.atan2(0.5 * beacon_width[b], math.hypot(dx, dy)),
                        b, MOVED if moved[b] else label)
        count += 1
    return count


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
    if path < _EPS or math.atan2(dz, path) < min_elevation:
        return False, 0.0, 0.0, 0.0
    t, u = _crossing(cx, cy, mx, my, ax, ay, bx, by)
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
        reflectivity = seg[s, 5]
        if reflectivity <= 0.0:
            continue  # not a mirror
        ax, ay, bx, by, top = seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], seg[s, 4]
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
            _list_detection(found, found_ints, count, math.atan2(dy, dx), math.atan2(dz, path),
                            1.0, reflectivity * limit2 / (path2 + dz * dz),
                            math.atan2(0.5 * beacon_width[b], path), b, GHOST)
            count += 1
    return count


@jit
def collect(eye, lens, beacon_xyz, beacon_width, moved, seg, found, found_ints):
    """Every detection of a frame before noise: direct (or partial, or moved) views, then ghosts.

    Args:
        eye: The camera's position (x, y, z) [m].
        lens: (min_elevation [rad], max_range [m]): the lowest and farthest light it sees.
        beacon_xyz: Where each beacon really is, shape (N, 3) [m].
        beacon_width: Each beacon's width W, shape (N,) [m].
        moved: Whether each beacon was moved after the map was made (label MOVED), shape (N,).
        seg: The occluders, rows (x1, y1, x2, y2, height, reflectivity), shape (S, 6).
        found: Filled with the detections' rows ``FOUND_*``: the azimuth in the world frame,
            elevation, visible share, brightness (received flux over the detection threshold,
            >= 1: the visible share over the squared 3-D distance, times the reflectivity for a
            ghost) and the beacon's angular half-width; shape (FOUND_FLOAT_ROWS, capacity).
        found_ints: Filled with the map row and label of each, shape (FOUND_INT_ROWS, capacity).

    Returns:
        The number of detections M: the direct views (:func:`direct_view`) in map order, then
        the ghosts (:func:`mirror_view`).
    """
    count = direct_view(eye, lens, beacon_xyz, beacon_width, moved, seg, found, found_ints)
    return mirror_view(eye, lens, beacon_xyz, beacon_width, seg, found, found_ints, count)


@jit(inline="always")
def _level_azimuth(azimuth, elevation, pitch, roll):
    """The azimuth a camera tilted by (pitch, roll) sees the direction (elevation, azimuth) at.

    Pitch and roll are right-handed rotations of the camera about its y- and x-axes: the camera
    sees R_y(pitch)ᵀ R_x(roll)ᵀ d for d = (cos e cos α, cos e sin α, sin e).
    """
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    ce = math.cos(elevation)
    dx, dy, dz = ce * math.cos(azimuth), ce * math.sin(azimuth), math.sin(elevation)
    dy, dz = cr * dy + sr * dz, -sr * dy + cr * dz  # undo the roll
    dx = cp * dx - sp * dz  # undo the pitch (only x matters for the azimuth)
    return math.atan2(dy, dx)


@jit(inline="always")
def _write_frame(out_floats, out_ints, order, measured, true_azimuth, ids, mirrored, found,
                 found_ints):
    """Write the detections of ``found`` into the frame (rows ``FRAME_*``) in ``order``.

    Entry k of the frame is detection ``order[k]``, as far as the frame reaches. ``measured``,
    ``true_azimuth``, ``ids`` and ``mirrored`` are per detection, like ``found``.
    """
    for k in range(min(order.size, out_floats.shape[1])):
        m = order[k]
        out_floats[FRAME_AZIMUTH, k] = measured[m]
        out_floats[FRAME_QUALITY, k] = math.log10(found[FOUND_BRIGHTNESS, m])
        out_floats[FRAME_TRUE_AZIMUTH, k] = true_azimuth[m]
        out_floats[FRAME_VISIBLE, k] = found[FOUND_VISIBLE, m]
        out_floats[FRAME_ELEVATION, k] = found[FOUND_ELEVATION, m]
        out_floats[FRAME_HALF_WIDTH, k] = found[FOUND_HALF_WIDTH, m]
        out_ints[FRAME_ID, k] = ids[m]
        out_ints[FRAME_BEACON, k] = found_ints[FOUND_BEACON, m]
        out_ints[FRAME_LABEL, k] = found_ints[FOUND_LABEL, m]
        out_ints[FRAME_MIRRORED, k] = mirrored[m]


@jit(inline="always")
def _pad_frame(out_floats, out_ints, start):
    """Pad the frame from entry ``start`` on: id, beacon and label −1, everything else 0."""
    for k in range(start, out_floats.shape[1]):
        for row in range(FRAME_FLOAT_ROWS):
            out_floats[row, k] = 0.0
        out_ints[FRAME_ID, k] = -1
        out_ints[FRAME_BEACON, k] = -1
        out_ints[FRAME_LABEL, k] = -1
        out_ints[FRAME_MIRRORED, k] = 0


@jit
def finish(found, found_ints, count, heading, tilt, uniforms, delta_d, misdecode_rate, map_ids,
           out_floats, out_ints):
    """Camera-frame azimuths, eq. 1 noise and misread ids, listed by measured azimuth.

    Takes the first ``count`` detections :func:`collect` listed in ``found`` and ``found_ints``
    and writes them into ``out_floats`` and ``out_ints`` (rows ``FRAME_*``), sorted by measured
    azimuth. The outputs may be longer than M = ``count`` (fixed-size observations): the rest is
    padded with id −1, beacon −1, label −1 and zeros; if they are shorter, the detections with the
    largest azimuths are left out. A misread detection's label becomes MISIDENTIFIED in
    ``found_ints`` too.

    A tilted camera (``tilt`` = (pitch, roll)) sees each direction rotated
    (:func:`_level_azimuth`) — the perturbation the paper describes on its bumpy stretch.
    ``uniforms`` (3, M) in [0, 1): the noise (uniform on ±``delta_d``), whether the id is
    misread (at ``misdecode_rate``), and which other map id it is read as (:func:`misread_row`).
    """
    n_map = map_ids.size
    pitch, roll = tilt
    tilted = pitch != 0.0 or roll != 0.0
    beacon, label = found_ints[FOUND_BEACON], found_ints[FOUND_LABEL]
    true_azimuth = np.empty(count)
    measured = np.empty(count)
    ids = np.empty(count, dtype=np.int64)
    mirrored = np.empty(count, dtype=np.int64)
    for m in range(count):
        a = found[FOUND_AZIMUTH, m] - heading
        if tilted:
            a = _level_azimuth(a, found[FOUND_ELEVATION, m], pitch, roll)
        true_azimuth[m] = wrap_compiled(a)
        measured[m] = wrap_compiled(true_azimuth[m] + (2.0 * uniforms[0, m] - 1.0) * delta_d)
        ids[m] = map_ids[beacon[m]]
        mirrored[m] = label[m] == GHOST
        if uniforms[1, m] < misdecode_rate and n_map > 1:
            ids[m] = map_ids[misread_row(beacon[m], uniforms[2, m], n_map)]
            label[m] = MISIDENTIFIED
    order = np.argsort(measured, kind="mergesort")
    _write_frame(out_floats, out_ints, order, measured, true_azimuth, ids, mirrored, found,
                 found_ints)
    _pad_frame(out_floats, out_ints, count)


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
            t, u = _crossing(x, y, qx, qy, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3])
            if 0.0 <= t < nearest and 0.0 <= u <= 1.0:
                nearest = t
        out[r] = nearest * max_range

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
angles come from ``atan2`` only for the few candidates that survive.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit
from azgym.sensing.labels import DIRECT, GHOST, MISIDENTIFIED, MOVED, PARTIAL
from azgym.sensing.misread import misread_row

_EPS = 1e-9
_MAX_COVERS = 16


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


@jit
def direct_view(cx, cy, cz, beacon_xyz, beacon_width, seg, min_elevation, max_range, out_azimuth,
                out_label, out_visible):
    """Azimuth (world frame) and label of every beacon seen directly from the camera.

    For beacon b at horizontal distance D the extent is ±h, h = atan(W / 2D), around its centre
    direction α. Every occluder in front of the beacon (closer along the ray, and tall enough there
    for the ray to pass below its top) covers the angular interval between its end points'
    directions; the visible part of the extent is what no cover reaches. ``out_azimuth`` is the
    centroid of the visible part (exact for a beacon of uniform brightness across its width),
    ``out_label`` DIRECT or PARTIAL, ``out_visible`` the visible share of the width (0: hidden).
    Beacons below ``min_elevation`` [rad] or farther than ``max_range`` [m, 3-D] are not seen.
    """
    covers_lo = np.empty(_MAX_COVERS)
    covers_hi = np.empty(_MAX_COVERS)
    for b in range(beacon_xyz.shape[0]):
        out_visible[b] = 0.0
        out_label[b] = DIRECT
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
        # The extent's edge directions, as unit vectors, for the cheap rejection test.
        n_covers = 0
        for s in range(seg.shape[0]):
            ex1 = seg[s, 0] - cx
            ey1 = seg[s, 1] - cy
            ex2 = seg[s, 2] - cx
            ey2 = seg[s, 3] - cy
            # Both end points strictly on one side of the beacon's extent: no overlap. The side is
            # the sign of the cross product with the centre direction, compared with sin(h).
            c1 = dx * ey1 - dy * ex1
            c2 = dx * ey2 - dy * ex2
            d1 = dx * ex1 + dy * ey1
            d2 = dx * ex2 + dy * ey2
            n1 = math.sqrt(ex1 * ex1 + ey1 * ey1) * dist
            n2 = math.sqrt(ex2 * ex2 + ey2 * ey2) * dist
            margin = math.sin(half) + 1e-12
            if (c1 > margin * n1 and c2 > margin * n2) or (c1 < -margin * n1 and c2 < -margin * n2):
                continue
            if d1 <= 0.0 and d2 <= 0.0:
                continue  # entirely behind the camera
            a1 = math.atan2(ey1, ex1) - alpha
            a2 = math.atan2(ey2, ex2) - alpha
            a1 = a1 - 2.0 * math.pi * math.floor((a1 + math.pi) / (2.0 * math.pi))
            a2 = a2 - 2.0 * math.pi * math.floor((a2 + math.pi) / (2.0 * math.pi))
            lo = min(a1, a2)
            hi = max(a1, a2)
            if hi - lo >= math.pi:
                continue  # the segment passes behind the camera
            lo = max(lo, -half)
            hi = min(hi, half)
            if hi <= lo:
                continue
            # Is the segment in front of the beacon, and tall enough, at the overlap's middle?
            mid = alpha + 0.5 * (lo + hi)
            rx = math.cos(mid)
            ry = math.sin(mid)
            t, u = _crossing(cx, cy, cx + rx * dist, cy + ry * dist, seg[s, 0], seg[s, 1],
                             seg[s, 2], seg[s, 3])
            if not (_EPS < t < 1.0 - 1e-7 and -_EPS <= u <= 1.0 + _EPS):
                continue
            if cz + t * dz >= seg[s, 4]:
                continue  # the ray passes over the occluder
            if n_covers < _MAX_COVERS:
                covers_lo[n_covers] = lo
                covers_hi[n_covers] = hi
                n_covers += 1
        if n_covers == 0:
            out_azimuth[b] = alpha
            out_visible[b] = 1.0
            continue
        # Visible part = [-half, half] minus the union of the covers: sweep the sorted covers.
        order = np.argsort(covers_lo[:n_covers])
        cursor = -half
        length = 0.0
        moment = 0.0
        for k in range(n_covers):
            lo = covers_lo[order[k]]
            hi = covers_hi[order[k]]
            if lo > cursor:
                length += lo - cursor
                moment += 0.5 * (lo * lo - cursor * cursor)
            cursor = max(cursor, hi)
        if half > cursor:
            length += half - cursor
            moment += 0.5 * (half * half - cursor * cursor)
        if length <= 1e-12 * half:
            continue  # fully covered: hidden
        out_azimuth[b] = alpha + moment / length
        out_visible[b] = length / (2.0 * half)
        out_label[b] = PARTIAL


@jit
def mirror_view(cx, cy, cz, beacon_xyz, beacon_width, seg, min_elevation, max_range, out):
    """Ghosts: mirror images of beacons in reflective occluders. Returns how many were found.

    For each reflective segment and beacon on the camera's side of it, the beacon's mirror image
    B' gives the reflection point R where C→B' crosses the mirror's line. A ghost is seen in the
    direction of B' when R lies on the segment, below its top (heights vary linearly along the
    unfolded path), both legs C→R and R→B are clear, the elevation is within the lens' range and
    the reflected flux, reflectivity / path², is at least that of a direct beacon at ``max_range``.
    ``out`` rows get (world azimuth, beacon index, segment index, flux ratio, elevation, angular
    half-width).
    """
    found = 0
    limit2 = max_range * max_range
    for s in range(seg.shape[0]):
        reflectivity = seg[s, 5]
        if reflectivity <= 0.0:
            continue
        ax, ay, bx_, by_ = seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3]
        sx = bx_ - ax
        sy = by_ - ay
        length2 = sx * sx + sy * sy
        if length2 == 0.0:
            continue
        side_c = sx * (cy - ay) - sy * (cx - ax)
        for b in range(beacon_xyz.shape[0]):
            px = beacon_xyz[b, 0]
            py = beacon_xyz[b, 1]
            pz = beacon_xyz[b, 2]
            side_b = sx * (py - ay) - sy * (px - ax)
            if side_c * side_b <= 0.0:
                continue  # not both in front of the mirror
            # Mirror image of the beacon in the segment's line.
            k = ((px - ax) * sx + (py - ay) * sy) / length2
            fx = ax + k * sx
            fy = ay + k * sy
            mx = 2.0 * fx - px
            my = 2.0 * fy - py
            dx = mx - cx
            dy = my - cy
            path2 = dx * dx + dy * dy
            dz = pz - cz
            if reflectivity * limit2 < path2 + dz * dz:
                continue  # too faint
            path = math.sqrt(path2)
            if path < _EPS or math.atan2(dz, path) < min_elevation:
                continue
            t, u = _crossing(cx, cy, mx, my, ax, ay, bx_, by_)
            if not (0.0 < t < 1.0 and 0.0 <= u <= 1.0):
                continue  # the reflection point is off the segment (e.g. on its extension)
            rx = cx + t * dx
            ry = cy + t * dy
            rz = cz + t * dz
            if rz >= seg[s, 4]:
                continue  # the ray would pass over the mirror's top
            if blocked(cx, cy, cz, rx, ry, rz, seg, s) or blocked(rx, ry, rz, px, py, pz, seg, s):
                continue
            if found < out.shape[0]:
                out[found, 0] = math.atan2(dy, dx)
                out[found, 1] = b
                out[found, 2] = s
                out[found, 3] = reflectivity * limit2 / (path2 + dz * dz)
                out[found, 4] = math.atan2(dz, path)
                out[found, 5] = math.atan2(0.5 * beacon_width[b], path)
                found += 1
    return found


@jit
def collect(cx, cy, cz, beacon_xyz, beacon_width, moved, seg, min_elevation, max_range, world,
            elevation, beacon, label, visible, brightness, halfwidth, scratch_azimuth,
            scratch_label, scratch_visible, ghosts):
    """Every detection of a frame before noise: direct (or partial, or moved) views, then ghosts.

    Fills ``world`` (azimuth in the world frame), ``elevation``, ``beacon`` (map row), ``label``,
    ``visible``, ``halfwidth`` (the angular half-width of the whole beacon) and ``brightness``
    (received flux over the detection threshold, >= 1: the visible share over the squared 3-D
    distance, times the reflectivity for a ghost) and returns their count M.
    """
    direct_view(cx, cy, cz, beacon_xyz, beacon_width, seg, min_elevation, max_range,
                scratch_azimuth, scratch_label, scratch_visible)
    count = 0
    for b in range(beacon_xyz.shape[0]):
        if scratch_visible[b] > 0.0:
            world[count] = scratch_azimuth[b]
            dx = beacon_xyz[b, 0] - cx
            dy = beacon_xyz[b, 1] - cy
            dz = beacon_xyz[b, 2] - cz
            elevation[count] = math.atan2(dz, math.hypot(dx, dy))
            halfwidth[count] = math.atan2(0.5 * beacon_width[b], math.hypot(dx, dy))
            brightness[count] = max(1.0, scratch_visible[b] * max_range * max_range
                                    / (dx * dx + dy * dy + dz * dz))
            beacon[count] = b
            label[count] = MOVED if moved[b] else scratch_label[b]
            visible[count] = scratch_visible[b]
            count += 1
    n_ghosts = mirror_view(cx, cy, cz, beacon_xyz, beacon_width, seg, min_elevation, max_range,
                           ghosts)
    for g in range(n_ghosts):
        world[count] = ghosts[g, 0]
        elevation[count] = ghosts[g, 4]
        halfwidth[count] = ghosts[g, 5]
        brightness[count] = ghosts[g, 3]
        beacon[count] = int(ghosts[g, 1])
        label[count] = GHOST
        visible[count] = 1.0
        count += 1
    return count


@jit
def finish(world, elevation, beacon, label, visible, brightness, halfwidth, heading, pitch, roll,
           uniforms, delta_d, misdecode_rate, map_ids, out_floats, out_ints):
    """Camera-frame azimuths, eq. 1 noise and misread ids, listed by measured azimuth.

    ``out_floats`` rows get the measured azimuth, the quality (log10 of the brightness over the
    detection threshold, >= 0), the true azimuth, the visible share, the elevation and the
    beacon's angular half-width;
    ``out_ints`` rows the decoded id, beacon row, label and whether it is a mirror image (1) or
    not (0). They may be longer than M (fixed-size observations): the rest is padded with id −1,
    beacon −1, label −1 and zeros.

    A tilted camera (``pitch`` and ``roll``: right-handed rotations of the camera about its y- and
    x-axes) sees each direction (elevation e, level azimuth α) rotated: its azimuth is that of
    R_y(pitch)ᵀ R_x(roll)ᵀ d for d = (cos e cos α, cos e sin α, sin e) — the perturbation the paper
    describes on its bumpy stretch. ``uniforms`` (3, M) in [0, 1): the noise, whether the id is
    misread, and which other map id it is read as (one of the N − 1 others, uniformly).
    """
    count = world.size
    n_map = map_ids.size
    out_measured, out_quality, out_true, out_visible = (out_floats[0], out_floats[1],
                                                           out_floats[2], out_floats[3])
    out_ids, out_beacon, out_label, out_mirrored = (out_ints[0], out_ints[1], out_ints[2],
                                                    out_ints[3])
    mirrored = np.empty(count, dtype=np.int64)
    measured = np.empty(count)
    ids = np.empty(count, dtype=np.int64)
    true_azimuth = np.empty(count)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    tilted = pitch != 0.0 or roll != 0.0
    for m in range(count):
        a = world[m] - heading
        if tilted:
            ce = math.cos(elevation[m])
            dx, dy, dz = ce * math.cos(a), ce * math.sin(a), math.sin(elevation[m])
            dy, dz = cr * dy + sr * dz, -sr * dy + cr * dz  # undo the roll
            dx = cp * dx - sp * dz  # undo the pitch (only x matters for the azimuth)
            a = math.atan2(dy, dx)
        a = a - 2.0 * math.pi * math.ceil((a - math.pi) / (2.0 * math.pi))  # to (−π, π]
        true_azimuth[m] = a
        noisy = a + (2.0 * uniforms[0, m] - 1.0) * delta_d
        measured[m] = noisy - 2.0 * math.pi * math.ceil((noisy - math.pi) / (2.0 * math.pi))
        ids[m] = map_ids[beacon[m]]
        mirrored[m] = label[m] == GHOST
        if uniforms[1, m] < misdecode_rate and n_map > 1:
            ids[m] = map_ids[misread_row(beacon[m], uniforms[2, m], n_map)]
            label[m] = MISIDENTIFIED
    order = np.argsort(measured, kind="mergesort")
    for k in range(min(count, out_ids.size)):
        m = order[k]
        out_ids[k] = ids[m]
        out_measured[k] = measured[m]
        out_true[k] = true_azimuth[m]
        out_beacon[k] = beacon[m]
        out_label[k] = label[m]
        out_mirrored[k] = mirrored[m]
        out_visible[k] = visible[m]
        out_quality[k] = math.log10(brightness[m])
        out_floats[4, k] = elevation[m]
        out_floats[5, k] = halfwidth[m]
    for k in range(count, out_ids.size):  # padding, where the outputs are longer than M
        out_ids[k] = -1
        out_measured[k] = 0.0
        out_true[k] = 0.0
        out_beacon[k] = -1
        out_label[k] = -1
        out_mirrored[k] = 0
        out_visible[k] = 0.0
        out_quality[k] = 0.0
        out_floats[4, k] = 0.0
        out_floats[5, k] = 0.0


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

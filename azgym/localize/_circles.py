"""The triplet circles: the camera position from the azimuths of three beacons (Sec. 2.5).

Two beacons seen under the angle θ_ij = α_i − α_j put the camera on a circle through both
(the inscribed-angle theorem, eq. 9-11). :func:`circle_row` writes that circle as one linear
equation in (x, y, q = x² + y²), :func:`pair_table` computes it for every pair of a frame's
measurements once (:func:`fill_pair` for one pair, in the frame :func:`pair_frame` sets), and
:func:`solve_triplet` intersects three of them (eq. 7-18) and adds the heading (eq. 19-20).
:func:`distinct_beacons` is the rule that a triplet must see three different beacons, and
:func:`write_ascending` the order a triplet's indices are kept in. ransac, the triplet localizer
and lsq's algebraic start all build on these.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit


@jit(inline="always")
def circle_row(xi, yi, xj, yj, ci, si, cj, sj):
    """The inscribed-angle circle of a beacon pair as a linear equation in (x, y, q = x² + y²).

    From the law of cosines with the cross product (the derivation behind eq. 9-11): the camera C
    sees P_i and P_j under θ_ij = α_i − α_j, so with b_k = P_k − C,
    ``sin θ_ij (b_i · b_j) − cos θ_ij (b_j × b_i) = 0``. This is eq. 11 multiplied through by
    sin θ_ij, which keeps it finite for every θ: at sin θ_ij = 0 it becomes the line through P_i
    and P_j, exactly the limit case of eq. 18, so no threshold switch is needed.

    Note: eq. 11 as printed has the opposite sign on its cot terms; that matches θ_ij = α_j − α_i,
    not eq. 8's α_i − α_j. This form is checked to 1e-10 m on noise-free data by the tests.

    Returns (a_x, a_y, a_q, a_0) with a_x x + a_y y + a_q q + a_0 = 0.
    """
    s = si * cj - ci * sj  # sin(α_i − α_j)
    c = ci * cj + si * sj  # cos(α_i − α_j)
    return (
        -s * (xi + xj) - c * (yj - yi),
        -s * (yi + yj) - c * (xi - xj),
        s,
        s * (xi * xj + yi * yj) - c * (xj * yi - xi * yj),
    )


@jit(inline="always")
def pair_frame(bx, by):
    """The frame the circle equations are written in: the beacons' centroid and their extent L.

    Relative to the centroid and scaled by L, the unknowns (x/L, y/L, q/L²) are all of order one.
    Returns (ox, oy, L).
    """
    n = bx.size
    ox = 0.0
    oy = 0.0
    for m in range(n):
        ox += bx[m]
        oy += by[m]
    ox /= n
    oy /= n
    scale = 0.0
    for m in range(n):
        scale = max(scale, abs(bx[m] - ox), abs(by[m] - oy))
    if scale == 0.0:
        scale = 1.0
    return ox, oy, scale


@jit(inline="always")
def fill_pair(rows, bx, by, ca, sa, ox, oy, scale, i, j):
    """Write the circle equation (``circle_row``) of the pair i < j into ``rows[i, j]``."""
    inv = 1.0 / scale
    r0, r1, r2, r3 = circle_row((bx[i] - ox) * inv, (by[i] - oy) * inv, (bx[j] - ox) * inv,
                                (by[j] - oy) * inv, ca[i], sa[i], ca[j], sa[j])
    rows[i, j, 0] = r0
    rows[i, j, 1] = r1
    rows[i, j, 2] = r2
    rows[i, j, 3] = r3


@jit(inline="always")
def fill_every_pair(rows, bx, by, ca, sa, ox, oy, scale):
    """``fill_pair`` for every pair i < j of the measurements."""
    for i in range(bx.size):
        for j in range(i + 1, bx.size):
            fill_pair(rows, bx, by, ca, sa, ox, oy, scale, i, j)


@jit
def pair_table(bx, by, ca, sa):
    """The circle equation (``circle_row``) of every pair of measurements, computed once a frame.

    Written in the ``pair_frame`` (relative to the beacons' centroid, scaled by their extent L).
    Returns (rows (n, n, 4), ox, oy, L); ``rows[i, j]`` is set for i < j.
    """
    n = bx.size
    ox, oy, scale = pair_frame(bx, by)
    rows = np.zeros((n, n, 4))
    fill_every_pair(rows, bx, by, ca, sa, ox, oy, scale)
    return rows, ox, oy, scale


@jit(inline="always")
def distinct_beacons(a, b, c):
    """Whether three measurements, of the beacons in map rows a, b and c, are of three beacons.

    Two detections of one beacon (a ghost and its beacon) say nothing about the position, so a
    triplet with them is not solved.
    """
    return a != b and b != c and a != c


@jit(inline="always")
def write_ascending(i, j, k, row):
    """Write the triplet (i, j, k) into ``row`` in ascending order, as triplet lists keep it."""
    if i > j:
        i, j = j, i
    if j > k:
        j, k = k, j
    if i > j:
        i, j = j, i
    row[0] = i
    row[1] = j
    row[2] = k


@jit(inline="always")
def solve_triplet(rows, ox, oy, scale, bx, by, ca, sa, i, j, k, degeneracy_tol):
    """Camera position from three azimuths (Sec. 2.5, eq. 7-18) and heading (eq. 19-20).

    Solves the three pairwise circle equations (rows of ``pair_table``, i < j < k) for (x, y, q):
    where the cotangents of eq. 11 are finite this has the same solution as eq. 14-17 (whose rows
    are differences of these circles), and where one is not it contains eq. 18.

    The triplet is rejected when degenerate: all three beacons on a line through C, or C on the
    circle through them (|det| below ``degeneracy_tol`` times the rows' Hadamard bound).

    The heading is the direction of Σ_m (P_m − C) e^{−iα_m}, a circular mean of β_m − α_m weighted
    by distance (eq. 20 uses one beacon; the mean is the same on noise-free data, does not depend on
    the order of the triplet, and weights each beacon by how well it fixes the direction).

    Returns (ok, x, y, h_x, h_y, quality) where (h_x, h_y) is a positive multiple of
    (cos φ, sin φ) and quality = det² / Hadamard bound² in [0, 1] grades the geometry.
    """
    a0, a1, a2, a3 = rows[i, j, 0], rows[i, j, 1], rows[i, j, 2], rows[i, j, 3]
    b0, b1, b2, b3 = rows[j, k, 0], rows[j, k, 1], rows[j, k, 2], rows[j, k, 3]
    c0, c1, c2, c3 = rows[i, k, 0], rows[i, k, 1], rows[i, k, 2], rows[i, k, 3]
    m00 = b1 * c2 - b2 * c1
    m01 = b2 * c0 - b0 * c2
    m02 = b0 * c1 - b1 * c0
    det = a0 * m00 + a1 * m01 + a2 * m02
    hadamard_sq = ((a0 * a0 + a1 * a1 + a2 * a2) * (b0 * b0 + b1 * b1 + b2 * b2)
                   * (c0 * c0 + c1 * c1 + c2 * c2))
    if not det * det > degeneracy_tol * degeneracy_tol * hadamard_sq:
        return False, 0.0, 0.0, 1.0, 0.0, 0.0
    # Cramer's rule for (x, y) with right-hand side (−a3, −b3, −c3).
    inv_det = scale / det
    x = ox - (a3 * m00 + b3 * (a2 * c1 - a1 * c2) + c3 * (a1 * b2 - a2 * b1)) * inv_det
    y = oy - (a3 * m01 + b3 * (a0 * c2 - a2 * c0) + c3 * (a2 * b0 - a0 * b2)) * inv_det
    dxi, dyi = bx[i] - x, by[i] - y
    dxj, dyj = bx[j] - x, by[j] - y
    dxk, dyk = bx[k] - x, by[k] - y
    hx = (dxi * ca[i] + dyi * sa[i]) + (dxj * ca[j] + dyj * sa[j]) + (dxk * ca[k] + dyk * sa[k])
    hy = (dyi * ca[i] - dxi * sa[i]) + (dyj * ca[j] - dxj * sa[j]) + (dyk * ca[k] - dxk * sa[k])
    if not (hx * hx + hy * hy > 0.0 and math.isfinite(x) and math.isfinite(y)):
        return False, 0.0, 0.0, 1.0, 0.0, 0.0
    # (hx, hy) is returned unnormalised: every use of the heading is homogeneous in it.
    return True, x, y, hx, hy, det * det / hadamard_sq

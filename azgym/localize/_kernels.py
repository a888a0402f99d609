"""Compiled (numba) inner loops shared by the localizers.

Everything here works on plain arrays of *usable* measurements — azimuths ``az`` (K,) in the camera
frame, the horizontal positions ``bx, by`` (K,) of the beacons they were decoded as, and the beacon
widths ``width`` (K,) — so the Python side (validation, id lookup) stays out of the hot loops.

Angles between a predicted and a measured direction are computed as ``atan2(cross, dot)`` of the
two direction vectors, which needs no wrapping: the residual ε_i of eq. 23/30 is the signed angle
from the predicted world direction of beacon i to its measured world direction α_i + φ.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit

HALF_PI = 0.5 * math.pi
QUARTER_PI = 0.25 * math.pi
TAN_PI_8 = math.tan(math.pi / 8.0)

VECTOR_MATH = {"reassoc", "nsz", "arcp", "contract"}
"""numba ``fastmath`` flags for loops over many candidates (ransac's scoring, mex's grid rows).

Reassociation lets LLVM vectorise such a loop (4 values at a time); the sums then depend on the
compiled code, which is fixed for a machine, so results stay bit-for-bit repeatable.
"""

SMALL_ANGLE_TAN = 0.1
"""|tan ε| up to which :func:`small_angle` sums atan's Taylor series instead of calling atan2.

At |u| = 0.1 (5.7°) the series to u¹⁷ is exact to 1e-18 rad: as accurate as
:func:`fast_atan2`, and cheaper (one division). Residuals of inliers are far inside this range.
"""
SINGULAR_RATIO = 1e-12
"""A 3×3 normal matrix whose determinant is at most this fraction of its diagonal's product
counts as singular.

The diagonal product is the largest value the determinant of a positive semi-definite matrix
can take (Hadamard's bound), so the ratio is a scale-free conditioning measure; below 1e-12 the
solution would be mostly rounding error.
"""

# Pose arrays (a start pose, a triplet's or the refinement's answer) hold (x, y, cos φ, sin φ) in
# these slots; the refinement's output continues with its cost, iterations and status. Every
# reader and writer indexes them by name, so the layout is stated here once.
POSE_X = 0
"""Slot of a pose array: the camera's x [m]."""
POSE_Y = 1
"""Slot of a pose array: the camera's y [m]."""
POSE_COS = 2
"""Slot of a pose array: cos φ of the heading φ."""
POSE_SIN = 3
"""Slot of a pose array: sin φ."""
POSE_SIZE = 4
"""Length of a pose array."""
REFINED_COST = POSE_SIZE
"""Slot of :func:`refine`'s output: the final cost Σ w_i ε_i² [rad²]."""
REFINED_ITERATIONS = POSE_SIZE + 1
"""Slot of :func:`refine`'s output: the number of Levenberg-Marquardt iterations."""
REFINED_STATUS = POSE_SIZE + 2
"""Slot of :func:`refine`'s output: CONVERGED, MAX_ITER or SINGULAR."""
REFINED_SIZE = POSE_SIZE + 3
"""Length of :func:`refine`'s output."""

# Status codes of the refinement (kept as ints so the kernels stay simple).
CONVERGED = 0
"""Refinement status: a step no longer changed the pose or the cost, or none lowered the cost."""
MAX_ITER = 1
"""Refinement status: stopped at the iteration limit before converging."""
SINGULAR = 2
"""Refinement status: the measurements used do not determine the pose at the answer."""

# Levenberg-Marquardt (Marquardt's scaling: λ multiplies the diagonal of JᵀWJ).
INITIAL_DAMPING = 1e-4
"""λ of the first step: small, so a start near the minimum takes almost a Gauss-Newton step."""
DAMPING_UP = 10.0
"""Factor on λ after a step that raises the cost (or a system that cannot be solved)."""
DAMPING_DOWN = 0.1
"""Factor on λ after a step that lowers the cost."""
DAMPING_FLOOR = 1e-9
"""Smallest λ after a successful step, so a few rejections can bring it back up."""
DAMPING_LIMIT = 1e12
"""λ at which the search for a cost-lowering step stops: the step is then a gradient step shrunk
about 1e12-fold, and if even that does not lower the cost the pose is a (numerical) minimum."""
DIAGONAL_FLOOR = 1e-300
"""Added to each damped diagonal entry to keep it positive: a parameter no measurement constrains
(a zero row and column of JᵀWJ) then gets a zero step instead of making the system singular. It
is far below any real entry."""
FLAT_COST = 1e-15
"""Relative cost decrease below which a step counts as converged: a few ulp of the cost, so the
decrease is rounding noise."""
STEP_POSITION_TOL = 1e-7
"""Position part of the converged-step test [m] (:func:`settled`): |δx| + |δy| at most this."""
STEP_HEADING_TOL = 1e-9
"""Heading part of the converged-step test [rad] (:func:`settled`): |δφ| at most this."""


@jit(inline="always")
def fast_atan2(y: float, x: float) -> float:
    """atan2 accurate to a few ulp (Cephes' rational approximation), cheaper than libm's.

    The argument is reduced to [0, tan(π/8)] with at most one division; the remaining rational
    P(z)/Q(z) is Cephes' ``atan.c`` minimax fit. Max error against numpy: 4.5e-16 rad.
    """
    ax = abs(x)
    ay = abs(y)
    mx = max(ax, ay)
    mn = min(ax, ay)
    big = mn > TAN_PI_8 * mx
    num = mn - mx if big else mn
    den = mn + mx if big else mx
    if den == 0.0:
        den = 1.0
    t = num / den
    z = t * t
    p = (
        (
            ((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z
             - 7.500855792314704667340e1) * z
            - 1.228866684490136173410e2
        ) * z
        - 6.485021904942025371773e1
    )
    q = (
        (
            (((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z
             + 4.328810604912902668951e2) * z
            + 4.853903996359136964868e2
        ) * z
        + 1.945506571482613964425e2
    )
    r = t + t * z * p / q
    if big:
        r += QUARTER_PI
    if ay > ax:
        r = HALF_PI - r
    if x < 0.0:
        r = math.pi - r
    return -r if y < 0.0 else r


@jit(inline="always")
def small_angle(cross: float, dot: float) -> float:
    """atan2(cross, dot) for a direction within a few degrees of ``dot``'s: one division.

    For |u| = |cross/dot| <= SMALL_ANGLE_TAN (5.7°) the Taylor series of atan to u¹⁷ is exact to
    1e-18; wider angles go through :func:`fast_atan2`.
    """
    if dot > 0.0 and abs(cross) <= SMALL_ANGLE_TAN * dot:
        u = cross / dot
        z = u * u
        return u * (1.0 + z * (-1.0 / 3.0 + z * (1.0 / 5.0 + z * (-1.0 / 7.0 + z * (
            1.0 / 9.0 + z * (-1.0 / 11.0 + z * (1.0 / 13.0 + z * (-1.0 / 15.0 + z / 17.0))))))))
    return fast_atan2(cross, dot)


@jit
def solve3(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> float:
    """Solve the 3×3 system ``a @ out = b`` by Cramer's rule; returns det(a) (0 → not solved)."""
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    if det == 0.0 or not math.isfinite(det):
        return 0.0
    c10 = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
    c11 = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
    c12 = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
    c20 = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
    c21 = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
    c22 = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    out[0] = (c00 * b[0] + c10 * b[1] + c20 * b[2]) / det
    out[1] = (c01 * b[0] + c11 * b[1] + c21 * b[2]) / det
    out[2] = (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det
    return det


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


@jit
def pair_table(bx, by, ca, sa):
    """The circle equation (``circle_row``) of every pair of measurements, computed once a frame.

    Coordinates are taken relative to the beacons' centroid and scaled by their extent L, so the
    unknowns (x/L, y/L, q/L²) are all of order one. Returns (rows (n, n, 4), ox, oy, L).
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
    inv = 1.0 / scale
    rows = np.zeros((n, n, 4))
    for i in range(n):
        xi = (bx[i] - ox) * inv
        yi = (by[i] - oy) * inv
        for j in range(i + 1, n):
            xj = (bx[j] - ox) * inv
            yj = (by[j] - oy) * inv
            r0, r1, r2, r3 = circle_row(xi, yi, xj, yj, ca[i], sa[i], ca[j], sa[j])
            rows[i, j, 0] = r0
            rows[i, j, 1] = r1
            rows[i, j, 2] = r2
            rows[i, j, 3] = r3
    return rows, ox, oy, scale


@jit(inline="always")
def distinct_beacons(a, b, c):
    """Whether three measurements, of the beacons in map rows a, b and c, are of three beacons.

    Two detections of one beacon (a ghost and its beacon) say nothing about the position, so a
    triplet with them is not solved.
    """
    return a != b and b != c and a != c


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


@jit(inline="always")
def position_gradient(dx, dy):
    """(∂ε/∂x, ∂ε/∂y) = (−Δy/D², Δx/D²) for a beacon at (Δx, Δy) from the camera; ∂ε/∂φ = 1.

    Returns (ok, ∂ε/∂x, ∂ε/∂y); not ok for a beacon at the camera itself, whose direction (and so
    its residual's gradient) is undefined.
    """
    d2 = dx * dx + dy * dy
    if d2 == 0.0:
        return False, 0.0, 0.0
    return True, -dy / d2, dx / d2


@jit(inline="always")
def determined(det, diag):
    """Whether a 3×3 normal matrix is regular: ``det`` above SINGULAR_RATIO of ``diag``.

    ``det`` is its determinant, ``diag`` the product of its diagonal (the largest value the
    determinant of such a positive semi-definite matrix can take).
    """
    return diag > 0.0 and abs(det) > SINGULAR_RATIO * diag


@jit
def information(bx, by, use, weight, x, y, unit_rows, out):
    """``out`` = Σ_i w_i j_i j_iᵀ over ``use``, with j_i = ∂ε_i/∂(x, y, φ) = (−Δy/D², Δx/D², 1).

    With ``unit_rows`` each j_i is first scaled to unit length. A beacon at (x, y) itself has no
    defined direction and is left out.
    """
    out[:, :] = 0.0
    for m in range(bx.size):
        if not use[m]:
            continue
        ok, jx, jy = position_gradient(bx[m] - x, by[m] - y)
        if not ok:
            continue
        j = (jx, jy, 1.0)
        w = weight[m]
        if unit_rows:
            w /= j[0] * j[0] + j[1] * j[1] + 1.0
        for r in range(3):
            for c in range(3):
                out[r, c] += w * j[r] * j[c]


@jit
def singular_at(bx, by, use, x, y):
    """Whether the azimuths of the beacons in ``use`` leave the pose at (x, y) undetermined.

    The test is on the rank of the Jacobian, scale-free: its rows j_i are normalised to unit
    length (so one beacon very close to the camera, whose row is huge, cannot make the others look
    negligible), and the pose is undetermined unless :func:`determined` accepts Σ ĵ_i ĵ_iᵀ. That
    happens when every beacon lies on one line through the camera, or when the camera is on a
    circle through all of them (the "danger circle" of three beacons).
    """
    matrix = np.empty((3, 3))
    information(bx, by, use, np.ones(bx.size), x, y, True, matrix)
    diag = matrix[0, 0] * matrix[1, 1] * matrix[2, 2]
    c00 = matrix[1, 1] * matrix[2, 2] - matrix[1, 2] * matrix[2, 1]
    c01 = matrix[1, 2] * matrix[2, 0] - matrix[1, 0] * matrix[2, 2]
    c02 = matrix[1, 0] * matrix[2, 1] - matrix[1, 1] * matrix[2, 0]
    det = matrix[0, 0] * c00 + matrix[0, 1] * c01 + matrix[0, 2] * c02
    return not determined(det, diag)


@jit(inline="always")
def residuals(bx, by, ca, sa, weight, use, x, y, ch, sh, eps):
    """ε_i of eq. 23/30 at pose (x, y, φ) into ``eps`` (for ``use[i]``); returns Σ w_i ε_i²."""
    cost = 0.0
    for m in range(bx.size):
        if not use[m]:
            continue
        dx = bx[m] - x
        dy = by[m] - y
        mx = ca[m] * ch - sa[m] * sh  # measured world direction cos(α_m + φ)
        my = sa[m] * ch + ca[m] * sh
        e = small_angle(dx * my - dy * mx, dx * mx + dy * my)
        eps[m] = e
        cost += weight[m] * e * e
    return cost


@jit(inline="always")
def normal_equations(bx, by, weight, use, eps, x, y, jtj, rhs):
    """The Gauss-Newton system at (x, y): JᵀWJ into ``jtj``, −JᵀWε into ``rhs``.

    ε are the residuals ``eps`` at (x, y); the rows of J are (∂ε_i/∂x, ∂ε_i/∂y) of
    :func:`position_gradient` and ∂ε_i/∂φ = 1 (eq. 28-33).
    """
    jtj[:, :] = 0.0
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    for m in range(bx.size):
        if not use[m]:
            continue
        ok, j0, j1 = position_gradient(bx[m] - x, by[m] - y)
        if not ok:
            continue
        w = weight[m]
        e = eps[m]
        jtj[0, 0] += w * j0 * j0
        jtj[0, 1] += w * j0 * j1
        jtj[0, 2] += w * j0
        jtj[1, 1] += w * j1 * j1
        jtj[1, 2] += w * j1
        jtj[2, 2] += w
        g0 += w * j0 * e
        g1 += w * j1 * e
        g2 += w * e
    jtj[1, 0] = jtj[0, 1]
    jtj[2, 0] = jtj[0, 2]
    jtj[2, 1] = jtj[1, 2]
    rhs[0] = -g0
    rhs[1] = -g1
    rhs[2] = -g2


@jit(inline="always")
def store_refined(out, x, y, ch, sh, cost, iterations, status):
    """Write the refinement's answer into its output array, slot by slot."""
    out[POSE_X] = x
    out[POSE_Y] = y
    out[POSE_COS] = ch
    out[POSE_SIN] = sh
    out[REFINED_COST] = cost
    out[REFINED_ITERATIONS] = iterations
    out[REFINED_STATUS] = status


@jit(inline="always")
def settled(cost, new_cost, dx, dy, dphi):
    """Whether a step (dx, dy, dphi) that lowered the cost to ``new_cost`` ends the iteration.

    It does when the cost dropped by no more than rounding (FLAT_COST), or when the step moved the
    position by at most STEP_POSITION_TOL and the heading by at most STEP_HEADING_TOL. Near the
    minimum each Gauss-Newton step shrinks the distance to it by about the size of the residuals
    (~1e-3 rad), so the pose is then within ~1e-10 m of the minimum; on noise-free data the
    residuals vanish and convergence is quadratic.
    """
    flat = cost - new_cost <= FLAT_COST * cost
    return flat or (abs(dx) + abs(dy) <= STEP_POSITION_TOL and abs(dphi) <= STEP_HEADING_TOL)


@jit
def refine(bx, by, ca, sa, weight, use, x, y, ch, sh, max_iter, out, info_matrix):
    """Levenberg-Marquardt on the mean squared azimuth error (eq. 28-33).

    Minimises Σ w_i ε_i(x, y, φ)² over the measurements with ``use[i]``; eliminating φ first gives
    eq. 29-31's φ'(x, y), so the minimiser is the same as eq. 32-33, but the joint 3-parameter
    problem has a cheap exact Jacobian (:func:`position_gradient`, ∂ε/∂φ = 1). Each step solves
    (JᵀWJ + λ diag JᵀWJ) δ = −JᵀWε with Marquardt's damping λ, raised until the cost drops; it
    stops when a step is :func:`settled`, or when no step lowers the cost any more.

    Writes the pose (``POSE_*`` slots) and the cost, iterations and status (``REFINED_*`` slots)
    into ``out`` (length REFINED_SIZE) and JᵀWJ at the solution into ``info_matrix``.
    """
    phi = math.atan2(sh, ch)
    norm = math.hypot(ch, sh)
    ch /= norm
    sh /= norm
    eps = np.empty(bx.size)  # the residuals at the current pose
    trial_eps = np.empty(bx.size)  # the residuals at the pose a step leads to
    rhs = np.empty(3)
    damped = np.empty((3, 3))
    step = np.empty(3)
    cost = residuals(bx, by, ca, sa, weight, use, x, y, ch, sh, eps)
    lam = INITIAL_DAMPING
    status = MAX_ITER
    it = 0
    while True:
        normal_equations(bx, by, weight, use, eps, x, y, info_matrix, rhs)
        if status == CONVERGED or it >= max_iter:
            break  # JᵀWJ is now evaluated at the final pose
        it += 1
        accepted = False
        # The search for λ stays inline: as a helper taking these arrays it made refine 10 % slower.
        while lam < DAMPING_LIMIT:
            damped[:, :] = info_matrix
            for r in range(3):
                damped[r, r] += lam * info_matrix[r, r] + DIAGONAL_FLOOR
            if solve3(damped, rhs, step) == 0.0:
                lam *= DAMPING_UP
                continue
            new_phi = phi + step[2]
            new_ch = math.cos(new_phi)
            new_sh = math.sin(new_phi)
            new_cost = residuals(bx, by, ca, sa, weight, use, x + step[0], y + step[1], new_ch,
                                 new_sh, trial_eps)
            if new_cost <= cost:
                accepted = True
                if settled(cost, new_cost, step[0], step[1], step[2]):
                    status = CONVERGED
                x += step[0]
                y += step[1]
                phi, ch, sh, cost = new_phi, new_ch, new_sh, new_cost
                eps, trial_eps = trial_eps, eps
                lam = max(lam * DAMPING_DOWN, DAMPING_FLOOR)
                break
            lam *= DAMPING_UP
        if not accepted:  # no step lowers the cost any more: a (numerical) minimum
            status = CONVERGED
    if singular_at(bx, by, use, x, y):
        status = SINGULAR
    store_refined(out, x, y, ch, sh, cost, it, status)

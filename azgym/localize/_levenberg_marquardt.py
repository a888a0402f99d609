"""The refinement (step 6): Levenberg-Marquardt on the squared azimuth errors (eq. 28-33).

:func:`refine` moves a start pose (x, y, φ) to the minimum of Σ w_i ε_i² over chosen
measurements, with ε_i the residual of eq. 23/30 and its exact Jacobian
(:func:`position_gradient`, ∂ε/∂φ = 1). Beside it are its parts (residuals, normal equations,
the step test and the output), the 3×3 solver of its normal equations (:func:`solve3`), and the
regularity tests that tell when the measurements do not determine the pose (:func:`determined`,
:func:`information`, :func:`singular_at`), which the covariance, lsq and mex use as well. Its
output is a pose array continued by the ``REFINED_*`` slots of :mod:`azgym.localize._kernels`.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit
from azgym.localize._angles import small_angle
from azgym.localize._kernels import (
    CONVERGED,
    MAX_ITER,
    POSE_COS,
    POSE_SIN,
    POSE_X,
    POSE_Y,
    REFINED_COST,
    REFINED_ITERATIONS,
    REFINED_STATUS,
    SINGULAR,
)

SINGULAR_RATIO = 1e-12
"""A 3×3 normal matrix whose determinant is at most this fraction of its diagonal's product
counts as singular (:func:`determined`).

The diagonal product is the largest value the determinant of a positive semi-definite matrix
can take (Hadamard's bound), so the ratio is a scale-free conditioning measure; below 1e-12 the
solution would be mostly rounding error.
"""
UNDETERMINED_RATIO = 1e-9
""":func:`singular_at`'s threshold on det(M) / (tr M / 3)³ of the dimensionless information
matrix M: below it the smallest eigenvalue of M is below about 1e-9 of the others, so an azimuth
error δ moves the position by more than ~3e4 · δ times the beacons' distance (metres per metre
for any real δ), and even noise-free azimuths leave it uncertain beyond 1e-6 of the scene: the
refinement's answer is wherever it stopped in a valley, not the pose."""

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
def information(bx, by, use, weight, x, y, out):
    """``out`` = Σ_i w_i j_i j_iᵀ over ``use``, with j_i = ∂ε_i/∂(x, y, φ) = (−Δy/D², Δx/D², 1).

    A beacon at (x, y) itself has no defined direction and is left out.
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
        for r in range(3):
            for c in range(3):
                out[r, c] += w * j[r] * j[c]


@jit
def singular_at(bx, by, use, x, y):
    """Whether the azimuths of the beacons in ``use`` leave the pose at (x, y) undetermined.

    That happens when every beacon lies on one line through the camera, or when the camera is on
    a circle through all of them (the "danger circle" of three beacons). The test is on the
    Jacobian's rows j_i = (−Δy/D², Δx/D², 1), made dimensionless and comparable: the position
    columns are multiplied by the mean distance D̄ of the beacons (so a position error of D̄ and
    a heading error of 1 rad weigh alike), and each row is scaled to unit length (so one beacon
    very close to the camera, whose row is huge, cannot make the others look negligible). The
    pose is undetermined unless det(M) > UNDETERMINED_RATIO · (tr M / 3)³ for M = Σ ĵ_i ĵ_iᵀ, the
    determinant against its largest value for that trace: a near-zero eigenvalue fails it
    whatever the others are. (The determinant against the diagonal's product would not do: it
    does not change when a column is scaled, so a camera 1e-30 m off the line of the beacons,
    whose x column is 1e-30 of the others, would pass it.)
    """
    total = 0.0
    count = 0
    for m in range(bx.size):
        if use[m]:
            d = math.hypot(bx[m] - x, by[m] - y)
            if d > 0.0:
                total += d
                count += 1
    if count == 0:
        return True
    scale = total / count
    matrix = np.zeros((3, 3))
    for m in range(bx.size):
        if not use[m]:
            continue
        ok, jx, jy = position_gradient(bx[m] - x, by[m] - y)
        if not ok:
            continue
        j = (jx * scale, jy * scale, 1.0)
        w = 1.0 / (j[0] * j[0] + j[1] * j[1] + 1.0)
        for r in range(3):
            for c in range(3):
                matrix[r, c] += w * j[r] * j[c]
    c00 = matrix[1, 1] * matrix[2, 2] - matrix[1, 2] * matrix[2, 1]
    c01 = matrix[1, 2] * matrix[2, 0] - matrix[1, 0] * matrix[2, 2]
    c02 = matrix[1, 0] * matrix[2, 1] - matrix[1, 1] * matrix[2, 0]
    det = matrix[0, 0] * c00 + matrix[0, 1] * c01 + matrix[0, 2] * c02
    mean_eigenvalue = (matrix[0, 0] + matrix[1, 1] + matrix[2, 2]) / 3.0
    return not det > UNDETERMINED_RATIO * mean_eigenvalue**3


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
    ch, sh = ch / norm, sh / norm
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
            for r in range(3):  # element by element: an array copy compiles a shape check
                for c in range(3):
                    damped[r, c] = info_matrix[r, c]
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

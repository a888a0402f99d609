"""Step 6 shared by the localizers: refine a start pose on chosen measurements, with a covariance.

The covariance is the error model's: with Jacobian J of the residuals, weights W and the model's
variances Σ (eq. 3: two uniform errors, variance Δ²/3 each), cov = (JᵀWJ)⁻¹ JᵀWΣWJ (JᵀWJ)⁻¹,
which is (JᵀΣ⁻¹J)⁻¹ for the optimally weighted estimator.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from azgym.core import BoolArray, Estimate, FloatArray
from azgym.jit import jit
from azgym.localize import _kernels as K
from azgym.localize._angles import fast_atan2
from azgym.localize._levenberg_marquardt import information, refine, solve3
from azgym.localize.base import Problem
from azgym.site.error_model import ErrorModel

__all__ = ["package", "refine_estimate", "refine_with_covariance"]

MIN_VARIANCE = 1e-300
"""Floor on a measurement's model variance [rad²] before it is inverted into a weight.

With Δα_d = 0 and no coverage error (no coverage term, or a beacon of width 0) the model
variance is 0; the floor keeps its weight finite (1/0 would be infinite). Every real variance is
many orders of magnitude above it.
"""


@jit
def _model_variance(width, dist, delta_d, coverage):
    """The error model's variance of one azimuth (eq. 3): (Δα_d² + Δα_c²)/3, Δα_c of eq. 2."""
    c = fast_atan2(0.5 * width, dist) if coverage else 0.0
    return (delta_d * delta_d + c * c) / 3.0


ON_BEACON_RESOLUTION = 1e-9
"""A camera closer to a beacon than this times its farthest used beacon counts as on it, even
for a beacon of width 0: rounding cannot place it nearer without placing it there."""


@jit
def _beacon_at(bx, by, width, use, x, y):
    """The used beacon (x, y) lies on, or −1: within half its width W, or within rounding of it.

    There the beacon's direction is undefined (its coverage error, eq. 2, reaches 45° at
    D = W/2), so its residual can take any value and its Jacobian row any size.
    """
    farthest = 0.0
    for m in range(bx.size):
        if use[m]:
            farthest = max(farthest, math.hypot(bx[m] - x, by[m] - y))
    for m in range(bx.size):
        if use[m]:
            d = math.hypot(bx[m] - x, by[m] - y)
            if d <= 0.5 * width[m] or d <= ON_BEACON_RESOLUTION * farthest:
                return m
    return -1


@jit
def refine_with_covariance(bx, by, ca, sa, width, use, weighted, delta_d, coverage, start,
                           max_iter, out, cov):
    """Refine the pose array ``start`` on ``use``; fill ``out`` (as ``refine``) and ``cov``.

    ``weighted`` weights each measurement by the inverse of the model's variance at the start
    pose, fixed while the cost is minimised. The covariance takes the model's variances at the
    answer, so it depends on the measurements used and the minimum found, not on where the
    refinement started.

    A refinement that ends on a beacon it used (the camera right under it, or a stall there)
    drops that beacon from ``use``, in place, and refines again from there; ending on a beacon
    again gives status ON_BEACON.
    """
    n = bx.size
    weight = np.ones(n)
    if weighted:
        for m in range(n):
            dist = math.hypot(bx[m] - start[K.POSE_X], by[m] - start[K.POSE_Y])
            weight[m] = 1.0 / max(_model_variance(width[m], dist, delta_d, coverage),
                                  MIN_VARIANCE)
    info = np.zeros((3, 3))
    refine(bx, by, ca, sa, weight, use, start[K.POSE_X], start[K.POSE_Y], start[K.POSE_COS],
           start[K.POSE_SIN], max_iter, out, info)
    under = _beacon_at(bx, by, width, use, out[K.POSE_X], out[K.POSE_Y])
    if out[K.REFINED_STATUS] != K.SINGULAR and under >= 0:
        # Under a beacon (or stalled on one) its azimuth says nothing: drop it, go on without.
        use[under] = False
        refine(bx, by, ca, sa, weight, use, out[K.POSE_X], out[K.POSE_Y], out[K.POSE_COS],
               out[K.POSE_SIN], max_iter, out, info)
        if out[K.REFINED_STATUS] != K.SINGULAR and _beacon_at(
                bx, by, width, use, out[K.POSE_X], out[K.POSE_Y]) >= 0:
            out[K.REFINED_STATUS] = K.ON_BEACON
    var = np.empty(n)
    for m in range(n):
        dist = math.hypot(bx[m] - out[K.POSE_X], by[m] - out[K.POSE_Y])
        var[m] = _model_variance(width[m], dist, delta_d, coverage)
    meat = np.empty((3, 3))
    information(bx, by, use, weight * weight * var, out[K.POSE_X], out[K.POSE_Y], meat)
    inverse = np.empty((3, 3))
    unit = np.zeros(3)
    column = np.empty(3)
    # Element by element throughout: array copies and products compile shape checks that take
    # seconds to compile, for 3×3 matrices.
    for c in range(3):
        unit[:] = 0.0
        unit[c] = 1.0
        if solve3(info, unit, column) == 0.0:
            cov[:, :] = np.nan
            return
        for r in range(3):
            inverse[r, c] = column[r]
    _sandwich(inverse, meat, cov)


@jit
def _sandwich(outer, inner, out):
    """``out`` = outer @ inner @ outer for 3×3 matrices (the sandwich covariance)."""
    left = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            left[r, c] = outer[r, 0] * inner[0, c] + outer[r, 1] * inner[1, c] + \
                outer[r, 2] * inner[2, c]
    for r in range(3):
        for c in range(3):
            out[r, c] = left[r, 0] * outer[0, c] + left[r, 1] * outer[1, c] + \
                left[r, 2] * outer[2, c]


def refine_estimate(
    problem: Problem,
    use: BoolArray,
    start: FloatArray,
    weighted: bool,
    max_iter: int,
    error_model: ErrorModel,
    diagnostics: dict[str, Any] | None = None,
) -> Estimate:
    """Refine the start pose on the measurements in ``use`` and package the :class:`Estimate`.

    Args:
        problem: The frame's usable measurements.
        use: Which of them the refinement uses (they become the estimate's inliers).
        start: Start pose, a pose array (``K.POSE_*`` slots: x, y, cos φ, sin φ).
        weighted: Weight by inverse error-model variance instead of equally (eq. 31).
        max_iter: Iteration limit of Levenberg-Marquardt.
        error_model: Model of the azimuth errors, for weights and covariance.
        diagnostics: Extra entries for ``Estimate.diagnostics``.
    """
    out = np.empty(K.REFINED_SIZE)
    cov = np.empty((3, 3))
    use = use.copy()  # the refinement may drop a beacon the camera is under
    refine_with_covariance(
        problem.bx, problem.by, problem.cos_az, problem.sin_az, problem.width, use, weighted,
        error_model.delta_alpha_d, error_model.coverage, start, max_iter, out, cov,
    )
    return package(problem.expand(use), out, cov, diagnostics or {})


def package(
    inliers: BoolArray, out: FloatArray, cov: FloatArray, diagnostics: dict[str, Any]
) -> Estimate:
    """The :class:`Estimate` from the refinement's output ``out`` (as ``refine`` writes it).

    Args:
        inliers: The measurements used, over all M measurements of the frame.
        out: The refinement's output (``K.POSE_*`` and ``K.REFINED_*`` slots; it may go on).
        cov: The covariance.
        diagnostics: Entries for ``Estimate.diagnostics`` (iterations and cost are added).

    A refinement that ended singular, on a beacon, at the iteration limit or at a non-finite pose
    gives
    ``ok=False`` with the reason: its pose is not the minimum of eq. 31, so it is no answer.
    """
    values = out.tolist()  # Python floats: read one by one, far cheaper than numpy scalars
    status = int(values[K.REFINED_STATUS])
    diagnostics["n_iterations"] = int(values[K.REFINED_ITERATIONS])
    diagnostics["converged"] = status == K.CONVERGED
    diagnostics["cost"] = values[K.REFINED_COST]
    if status == K.SINGULAR:
        return Estimate.failure(
            "the measurements used do not determine the pose (singular geometry)",
            inliers.size, diagnostics,
        )
    if status == K.ON_BEACON:
        return Estimate.failure(
            "the refinement ended on a beacon it used, even after dropping the one it ended on "
            "first: a beacon's direction is undefined right under it",
            inliers.size, diagnostics,
        )
    if status == K.MAX_ITER:
        # A refinement still moving after max_iter steps is crawling along a valley the
        # measurements barely constrain (the camera near the beacons' circle): its pose is
        # wherever it stopped, centimetres to metres from the minimum.
        return Estimate.failure(
            f"the refinement did not converge in {diagnostics['n_iterations']} iterations "
            "(ill-conditioned geometry, e.g. the camera near the circle through the beacons)",
            inliers.size, diagnostics,
        )
    x, y = values[K.POSE_X], values[K.POSE_Y]
    heading = math.atan2(values[K.POSE_SIN], values[K.POSE_COS])
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(heading)):
        return Estimate.failure("the refinement ended at a non-finite pose", inliers.size,
                                diagnostics)
    return Estimate._filled(x, y, heading, inliers, True, "", cov, diagnostics)

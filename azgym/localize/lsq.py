"""Least squares on every measurement: the non-robust baseline, and the solver behind `loo`."""

from __future__ import annotations

import math

import numpy as np

from azgym.core import Estimate
from azgym.hyperparameters import check_flag, check_range
from azgym.jit import jit
from azgym.localize import _kernels as K
from azgym.localize._circles import circle_row
from azgym.localize._levenberg_marquardt import determined, refine, solve3
from azgym.localize.base import MIN_MEASUREMENTS, Localizer, Problem
from azgym.localize.refinement import refine_estimate
from azgym.site.error_model import ErrorModel

__all__ = ["LeastSquares", "algebraic_start", "fit_subset", "heading_sum"]


@jit(inline="always")
def _pool_circles(bx, by, ca, sa, beacon_index, use, ox, oy, scale, ata, atb):
    """Add every pair's circle equation (``circle_row``) to the normal equations AᵀA s = Aᵀb.

    The unknowns are s = (x, y, q) in coordinates relative to (ox, oy) and divided by ``scale``. A
    pair of two detections of one beacon (a ghost) says nothing about the position and is skipped.
    """
    n = bx.size
    for i in range(n):
        if not use[i]:
            continue
        xi = (bx[i] - ox) / scale
        yi = (by[i] - oy) / scale
        for j in range(i + 1, n):
            if not use[j] or beacon_index[j] == beacon_index[i]:
                continue
            xj = (bx[j] - ox) / scale
            yj = (by[j] - oy) / scale
            r0, r1, r2, r3 = circle_row(xi, yi, xj, yj, ca[i], sa[i], ca[j], sa[j])
            row = (r0, r1, r2)
            for a in range(3):
                atb[a] -= row[a] * r3
                for b in range(3):
                    ata[a, b] += row[a] * row[b]


@jit(inline="always")
def heading_sum(bx, by, ca, sa, use, x, y):
    """Σ over ``use`` of the unit vectors along β_i − α_i seen from (x, y): (h_x, h_y).

    Its direction is the circular mean of β_i − α_i, the heading of eq. 19-20 pooled over every
    measurement with equal weights. A beacon at (x, y) itself has no direction and is left out.
    """
    hx = 0.0
    hy = 0.0
    for m in range(bx.size):
        if not use[m]:
            continue
        dx = bx[m] - x
        dy = by[m] - y
        d = math.sqrt(dx * dx + dy * dy)
        if d > 0.0:
            hx += (dx * ca[m] + dy * sa[m]) / d
            hy += (dy * ca[m] - dx * sa[m]) / d
    return hx, hy


@jit
def algebraic_start(bx, by, ca, sa, beacon_index, use, out):
    """Closed-form pose from all measurements in ``use``: the triplet method's circles, pooled.

    Every pair of measured beacons gives the linear circle equation of ``circle_row`` in
    (x, y, q = x² + y²); all pairs are solved together by linear least squares (q treated as a
    third unknown). With three beacons this is the triplet solution of Sec. 2.5. The heading is the
    circular mean of β_i − α_i. Writes the pose array (``K.POSE_*`` slots) into ``out`` and
    returns False when the measurements do not determine the pose.

    As in ``_circles.pair_table``, coordinates are taken relative to the beacons' centroid and
    divided by their extent L, so the unknowns (x/L, y/L, q/L²) are all of order one.
    """
    ox = 0.0
    oy = 0.0
    count = 0
    for m in range(bx.size):
        if use[m]:
            ox += bx[m]
            oy += by[m]
            count += 1
    if count < MIN_MEASUREMENTS:
        return False
    ox /= count
    oy /= count
    scale = 0.0
    for m in range(bx.size):
        if use[m]:
            scale = max(scale, abs(bx[m] - ox), abs(by[m] - oy))
    if scale == 0.0:
        return False
    ata = np.zeros((3, 3))
    atb = np.zeros(3)
    _pool_circles(bx, by, ca, sa, beacon_index, use, ox, oy, scale, ata, atb)
    sol = np.empty(3)
    diag = ata[0, 0] * ata[1, 1] * ata[2, 2]
    if not determined(solve3(ata, atb, sol), diag):
        return False
    x = sol[0] * scale + ox
    y = sol[1] * scale + oy
    hx, hy = heading_sum(bx, by, ca, sa, use, x, y)
    hn = math.sqrt(hx * hx + hy * hy)
    if not (hn > 0.0 and math.isfinite(x) and math.isfinite(y)):
        return False
    out[K.POSE_X] = x
    out[K.POSE_Y] = y
    out[K.POSE_COS] = hx / hn
    out[K.POSE_SIN] = hy / hn
    return True


@jit
def fit_subset(bx, by, ca, sa, beacon_index, use, max_iter, out):
    """Algebraic start plus unweighted refinement on ``use``; returns the mean squared residual.

    Writes the pose array (``K.POSE_*`` slots) into ``out``; returns inf when the subset is
    singular.
    """
    if not algebraic_start(bx, by, ca, sa, beacon_index, use, out):
        return np.inf
    result = np.empty(K.REFINED_SIZE)
    info = np.empty((3, 3))
    weight = np.ones(bx.size)
    refine(bx, by, ca, sa, weight, use, out[K.POSE_X], out[K.POSE_Y], out[K.POSE_COS],
           out[K.POSE_SIN], max_iter, result, info)
    if result[K.REFINED_STATUS] == K.SINGULAR:
        return np.inf
    for slot in range(K.POSE_SIZE):  # slot by slot: an array copy compiles a shape check
        out[slot] = result[slot]
    return result[K.REFINED_COST] / np.count_nonzero(use)


class LeastSquares(Localizer):
    """All-measurement nonlinear least squares from an algebraic start (no outlier rejection).

    The start pools every pair's circle equation (:func:`algebraic_start`); Levenberg-Marquardt
    then minimises eq. 31 over all usable measurements. Outliers pull it away: it is the baseline
    robust localizers are measured against.

    Args:
        weighted: Weight by the error model's variances instead of equally.
        delta_alpha_d: Δα_d of the error model [rad] (weights and covariance).
        coverage: Whether the error model includes the coverage term (eq. 2).
        max_iter: Iteration limit of Levenberg-Marquardt.
    """

    name = "lsq"

    def __init__(
        self,
        *,
        weighted: bool = False,
        delta_alpha_d: float = math.radians(0.4),
        coverage: bool = True,
        max_iter: int = 50,
    ) -> None:
        self.weighted = weighted
        self.delta_alpha_d = delta_alpha_d
        self.coverage = coverage
        self.max_iter = max_iter
        self._validate_once()

    def _check_params(self) -> None:
        name = type(self).__name__
        check_flag(name, "weighted", self.weighted)
        check_range(name, "delta_alpha_d", self.delta_alpha_d, low=0.0, high=math.pi / 2,
                    high_open=True)
        check_flag(name, "coverage", self.coverage)
        check_range(name, "max_iter", self.max_iter, low=1, integer=True)

    def _localize(self, problem: Problem) -> Estimate:
        use = np.ones(problem.size, dtype=np.bool_)
        start = np.empty(K.POSE_SIZE)
        if not algebraic_start(problem.bx, problem.by, problem.cos_az, problem.sin_az,
                               problem.beacon_index, use, start):
            return Estimate.failure(
                "the measured beacons do not determine the pose (collinear or concyclic)",
                problem.n_measurements,
            )
        model = ErrorModel(delta_alpha_d=self.delta_alpha_d, coverage=bool(self.coverage))
        return refine_estimate(problem, use, start, bool(self.weighted), self.max_iter, model)

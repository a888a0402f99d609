"""The paper's RANSAC localizer (Rátosi & Simon 2021, Sec. 2.3-2.7)."""

from __future__ import annotations

import math
from functools import lru_cache
from itertools import combinations

import numpy as np

from azgym.core import BeaconMap, BoolArray, Estimate, FloatArray, IntArray, Measurements
from azgym.jit import jit
from azgym.localize import _kernels as K
from azgym.localize.base import (
    MIN_MEASUREMENTS,
    ROW_BEACON_INDEX,
    ROW_BX,
    ROW_BY,
    ROW_COS_AZ,
    ROW_SIN_AZ,
    ROW_SOURCE,
    ROW_WIDTH,
    Localizer,
    Problem,
    check_range,
    gather,
)
from azgym.localize.refinement import package, refine_with_covariance
from azgym.site.error_model import ErrorModel

SERIES_Z_MAX = 0.0025
"""u² = tan² ε up to which :func:`_score_all` trusts its atan series (to u¹¹) for an inlier.

At u² = 0.0025 (ε = 2.86°) the first term left out is below 2e-17 of ε, so the series is exact
to the last bit that matters; an inlier farther off makes the candidate "special", rescored with
the exact angle.
"""

# The slots of ``settings``, the hyperparameters handed to the kernels as one float array (one
# argument instead of five: each argument costs time at the Python/compiled boundary).
SETTING_DELTA_D = 0
"""Slot of ``settings``: Δα_d [rad]."""
SETTING_COVERAGE = 1
"""Slot of ``settings``: 1.0 if the tolerance includes the coverage term Δα_c,i, else 0.0."""
SETTING_DEGENERACY_TOL = 2
"""Slot of ``settings``: the degeneracy tolerance of the triplet solution."""
SETTING_WEIGHTED = 3
"""Slot of ``settings``: 1.0 if the refinement is weighted by the model's variances, else 0.0."""
SETTING_MAX_ITER = 4
"""Slot of ``settings``: the refinement's iteration limit."""
N_SETTINGS = 5
"""Length of ``settings``."""

# The slots of the kernels' ``out``: the refinement's output (``K.POSE_*``, ``K.REFINED_*``), then
# these three.
OUT_SUPPORT = K.REFINED_SIZE
"""Slot of ``out``: NS, the number of supporters of the winning triplet (step 5)."""
OUT_TRIPLET_MEAN_SQ = K.REFINED_SIZE + 1
"""Slot of ``out``: E, the winning triplet's mean squared error over its supporters (eq. 27)."""
OUT_VALID_TRIPLETS = K.REFINED_SIZE + 2
"""Slot of ``out``: how many triplets were not degenerate."""
OUT_SIZE = K.REFINED_SIZE + 3
"""Length of ``out``."""


def n_trials(n_measurements: int, n_good: int, pr_hit: float, p_star: float) -> int:
    """Number of random triplets N_Q that hits a reliable one with probability Pr_hit (eq. 4-6).

    Args:
        n_measurements: N_B, the number of measurements.
        n_good: N_GOOD, a lower bound on the number of inliers (>= 3).
        pr_hit: Pr_hit, the wanted probability of at least one reliable triplet, in (0, 1).
        p_star: P*, the probability that an all-inlier triplet gives a good estimate, in (0, 1].
    """
    p_reliable = math.comb(n_good, 3) / math.comb(n_measurements, 3) * p_star  # eq. 4
    if p_reliable >= 1.0:
        return 1
    return max(1, math.ceil(math.log1p(-pr_hit) / math.log1p(-p_reliable)))  # eq. 6


@lru_cache(maxsize=64)
def _all_triplets(n: int) -> IntArray:
    triplets = np.array(list(combinations(range(n), 3)), dtype=np.int64).reshape(-1, 3)
    triplets.setflags(write=False)
    return triplets


def _random_triplets(n: int, count: int, rng: np.random.Generator) -> IntArray:
    """``count`` triplets of distinct, ascending indices, drawn uniformly (independent trials)."""
    keys = rng.random((count, n))
    return np.sort(np.argpartition(keys, 3, axis=1)[:, :3], axis=1).astype(np.int64)


@jit(inline="always")
def _inside_tolerance(cross, dot, d2, w, tan_d, wide_d2):
    """|ε| <= Δα = 2(Δα_d + Δα_c) (eq. 25-26) from the direction vectors, without sqrt or atan.

    With t = tan Δα_d, tan Δα_c = W / 2D and the addition formulas, tan(Δα_d + Δα_c) = n / d with
    n = 2Dt + W and d = 2D − Wt, and tan Δα = 2nd / (d² − n²). Where Δα < π/2 (d > n, i.e.
    D² > ``wide_d2``), |ε| <= Δα ⟺ dot > 0 and |cross| (d² − n²) <= 2nd · dot. Expanded in D this
    reads L <= D·S with L = D²(4(1−t²)|cross| − 8t·dot) − W²(1−t²)|cross| + 2W²t·dot and
    S = 8Wt|cross| + 4W(1−t²)dot >= 0, decided by L <= 0 or L² <= D²S²: only D² is needed.

    Returns (inside, wide); a "wide" measurement (tolerance >= π/2, the beacon closer than about
    its own width) is not decided here.
    """
    wide = d2 <= wide_d2
    c = abs(cross)
    q = 1.0 - tan_d * tan_d
    lhs = d2 * (4.0 * q * c - 8.0 * tan_d * dot) - w * w * (q * c - 2.0 * tan_d * dot)
    slope = w * (8.0 * tan_d * c + 4.0 * q * dot)
    inside = (dot > 0.0) & ((lhs <= 0.0) | (lhs * lhs <= d2 * slope * slope)) & ~wide
    return inside, wide


@jit(inline="always")
def _wide_d2(w, tan_d):
    """D² below which Δα_d + Δα_c >= π/4 (tolerance >= π/2): D <= W(1 + t) / 2(1 − t)."""
    if tan_d >= 1.0:
        return np.inf
    limit = 0.5 * w * (1.0 + tan_d) / (1.0 - tan_d)
    return limit * limit


@jit(inline="always")
def _is_inlier(bx, by, ca, sa, width, m, x, y, ch, sh, tan_d, delta_d, coverage):
    """Inlier test |ε_m| <= Δα_m = 2(Δα_d + Δα_c,m) (eq. 23-26); returns (inlier, ε_m).

    (ch, sh) may be any positive multiple of (cos φ, sin φ). ε is computed for inliers only.
    """
    dx = bx[m] - x
    dy = by[m] - y
    mx = ca[m] * ch - sa[m] * sh  # measured world direction, along α_m + φ
    my = sa[m] * ch + ca[m] * sh
    cross = dx * my - dy * mx
    dot = dx * mx + dy * my
    w = width[m] if coverage else 0.0
    d2 = dx * dx + dy * dy
    inside, wide = _inside_tolerance(cross, dot, d2, w, tan_d, _wide_d2(w, tan_d))
    if not wide:
        return inside, K.small_angle(cross, dot) if inside else 0.0
    # Wide tolerance: compare the angles themselves.
    eps = K.fast_atan2(cross, dot)
    return abs(eps) <= 2.0 * (delta_d + K.fast_atan2(0.5 * w, math.sqrt(d2))), eps


@jit(fastmath=K.VECTOR_MATH)
def _score_all(bx, by, ca, sa, width, px, py, hx, hy, tan_d, coverage, ns, sq, special):
    """Supporters NS_t and Σε² of every candidate pose t at once (the fast path of _is_inlier).

    The inner loop runs over candidates, so it vectorises (``K.VECTOR_MATH``) without horizontal
    sums. A measurement whose tolerance is π/2 or more, or an inlier beyond SERIES_Z_MAX (2.86°),
    is "special" for that candidate: the caller then rescores the candidate exactly with
    _score_exact.
    """
    count = px.size
    for t in range(count):
        ns[t] = 0
        sq[t] = 0.0
        special[t] = 0
    for m in range(bx.size):
        xm = bx[m]
        ym = by[m]
        cm = ca[m]
        sm = sa[m]
        w = width[m] if coverage else 0.0
        wide_d2 = _wide_d2(w, tan_d)
        for t in range(count):
            dx = xm - px[t]
            dy = ym - py[t]
            mx = cm * hx[t] - sm * hy[t]  # measured world direction, scaled by |h|
            my = sm * hx[t] + cm * hy[t]
            cross = dx * my - dy * mx
            dot = dx * mx + dy * my
            inlier, wide = _inside_tolerance(cross, dot, dx * dx + dy * dy, w, tan_d, wide_d2)
            u = cross / dot
            z = u * u
            # atan(u) to u¹¹, exact for z <= SERIES_Z_MAX.
            eps = u * (1.0 + z * (-1.0 / 3.0 + z * (1.0 / 5.0 + z * (-1.0 / 7.0 + z * (
                1.0 / 9.0 - z / 11.0)))))
            ns[t] += inlier
            sq[t] += eps * eps if inlier else 0.0
            special[t] += wide | (inlier & (z > SERIES_Z_MAX))


@jit
def _score_exact(bx, by, ca, sa, width, x, y, ch, sh, tan_d, delta_d, coverage):
    """Supporters and Σε² of one candidate pose, measurement by measurement (eq. 26-27)."""
    ns = 0
    sq = 0.0
    for m in range(bx.size):
        inlier, eps = _is_inlier(bx, by, ca, sa, width, m, x, y, ch, sh, tan_d, delta_d, coverage)
        if inlier:
            ns += 1
            sq += eps * eps
    return ns, sq


@jit(inline="always")
def _solve_triplets(bx, by, ca, sa, beacon_index, triplets, degeneracy_tol):
    """The candidate pose of every triplet (eq. 7-20, ``K.solve_triplet``).

    Returns (x, y, h_x, h_y, valid, number valid), one entry per triplet; (h_x, h_y) is a positive
    multiple of (cos φ, sin φ). A degenerate triplet, or one with two detections of one beacon,
    is not valid and keeps a NaN position: it supports nothing.
    """
    count = triplets.shape[0]
    rows, ox, oy, scale = K.pair_table(bx, by, ca, sa)
    px = np.full(count, np.nan)
    py = np.full(count, np.nan)
    hx = np.zeros(count)
    hy = np.zeros(count)
    valid = np.zeros(count, dtype=np.bool_)
    n_valid = 0
    for t in range(count):
        i = triplets[t, 0]
        j = triplets[t, 1]
        k = triplets[t, 2]
        if not K.distinct_beacons(beacon_index[i], beacon_index[j], beacon_index[k]):
            continue
        ok, x, y, h0, h1, _ = K.solve_triplet(rows, ox, oy, scale, bx, by, ca, sa, i, j, k,
                                              degeneracy_tol)
        if ok:
            px[t] = x
            py[t] = y
            hx[t] = h0
            hy[t] = h1
            valid[t] = True
            n_valid += 1
    return px, py, hx, hy, valid, n_valid


@jit(inline="always")
def _pick_best(bx, by, ca, sa, width, px, py, hx, hy, valid, tan_d, delta_d, coverage,
               best_pose):
    """Score every valid candidate and write the best one (step 5) into ``best_pose``.

    The score is the number of supporters NS (eq. 21-26) and their mean ε², E (eq. 27); the best
    candidate has the most supporters, then the smallest E (a full tie goes to the earlier one).
    ``best_pose`` gets (x, y, h_x, h_y) in the ``K.POSE_*`` slots, the heading not yet normalised.

    Returns (NS, E) of the winner; NS = −1 when no candidate has a supporter.
    """
    count = px.size
    ns = np.empty(count, dtype=np.int64)
    sq = np.empty(count)
    special = np.empty(count, dtype=np.int64)
    _score_all(bx, by, ca, sa, width, px, py, hx, hy, tan_d, coverage, ns, sq, special)
    best_ns = -1
    best_e = np.inf
    for t in range(count):
        if not valid[t]:
            continue
        support = ns[t]
        total = sq[t]
        if special[t] > 0:
            support, total = _score_exact(bx, by, ca, sa, width, px[t], py[t], hx[t], hy[t],
                                          tan_d, delta_d, coverage)
        if support < best_ns or support == 0:
            continue
        e = total / support
        if support > best_ns or e < best_e:
            best_ns = support
            best_e = e
            best_pose[K.POSE_X] = px[t]
            best_pose[K.POSE_Y] = py[t]
            best_pose[K.POSE_COS] = hx[t]
            best_pose[K.POSE_SIN] = hy[t]
    return best_ns, best_e


@jit(inline="always")
def _mark_supporters(bx, by, ca, sa, width, tan_d, delta_d, coverage, best_pose, best_mask):
    """The winner's supporters into ``best_mask``; then its heading normalised to (cos φ, sin φ)."""
    x = best_pose[K.POSE_X]
    y = best_pose[K.POSE_Y]
    ch = best_pose[K.POSE_COS]
    sh = best_pose[K.POSE_SIN]
    for m in range(bx.size):
        best_mask[m], _ = _is_inlier(bx, by, ca, sa, width, m, x, y, ch, sh, tan_d, delta_d,
                                     coverage)
    norm = math.hypot(ch, sh)
    best_pose[K.POSE_COS] = ch / norm
    best_pose[K.POSE_SIN] = sh / norm


@jit
def _search(bx, by, ca, sa, width, beacon_index, triplets, delta_d, coverage, degeneracy_tol,
            best_pose, best_mask):
    """Steps 1-5: solve, score and rank every triplet.

    Each triplet is solved (eq. 7-20) and scored by its supporters (eq. 21-26) and their mean ε²
    (eq. 27); the best has the most supporters, then the smallest mean ε². Its pose array goes
    into ``best_pose`` (``K.POSE_*`` slots), its supporters into ``best_mask``.

    Returns (NS of the winner, E of the winner, number of non-degenerate triplets).
    """
    tan_d = math.tan(delta_d)
    px, py, hx, hy, valid, n_valid = _solve_triplets(bx, by, ca, sa, beacon_index, triplets,
                                                     degeneracy_tol)
    best_ns, best_e = _pick_best(bx, by, ca, sa, width, px, py, hx, hy, valid, tan_d, delta_d,
                                 coverage, best_pose)
    if best_ns > 0:
        _mark_supporters(bx, by, ca, sa, width, tan_d, delta_d, coverage, best_pose, best_mask)
    return best_ns, best_e, n_valid


@jit
def _ransac(floats, ints, triplets, settings, out, mask, cov):
    """Steps 1-6 in one compiled call on a Problem's packed arrays.

    ``settings`` holds the hyperparameters in the ``SETTING_*`` slots. ``out`` (length OUT_SIZE)
    gets the refinement's output (see K.refine), then NS, E and the number of valid triplets
    (``OUT_*`` slots); ``mask`` (length M, all False on entry) the supporters, by original
    position; ``cov`` the covariance.
    """
    delta_d = settings[SETTING_DELTA_D]
    coverage = settings[SETTING_COVERAGE] != 0.0
    degeneracy_tol = settings[SETTING_DEGENERACY_TOL]
    weighted = settings[SETTING_WEIGHTED] != 0.0
    max_iter = int(settings[SETTING_MAX_ITER])
    bx = floats[ROW_BX]
    by = floats[ROW_BY]
    ca = floats[ROW_COS_AZ]
    sa = floats[ROW_SIN_AZ]
    width = floats[ROW_WIDTH]
    pose = np.empty(K.POSE_SIZE)
    support = np.zeros(bx.size, dtype=np.bool_)
    n_support, mean_sq, n_valid = _search(bx, by, ca, sa, width, ints[ROW_BEACON_INDEX], triplets,
                                          delta_d, coverage, degeneracy_tol, pose, support)
    out[OUT_SUPPORT] = n_support
    out[OUT_TRIPLET_MEAN_SQ] = mean_sq
    out[OUT_VALID_TRIPLETS] = n_valid
    if n_support >= MIN_MEASUREMENTS:
        refine_with_covariance(bx, by, ca, sa, width, support, weighted, delta_d, coverage, pose,
                               max_iter, out, cov)
        for m in range(bx.size):
            mask[ints[ROW_SOURCE, m]] = support[m]


@jit
def _ransac_frame(ids, azimuth, sorted_ids, sorted_order, xyz, width, triplets, settings, out,
                  mask, cov):
    """The id lookup (``gather``) and steps 1-6 in one compiled call, for exhaustive triplets.

    ``triplets`` are all triplets of the M measurements in lexicographic order; those within the
    first K (the usable measurements) are exactly all triplets of K. Returns (K, distinct
    beacons); when fewer than MIN_MEASUREMENTS beacons are distinct nothing else is done.
    """
    floats, ints, distinct = gather(ids, azimuth, sorted_ids, sorted_order, xyz, width)
    usable = floats.shape[1]
    if distinct >= MIN_MEASUREMENTS:
        if usable < ids.size:
            triplets = triplets[triplets[:, 2] < usable]
        _ransac(floats, ints, triplets, settings, out, mask, cov)
    return usable, distinct


class Ransac(Localizer):
    """RANSAC over beacon triplets with a position-dependent tolerance (Sec. 2.3-2.7).

    Steps 1-4 solve each triplet algebraically (eq. 7-20), count the measurements within the
    tolerance Δα_i = 2 (Δα_d + Δα_c,i) at that pose (eq. 21-26) and their mean squared error
    (eq. 27). Step 5 keeps the triplet with the most supporters, ties broken by the smallest mean
    error; step 6 refines the pose on those supporters by Levenberg-Marquardt (eq. 28-33).

    All C(K, 3) triplets are tried when there are at most ``max_exhaustive`` of them; otherwise N_Q
    random triplets from eq. 6, with N_GOOD = ceil(min_inlier_fraction · K).

    Args:
        delta_alpha_d: Δα_d, half-width of the centre-detection error [rad] (eq. 1).
        coverage: Whether the tolerance includes the coverage term Δα_c,i (eq. 2).
        pr_hit: Pr_hit of eq. 5-6.
        p_star: P* of eq. 4-6.
        min_inlier_fraction: Lower bound on the share of inliers, giving N_GOOD for eq. 6.
        max_exhaustive: Use every triplet when C(K, 3) is at most this.
        weighted: Weight the refinement by each measurement's error variance from the error model
            (Δα_d² + Δα_c,i²)/3 (beyond the paper, which weights all equally).
        degeneracy_tol: Triplets whose normalised determinant is below this are skipped
            (collinear with the camera, or the camera on their circle).
        max_iter: Iteration limit of the refinement.
        random_state: Seed or Generator for random triplets (only used when sampling).
    """

    name = "ransac"

    def __init__(
        self,
        *,
        delta_alpha_d: float = math.radians(0.4),
        coverage: bool = True,
        pr_hit: float = 0.999,
        p_star: float = 0.9,
        min_inlier_fraction: float = 0.5,
        max_exhaustive: int = 500,
        weighted: bool = False,
        degeneracy_tol: float = 1e-9,
        max_iter: int = 50,
        random_state: int | np.random.Generator | None = 0,
    ) -> None:
        self.delta_alpha_d = delta_alpha_d
        self.coverage = coverage
        self.pr_hit = pr_hit
        self.p_star = p_star
        self.min_inlier_fraction = min_inlier_fraction
        self.max_exhaustive = max_exhaustive
        self.weighted = weighted
        self.degeneracy_tol = degeneracy_tol
        self.max_iter = max_iter
        self.random_state = random_state

    def _check_params(self) -> None:
        name = type(self).__name__
        check_range(name, "delta_alpha_d", self.delta_alpha_d, low=0.0, high=math.pi / 2,
                    high_open=True)
        check_range(name, "pr_hit", self.pr_hit, low=0.0, high=1.0, low_open=True, high_open=True)
        check_range(name, "p_star", self.p_star, low=0.0, high=1.0, low_open=True)
        check_range(name, "min_inlier_fraction", self.min_inlier_fraction, low=0.0, high=1.0,
                    low_open=True)
        check_range(name, "max_exhaustive", self.max_exhaustive, low=1, integer=True)
        check_range(name, "degeneracy_tol", self.degeneracy_tol, low=0.0, high=1.0)
        check_range(name, "max_iter", self.max_iter, low=1, integer=True)
        settings = np.empty(N_SETTINGS)
        settings[SETTING_DELTA_D] = self.delta_alpha_d
        settings[SETTING_COVERAGE] = bool(self.coverage)
        settings[SETTING_DEGENERACY_TOL] = self.degeneracy_tol
        settings[SETTING_WEIGHTED] = bool(self.weighted)
        settings[SETTING_MAX_ITER] = self.max_iter
        self._settings = settings

    def error_model(self) -> ErrorModel:
        """The error model whose bounds set the tolerance (eq. 25)."""
        return ErrorModel(delta_alpha_d=self.delta_alpha_d, coverage=bool(self.coverage))

    def triplets(self, n: int) -> IntArray:
        """The triplets (rows of measurement indices) tried for ``n`` usable measurements."""
        if math.comb(n, 3) <= self.max_exhaustive:
            return _all_triplets(n)
        n_good = max(3, math.ceil(self.min_inlier_fraction * n))
        count = n_trials(n, n_good, self.pr_hit, self.p_star)
        if count >= math.comb(n, 3):
            return _all_triplets(n)
        rng = self.random_state
        if not isinstance(rng, np.random.Generator):
            rng = np.random.default_rng(rng)
        return _random_triplets(n, count, rng)

    def _localize_frame(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        # The fast path, with the id lookup in the kernel: exhaustive triplets only, since
        # sampled ones depend on the number of usable measurements, known after the lookup.
        count = len(measurements)
        if math.comb(count, 3) > self.max_exhaustive:
            return super()._localize_frame(measurements, beacons)
        out = np.empty(OUT_SIZE)
        mask = np.zeros(count, dtype=np.bool_)
        cov = np.empty((3, 3))
        usable, distinct = _ransac_frame(
            measurements.ids, measurements.azimuth, *beacons.lookup_tables(),
            _all_triplets(count), self._settings, out, mask, cov,
        )
        if distinct < MIN_MEASUREMENTS:
            return super()._localize_frame(measurements, beacons)  # the standard refusal
        return self._estimate(out, mask, cov, math.comb(usable, 3))

    def _localize(self, problem: Problem) -> Estimate:
        triplets = self.triplets(problem.size)
        out = np.empty(OUT_SIZE)
        mask = np.zeros(problem.n_measurements, dtype=np.bool_)
        cov = np.empty((3, 3))
        _ransac(problem.floats, problem.ints, triplets, self._settings, out, mask, cov)
        return self._estimate(out, mask, cov, int(triplets.shape[0]))

    @staticmethod
    def _estimate(out: FloatArray, mask: BoolArray, cov: FloatArray, n_triplets: int) -> Estimate:
        diagnostics = {"n_triplets": n_triplets, "n_valid_triplets": int(out[OUT_VALID_TRIPLETS])}
        if out[OUT_SUPPORT] < MIN_MEASUREMENTS:
            return Estimate.failure(
                "no non-degenerate triplet with at least 3 supporters", mask.size, diagnostics
            )
        diagnostics["triplet_mean_sq_error"] = float(out[OUT_TRIPLET_MEAN_SQ])
        return package(mask, out, cov, diagnostics)

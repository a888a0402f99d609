"""ransac's compiled triplet search, steps 1-5 (Sec. 2.3-2.6): from triplets to the best pose.

:func:`search` solves every triplet for a candidate pose (eq. 7-20, through
:mod:`azgym.localize._circles`), scores each candidate by its supporters, the measurements
within the tolerance Δα_i = 2 (Δα_d + Δα_c,i) at that pose (eq. 21-26), and their mean squared
error (eq. 27), and keeps the best (step 5). The tolerance test is :func:`_inside_tolerance`
(no sqrt or atan), with :func:`_is_inlier` as its exact form; :func:`_score_all` scores every
candidate at once in a vectorised loop. :func:`search`, :func:`consensus_first_search` (a few
spread triplets first) and :func:`score_pose` (steps 4-5 for a pose found elsewhere) are all
``ransac.py``'s compiled entry points call here, before step 6, the refinement.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit
from azgym.localize import _kernels as K
from azgym.localize._angles import fast_atan2, small_angle
from azgym.localize._circles import (
    distinct_beacons,
    fill_every_pair,
    fill_pair,
    pair_frame,
    pair_table,
    solve_triplet,
    write_ascending,
)
from azgym.sensing.geometry.ordering import stable_order

__all__ = ["CONSENSUS_MIN_TRIPLETS", "CONSENSUS_TRIPLETS", "consensus_first_search", "score_pose",
           "search"]

SERIES_Z_MAX = 0.0025
"""u² = tan² ε up to which :func:`_score_all` trusts its atan series (to u¹¹) for an inlier.

At u² = 0.0025 (ε = 2.86°) the first term left out is below 2e-17 of ε, so the series is exact
to the last bit that matters; an inlier farther off makes the candidate "special", rescored with
the exact angle.
"""


@jit(inline="always")  # in the IR: takes the scoring loop's fast-math flags; larger steps: LLVM's
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
        return inside, small_angle(cross, dot) if inside else 0.0
    # Wide tolerance: compare the angles themselves.
    eps = fast_atan2(cross, dot)
    return abs(eps) <= 2.0 * (delta_d + fast_atan2(0.5 * w, math.sqrt(d2))), eps


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


@jit
def _solve_triplets(rows, ox, oy, scale, bx, by, ca, sa, beacon_index, triplets, degeneracy_tol):
    """The candidate pose of every triplet (eq. 7-20, ``solve_triplet`` on the ``pair_table``).

    Returns (x, y, h_x, h_y, valid, number valid), one entry per triplet; (h_x, h_y) is a positive
    multiple of (cos φ, sin φ). A degenerate triplet, or one with two detections of one beacon,
    is not valid and keeps a NaN position: it supports nothing.
    """
    count = triplets.shape[0]
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
        if not distinct_beacons(beacon_index[i], beacon_index[j], beacon_index[k]):
            continue
        ok, x, y, h0, h1, _ = solve_triplet(rows, ox, oy, scale, bx, by, ca, sa, i, j, k,
                                            degeneracy_tol)
        if ok:
            px[t] = x
            py[t] = y
            hx[t] = h0
            hy[t] = h1
            valid[t] = True
            n_valid += 1
    return px, py, hx, hy, valid, n_valid


@jit
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


@jit
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
def search(bx, by, ca, sa, width, beacon_index, triplets, delta_d, coverage, degeneracy_tol,
           best_pose, best_mask):
    """Steps 1-5: solve, score and rank every triplet.

    Each triplet is solved (eq. 7-20) and scored by its supporters (eq. 21-26) and their mean ε²
    (eq. 27); the best has the most supporters, then the smallest mean ε². Its pose array goes
    into ``best_pose`` (``K.POSE_*`` slots), its supporters into ``best_mask``.

    Returns (NS of the winner, E of the winner, number of non-degenerate triplets).
    """
    rows, ox, oy, scale = pair_table(bx, by, ca, sa)
    return _search_table(rows, ox, oy, scale, bx, by, ca, sa, width, beacon_index, triplets,
                         delta_d, coverage, degeneracy_tol, best_pose, best_mask)


@jit
def _search_table(rows, ox, oy, scale, bx, by, ca, sa, width, beacon_index, triplets, delta_d,
                  coverage, degeneracy_tol, best_pose, best_mask):
    """:func:`search` on the frame's ``pair_table``, computed by the caller."""
    tan_d = math.tan(delta_d)
    px, py, hx, hy, valid, n_valid = _solve_triplets(rows, ox, oy, scale, bx, by, ca, sa,
                                                     beacon_index, triplets, degeneracy_tol)
    best_ns, best_e = _pick_best(bx, by, ca, sa, width, px, py, hx, hy, valid, tan_d, delta_d,
                                 coverage, best_pose)
    if best_ns > 0:
        _mark_supporters(bx, by, ca, sa, width, tan_d, delta_d, coverage, best_pose, best_mask)
    return best_ns, best_e, n_valid


CONSENSUS_TRIPLETS = 8
"""How many triplets spread across the view :func:`consensus_first_search` tries before all.

On the noisy frames without outliers of ``baselines/speed.py`` (paper-room, 12 beacons, 3 000
frames) one of the first three settled 82 % of them, one of the first eight 97 %; a frame with
an outlier tries all eight before its full search.
"""
CONSENSUS_MIN_TRIPLETS = 2 * CONSENSUS_TRIPLETS
"""The fewest triplets (C(K, 3)) a frame needs for the consensus to be tried first: with fewer
(K <= 5) the full search costs little more than the tries. It also keeps the refinement's start
where it was on the frames of fewest measurements, whose geometry is the weakest: on real
four-beacon frames, the first triplet every measurement supports, as a start instead of the one
of smallest mean ε², left some refinements at max_iter (a refusal) that converged from it."""


@jit
def _spread_triplets(order, out):
    """Triplets spread across the view, in the order to try them; returns how many were written.

    With the K measurements in ``order`` (sorted by azimuth), the places s, s + ⌊K/3⌋ and
    s + ⌊2K/3⌋ (mod K) for s = 0, 1, ..., then s, s + ⌊K/3⌋ + 1 and s + ⌊2K/3⌋ + 1: each
    triplet's three about a third of the way round the view from each other. Each is written
    into ``out`` once (as measurement indices, ascending), up to ``out.shape[0]`` of them.
    """
    k = order.size
    made = 0
    for shift in range(2):
        first = k // 3 + shift
        second = (2 * k) // 3 + shift
        for start in range(k):
            if made == out.shape[0]:
                return made
            a = order[start]
            b = order[(start + first) % k]
            c = order[(start + second) % k]
            if a == b or b == c or a == c:
                continue
            write_ascending(a, b, c, out[made])
            repeated = False
            for t in range(made):
                repeated |= (out[t, 0] == out[made, 0]) & (out[t, 1] == out[made, 1]) & (
                    out[t, 2] == out[made, 2])
            if not repeated:
                made += 1
    return made


@jit
def consensus_first_search(bx, by, ca, sa, width, beacon_index, azimuth, triplets, delta_d,
                           coverage, degeneracy_tol, best_pose, best_mask):
    """Steps 1-5 as :func:`search`, after a quick look for a triplet every measurement supports.

    On a frame of at least CONSENSUS_MIN_TRIPLETS triplets, up to CONSENSUS_TRIPLETS triplets
    spread across the view (:func:`_spread_triplets`) are tried first. The first one every
    usable measurement supports wins at once: no candidate can have more supporters, step 5's
    first criterion. Otherwise every triplet of ``triplets`` is ranked as :func:`search` ranks
    them.

    The one departure from the exhaustive search is the tie among candidates every measurement
    supports: it goes to the first one tried, not to the smallest mean ε² (eq. 27). Such
    candidates differ only in the pose step 6 starts from; it refines the same measurements (all
    of them) to the same minimum of eq. 31, to within its stopping tolerance, wherever it
    converges from both starts (CONSENSUS_MIN_TRIPLETS says where it may not).

    Returns (NS of the winner, E of the winner, non-degenerate triplets, triplets tried).
    """
    k = bx.size
    ox, oy, scale = pair_frame(bx, by)
    rows = np.empty((k, k, 4))  # the pair table, filled as far as it is needed
    tan_d = math.tan(delta_d)
    spread = np.empty((CONSENSUS_TRIPLETS, 3), dtype=np.int64)
    n_spread = 0
    if k * (k - 1) * (k - 2) // 6 >= CONSENSUS_MIN_TRIPLETS:
        n_spread = _spread_triplets(stable_order(azimuth, k), spread)
    n_valid = 0
    tried = 0
    for t in range(n_spread):
        i = spread[t, 0]
        j = spread[t, 1]
        m = spread[t, 2]
        if not distinct_beacons(beacon_index[i], beacon_index[j], beacon_index[m]):
            continue
        tried += 1
        fill_pair(rows, bx, by, ca, sa, ox, oy, scale, i, j)
        fill_pair(rows, bx, by, ca, sa, ox, oy, scale, j, m)
        fill_pair(rows, bx, by, ca, sa, ox, oy, scale, i, m)
        ok, x, y, h0, h1, _ = solve_triplet(rows, ox, oy, scale, bx, by, ca, sa, i, j, m,
                                            degeneracy_tol)
        if not ok:
            continue
        n_valid += 1
        support, total = _score_exact(bx, by, ca, sa, width, x, y, h0, h1, tan_d, delta_d,
                                      coverage)
        if support == k:
            best_pose[K.POSE_X] = x
            best_pose[K.POSE_Y] = y
            best_pose[K.POSE_COS] = h0
            best_pose[K.POSE_SIN] = h1
            _mark_supporters(bx, by, ca, sa, width, tan_d, delta_d, coverage, best_pose,
                             best_mask)
            return support, total / support, n_valid, tried
    fill_every_pair(rows, bx, by, ca, sa, ox, oy, scale)
    best_ns, best_e, n_valid = _search_table(rows, ox, oy, scale, bx, by, ca, sa, width,
                                             beacon_index, triplets, delta_d, coverage,
                                             degeneracy_tol, best_pose, best_mask)
    return best_ns, best_e, n_valid, triplets.shape[0]


@jit
def score_pose(bx, by, ca, sa, width, delta_d, coverage, pose, mask):
    """Steps 4-5 for one candidate pose found elsewhere (not from ``triplets``).

    ``pose`` holds (x, y, h_x, h_y) in the ``K.POSE_*`` slots, (h_x, h_y) any positive multiple
    of (cos φ, sin φ). Its supporters (eq. 21-26) go into ``mask`` and its heading is normalised,
    as :func:`search` leaves a winner. Returns (NS, E), E the supporters' mean ε² (eq. 27; inf
    without supporters).
    """
    tan_d = math.tan(delta_d)
    x = pose[K.POSE_X]
    y = pose[K.POSE_Y]
    ch = pose[K.POSE_COS]
    sh = pose[K.POSE_SIN]
    n_support = 0
    total = 0.0
    for m in range(bx.size):
        inlier, eps = _is_inlier(bx, by, ca, sa, width, m, x, y, ch, sh, tan_d, delta_d, coverage)
        mask[m] = inlier
        if inlier:
            n_support += 1
            total += eps * eps
    norm = math.hypot(ch, sh)
    pose[K.POSE_COS] = ch / norm
    pose[K.POSE_SIN] = sh / norm
    return n_support, total / n_support if n_support else np.inf

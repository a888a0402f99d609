"""The per-measurement features of the learned localizers: one compiled kernel, shared by all.

Training (:mod:`azgym.learn.dataset`) and serving (the ``ng-ransac`` localizer) call the very same
kernel, so a model never sees features computed another way than the ones it was trained on.
Every feature is in [0, 1] and uses only what a localizer gets, the frame's measurements (with
their quality) and the beacon map, and none changes when the world is translated or rotated or
the quality is scaled (the geometry sensor's quality is log10 brightness, the image sensor's
first column a blob area in px): they are ranks, shares and angles. Rows follow the usable
measurements of a :class:`~azgym.localize.base.Problem` (``problem.floats`` column order).

The features, and why each helps tell a good measurement (a direct or partly covered view of
the right beacon at its mapped position) from a mirror ghost, a misread id, a moved beacon or
an injected outlier:

- ``quality_rank``: rank of the quality among the frame's usable measurements (brightest 1;
  0.5 alone or without quality). A ghost's light comes off a face that mirrors 5-40 % of it over
  a longer path, so ghosts sit at the bottom of the frame's brightness order.
- ``quality_span``: (q − min) / (max − min) over the frame (0.5 when all equal or no quality):
  the same with the gaps kept, so a ghost far below the rest stands out from a merely far beacon.
- ``same_id_others``: other measurements with the same beacon, min(n, 2) / 2. A ghost carries its
  beacon's id, so it comes with its beacon's real view (or another ghost of it).
- ``brightest_of_id``: 1 for the brightest of its id's measurements (1 alone; 0.5 for a
  duplicate without quality): of a beacon and its mirror images, the real view is the brightest.
- ``beacons_in_view``: distinct usable beacons / 16, clipped to 1: how much a frame has to spare
  (with many beacons, one measurement's doubtful features matter less).
- ``consensus_residual``: the measurement's azimuth residual under the frame's consensus pose,
  log(1 + |r| / τ) / log(1 + π / τ) with τ = ``CONSENSUS_TOLERANCE`` at the training noise,
  scaled with a camera's Δα_d when served (:func:`consensus_tolerance`) (0.5 when no pose was
  found). The consensus pose is the best supported of the triplet solutions (Sec. 2.5, eq. 7-20)
  among at most ``CONSENSUS_CANDIDATES`` measurements of distinct beacons (the brightest of each
  id by quality, or spread evenly in azimuth without quality). It is the only feature that sees
  geometry: a shuffled azimuth (the paper's outliers), a misread id and a moved beacon's stale
  mapped position all leave a residual that no quality feature can show.
- ``consensus_support``: share of the frame's measurements within τ of the consensus pose (0
  when none was found): how far ``consensus_residual`` can be trusted in this frame.

Left out, after measuring (``make_frames``, 200 training layouts, 20 held-out ones):

- the beacon's mean map distance to the frame's other beacons (a misread names a beacon
  anywhere on the site): with the consensus residual it added nothing (a logistic regression's
  held-out AUC 0.9887 without it, 0.9889 with it);
- the share of the frame's measurements whose ids are in the map: the geometry sensor misreads
  an id as another map id, so the share is 1 in every training frame, and a feature that never
  varies in training teaches a model nothing but shifts its output wherever it does vary.

Cost: one kernel call, about 1-2 µs for a 12-measurement frame (at most 20 triplets solved,
each checked against every measurement with a few multiplications).
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.jit import jit
from azgym.localize._circles import pair_table, solve_triplet
from azgym.localize.base import (
    ROW_AZIMUTH,
    ROW_BEACON_INDEX,
    ROW_BX,
    ROW_BY,
    ROW_COS_AZ,
    ROW_SIN_AZ,
    ROW_SOURCE,
    Problem,
)

__all__ = ["CONSENSUS_CANDIDATES", "CONSENSUS_TOLERANCE", "FEATURE_LAYOUT", "FEATURE_NAMES",
           "N_FEATURES", "consensus_of", "consensus_tolerance", "fill_features",
           "first_quality_column", "frame_features", "measurement_features"]

FEATURE_NAMES: tuple[str, ...] = (
    "quality_rank", "quality_span", "same_id_others", "brightest_of_id", "beacons_in_view",
    "consensus_residual", "consensus_support",
)
"""One name per feature column, in column order (see the module docstring for each)."""
FEATURE_LAYOUT = "measurement-features-1"
"""The features' version: bumped whenever any feature, its order or its scaling changes (a weight
file records the layout it was trained on, and a model refuses features of another)."""
N_FEATURES = len(FEATURE_NAMES)
(QUALITY_RANK, QUALITY_SPAN, SAME_ID_OTHERS, BRIGHTEST_OF_ID, BEACONS_IN_VIEW, CONSENSUS_RESIDUAL,
 CONSENSUS_SUPPORT) = range(N_FEATURES)
BEACONS_FULL_VIEW = 16.0
"""Distinct beacons at which ``beacons_in_view`` reaches 1."""
CONSENSUS_CANDIDATES = 6
"""Measurements the consensus pose is built from: all their triplets, C(6, 3) = 20 at most."""
CONSENSUS_TOLERANCE = math.radians(1.0)
"""τ: an azimuth within this of the consensus pose's prediction supports it [rad]."""
INSERTION_SORT_MAX = 24
"""Most measurements :func:`_stable_order` sorts by insertion (fewer temporaries than a merge)."""
CONSENSUS_DEGENERACY = 1e-4
"""Triplets whose normalised determinant is below this are not solved (see ``solve_triplet``)."""


def measurement_features(problem: Problem, quality: FloatArray | None,
                         tolerance: float = CONSENSUS_TOLERANCE) -> FloatArray:
    """The features of every usable measurement of a frame, (K, N_FEATURES) float64.

    Args:
        problem: The frame's usable measurements (:meth:`Problem.from_frame`).
        quality: The frame's ``Measurements.quality``, (M,) or (M, Q), or None; indexed through
            ``problem.ints[ROW_SOURCE]``; only its first column is used.
        tolerance: τ, the consensus tolerance [rad] (:func:`consensus_tolerance`).

    Raises:
        InvalidInputError: ``quality`` has another number of rows than the frame has
            measurements, or more than two dimensions.
    """
    if quality is not None:
        quality = np.asarray(quality, dtype=np.float64)
        if quality.ndim not in (1, 2) or quality.shape[0] != problem.n_measurements:
            raise InvalidInputError(
                f"quality must have shape ({problem.n_measurements},) or "
                f"({problem.n_measurements}, Q), got {quality.shape}")
    column, has_quality = first_quality_column(quality, problem.n_measurements)
    out = np.empty((problem.size, N_FEATURES))
    # Contiguous arrays (no copy when they are already): one compiled signature serves all.
    frame_features(np.ascontiguousarray(problem.floats), np.ascontiguousarray(problem.ints),
                   problem.n_distinct, column, has_quality, tolerance, out)
    return out


def consensus_tolerance(delta_alpha_d: float, trained_delta_alpha_d: float) -> float:
    """τ for a camera of noise Δα_d, served by a model trained at ``trained_delta_alpha_d``.

    The consensus features measure residuals in units of τ; scaling τ with the camera's noise
    keeps them in the units the model was trained in (a 2° camera's good azimuths are as far
    off as a 0.4° camera's are, in units of their noise). At the training noise it is
    ``CONSENSUS_TOLERANCE`` exactly.
    """
    if delta_alpha_d == trained_delta_alpha_d:
        return CONSENSUS_TOLERANCE
    return CONSENSUS_TOLERANCE * delta_alpha_d / trained_delta_alpha_d


def first_quality_column(quality: FloatArray | None, count: int) -> tuple[FloatArray, bool]:
    """The first quality column of ``count`` measurements, and whether there is one.

    The column is the contiguous float64 array the features' kernel reads; without quality it is
    zeros, and False says so. It is read-only, as a frame's own columns are, so that the kernels
    taking it are compiled once, not once for read-only and once for writable arrays.
    """
    if quality is None:
        column, present = np.zeros(count), False
    else:
        column = quality if quality.ndim == 1 else quality[:, 0]  # of (M, 1): contiguous
        if column.dtype != np.float64 or not column.flags.c_contiguous:
            column = np.ascontiguousarray(column, dtype=np.float64)
        present = True
    column.setflags(write=False)
    return column, present


@jit
def frame_features(floats, ints, n_distinct, quality, has_quality, tolerance, out):
    """Fill ``out`` (K, N_FEATURES) with the features of one frame (rows of ``Problem``).

    ``quality`` is the first quality column of all M measurements (read through the source
    row); ``has_quality`` False ignores it; ``tolerance`` is τ [rad].
    """
    q, support, pose = consensus_of(floats, ints, quality, has_quality, tolerance)
    fill_features(floats, ints, n_distinct, q, has_quality, support, pose, tolerance, out)


@jit
def consensus_of(floats, ints, quality, has_quality, tolerance):
    """The frame's consensus pose, the one step of the features that solves triplets.

    Returns (q, support, pose): the usable measurements' quality (K,) (zeros without quality),
    the number of measurements within τ of the pose (0: none found) and the pose
    (x, y, h_x, h_y), (h_x, h_y) a positive multiple of (cos φ, sin φ). ``ng-ransac`` scores
    that pose first, instead of solving its triplet again.
    """
    k = floats.shape[1]
    q = np.empty(k)
    for u in range(k):
        q[u] = quality[ints[ROW_SOURCE, u]] if has_quality else 0.0
    support, pose = _consensus(floats, ints[ROW_BEACON_INDEX], q, has_quality, tolerance)
    return q, support, pose


@jit
def fill_features(floats, ints, n_distinct, q, has_quality, support, pose, tolerance, out):
    """Fill ``out`` (K, N_FEATURES) from the frame and its consensus (:func:`consensus_of`)."""
    k = floats.shape[1]
    _quality_features(q, ints[ROW_BEACON_INDEX], has_quality, out)
    bx, by = floats[ROW_BX], floats[ROW_BY]
    ca, sa = floats[ROW_COS_AZ], floats[ROW_SIN_AZ]
    scale_residual = 1.0 / math.log1p(math.pi / tolerance)
    for u in range(k):
        out[u, BEACONS_IN_VIEW] = min(n_distinct / BEACONS_FULL_VIEW, 1.0)
        out[u, CONSENSUS_SUPPORT] = support / k
        if support == 0:
            out[u, CONSENSUS_RESIDUAL] = 0.5
            continue
        cross, dot = _turn(bx[u] - pose[0], by[u] - pose[1], pose[2], pose[3], ca[u], sa[u])
        residual = abs(math.atan2(cross, dot))
        out[u, CONSENSUS_RESIDUAL] = math.log1p(residual / tolerance) * scale_residual


@jit(inline="always")
def _quality_features(q, beacon, has_quality, out):
    """``quality_rank``, ``quality_span``, ``same_id_others`` and ``brightest_of_id``."""
    k = q.size
    low, high = np.inf, -np.inf
    for u in range(k):
        low, high = min(low, q[u]), max(high, q[u])
    for u in range(k):
        below, ties, same, brighter = 0.0, 0.0, 0, 0
        for v in range(k):
            if v == u:
                continue
            below += q[v] < q[u]
            ties += q[v] == q[u]
            if beacon[v] == beacon[u]:
                same += 1
                brighter += q[v] > q[u]
        rank = (below + 0.5 * ties) / (k - 1) if k > 1 else 0.5
        out[u, QUALITY_RANK] = rank if has_quality else 0.5
        span = high - low
        out[u, QUALITY_SPAN] = (q[u] - low) / span if has_quality and span > 0.0 else 0.5
        out[u, SAME_ID_OTHERS] = min(same, 2) / 2.0
        if same == 0:
            out[u, BRIGHTEST_OF_ID] = 1.0
        elif has_quality:
            out[u, BRIGHTEST_OF_ID] = 1.0 if brighter == 0 else 0.0
        else:
            out[u, BRIGHTEST_OF_ID] = 0.5


@jit(inline="always")
def _candidates(azimuth, beacon, q, has_quality):
    """Up to CONSENSUS_CANDIDATES measurements of distinct beacons to build the consensus from.

    By quality, brightest first (the real view of a beacon before its ghosts); without quality,
    spread evenly over the frame's azimuth order, which gives triplets wide angles.
    """
    k = azimuth.size
    order = _stable_order(q, True) if has_quality else _stable_order(azimuth, False)
    chosen = np.empty(CONSENSUS_CANDIDATES, dtype=np.int64)
    count = 0
    steps = k if has_quality or k <= CONSENSUS_CANDIDATES else CONSENSUS_CANDIDATES
    for t in range(steps):
        u = order[t] if has_quality or k <= CONSENSUS_CANDIDATES else order[
            (t * k) // CONSENSUS_CANDIDATES]
        taken = False
        for c in range(count):
            taken |= beacon[chosen[c]] == beacon[u]
        if not taken:
            chosen[count] = u
            count += 1
            if count == CONSENSUS_CANDIDATES:
                break
    return chosen[:count]


@jit(inline="always")
def _stable_order(values, descending):
    """``np.argsort(±values, kind="mergesort")``, the stable order (descending: of −values).

    By insertion on a frame's few measurements (no temporary arrays), by merge sort on more.
    """
    k = values.size
    if k > INSERTION_SORT_MAX:
        return np.argsort(-values if descending else values, kind="mergesort")
    order = np.empty(k, dtype=np.int64)
    for u in range(k):
        v = values[u]
        t = u
        while t > 0 and (values[order[t - 1]] < v if descending else values[order[t - 1]] > v):
            order[t] = order[t - 1]
            t -= 1
        order[t] = u
    return order


@jit(inline="always")
def _consensus(floats, beacon, q, has_quality, tolerance):
    """The best supported triplet pose among the candidates: (support, pose)."""
    k = floats.shape[1]
    bx, by = floats[ROW_BX], floats[ROW_BY]
    ca, sa = floats[ROW_COS_AZ], floats[ROW_SIN_AZ]
    chosen = _candidates(floats[ROW_AZIMUTH], beacon, q, has_quality)
    n = chosen.size
    best, pose = 0, np.zeros(4)
    if n >= 3:
        cbx, cby, cca, csa = bx[chosen], by[chosen], ca[chosen], sa[chosen]
        rows, ox, oy, scale = pair_table(cbx, cby, cca, csa)
        tan_tol = math.tan(tolerance)
        for i in range(n):
            for j in range(i + 1, n):
                for m in range(j + 1, n):
                    if best == k:  # every measurement supports it: no later triplet can win
                        return best, pose
                    ok, x, y, hx, hy, _ = solve_triplet(rows, ox, oy, scale, cbx, cby, cca, csa,
                                                        i, j, m, CONSENSUS_DEGENERACY)
                    if not ok:
                        continue
                    support = 0
                    for u in range(k):
                        cross, dot = _turn(bx[u] - x, by[u] - y, hx, hy, ca[u], sa[u])
                        support += dot > 0.0 and abs(cross) < tan_tol * dot
                    if support > best:
                        best = support
                        pose[0], pose[1], pose[2], pose[3] = x, y, hx, hy
    return best, pose


@jit(inline="always")
def _turn(dx, dy, hx, hy, ca, sa):
    """(sin, cos) of measured minus predicted azimuth, times a positive factor.

    (dx, dy) points from the camera to the beacon in the world, (hx, hy) is a positive multiple
    of the heading's (cos φ, sin φ), and (ca, sa) the measured azimuth's cosine and sine.
    """
    px = dx * hx + dy * hy  # the beacon's direction in the camera frame (rotated by −φ)
    py = dy * hx - dx * hy
    return px * sa - py * ca, px * ca + py * sa


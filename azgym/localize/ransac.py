"""The paper's RANSAC localizer (Rátosi & Simon 2021, Sec. 2.3-2.7).

Here: the :class:`Ransac` class, which triplets it tries (all of them, or N_Q random ones from
eq. 4-6), and its compiled entry points, which run steps 1-6 on a frame (ransac's own,
consensus first, and the full search the learned localizers call) and exchange the
hyperparameters and results with the class through the named ``SETTING_*`` and ``OUT_*`` slots.
Steps 1-5, the triplet search itself, are compiled in :mod:`azgym.localize.ransac_search`;
step 6 is the shared refinement of :mod:`azgym.localize.refinement`.
"""

from __future__ import annotations

import math
from functools import lru_cache
from itertools import combinations
from typing import Any

import numpy as np

from azgym.core import BeaconMap, BoolArray, Estimate, FloatArray, IntArray, Measurements
from azgym.hyperparameters import check_flag, check_range
from azgym.jit import jit
from azgym.localize import _kernels as K
from azgym.localize.base import (
    MIN_MEASUREMENTS,
    ROW_AZIMUTH,
    ROW_BEACON_INDEX,
    ROW_BX,
    ROW_BY,
    ROW_COS_AZ,
    ROW_SIN_AZ,
    ROW_SOURCE,
    ROW_WIDTH,
    Localizer,
    Problem,
    gather,
)
from azgym.localize.ransac_search import consensus_first_search, score_pose, search
from azgym.localize.refinement import package, refine_with_covariance
from azgym.site.error_model import ErrorModel

__all__ = ["N_SETTINGS", "OUT_SIZE", "OUT_SUPPORT", "OUT_TRIED_TRIPLETS", "OUT_TRIPLET_MEAN_SQ",
           "OUT_VALID_TRIPLETS", "Ransac", "SETTING_COVERAGE", "SETTING_DEGENERACY_TOL",
           "SETTING_DELTA_D", "SETTING_MAX_ITER", "SETTING_WEIGHTED", "n_trials", "refine_winner",
           "score_candidate", "score_triplets", "settings_array", "solve_from_triplets",
           "solve_ransac"]

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
OUT_TRIED_TRIPLETS = K.REFINED_SIZE + 3
"""Slot of ``out``: how many triplets were tried (fewer than all when a consensus settled it)."""
OUT_SIZE = K.REFINED_SIZE + 4
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


def settings_array(delta_alpha_d: float = math.radians(0.4), coverage: bool = True,
                   degeneracy_tol: float = 1e-9, weighted: bool = False,
                   max_iter: int = 50) -> FloatArray:
    """The hyperparameters as the kernels take them, one float array (``SETTING_*`` slots)."""
    settings = np.empty(N_SETTINGS)
    settings[SETTING_DELTA_D] = delta_alpha_d
    settings[SETTING_COVERAGE] = coverage
    settings[SETTING_DEGENERACY_TOL] = degeneracy_tol
    settings[SETTING_WEIGHTED] = weighted
    settings[SETTING_MAX_ITER] = max_iter
    return settings


@lru_cache(maxsize=64)
def _all_triplets(n: int) -> IntArray:
    """Every triplet of ``n`` measurements, shared: the kernels only read it.

    Writable, as the triplets ng-ransac's kernels build are, so that the search is compiled for
    one kind of array, not for read-only and writable ones (:meth:`Ransac.triplets` hands out a
    read-only view).
    """
    return np.array(list(combinations(range(n), 3)), dtype=np.int64).reshape(-1, 3)


def _random_triplets(n: int, count: int, rng: np.random.Generator) -> IntArray:
    """``count`` triplets of distinct, ascending indices, drawn uniformly (independent trials)."""
    keys = rng.random((count, n))
    return np.sort(np.argpartition(keys, 3, axis=1)[:, :3], axis=1).astype(np.int64)


@jit
def solve_from_triplets(floats, ints, triplets, settings, out, mask, cov):
    """Steps 1-6 in one compiled call on a Problem's packed arrays.

    ``settings`` holds the hyperparameters in the ``SETTING_*`` slots. ``out`` (length OUT_SIZE)
    gets the refinement's output (see ``_levenberg_marquardt.refine``), then NS, E, the number
    of valid triplets and of triplets tried (``OUT_*`` slots); ``mask`` (length M, all False on
    entry) the supporters, by original position; ``cov`` the covariance.
    """
    pose = np.empty(K.POSE_SIZE)
    support = np.zeros(floats.shape[1], dtype=np.bool_)
    n_support, mean_sq, n_valid = score_triplets(floats, ints, triplets, settings, pose, support)
    out[OUT_TRIED_TRIPLETS] = triplets.shape[0]
    refine_winner(floats, ints, settings, pose, support, n_support, mean_sq, n_valid, out, mask,
                  cov)


@jit
def solve_ransac(floats, ints, triplets, settings, out, mask, cov):
    """Ransac's steps 1-6: as :func:`solve_from_triplets`, but consensus first when unweighted.

    The unweighted search is :func:`~azgym.localize.ransac_search.consensus_first_search`: a
    triplet every measurement supports, among a few spread across the view, ends it. The
    weighted one ranks every triplet (:func:`~azgym.localize.ransac_search.search`): its weights
    are the error model's at the winner's pose, so which of the candidates every measurement
    supports wins (the smallest mean ε², eq. 27) changes the answer. ``out`` also gets how many
    triplets were tried (``OUT_TRIED_TRIPLETS``).
    """
    pose = np.empty(K.POSE_SIZE)
    support = np.zeros(floats.shape[1], dtype=np.bool_)
    bx, by, width = floats[ROW_BX], floats[ROW_BY], floats[ROW_WIDTH]
    ca, sa = floats[ROW_COS_AZ], floats[ROW_SIN_AZ]
    delta_d = settings[SETTING_DELTA_D]
    coverage = settings[SETTING_COVERAGE] != 0.0
    tolerance = settings[SETTING_DEGENERACY_TOL]
    if settings[SETTING_WEIGHTED] != 0.0:
        n_support, mean_sq, n_valid = search(bx, by, ca, sa, width, ints[ROW_BEACON_INDEX],
                                             triplets, delta_d, coverage, tolerance, pose,
                                             support)
        tried = triplets.shape[0]
    else:
        n_support, mean_sq, n_valid, tried = consensus_first_search(
            bx, by, ca, sa, width, ints[ROW_BEACON_INDEX], floats[ROW_AZIMUTH], triplets, delta_d,
            coverage, tolerance, pose, support)
    out[OUT_TRIED_TRIPLETS] = tried
    refine_winner(floats, ints, settings, pose, support, n_support, mean_sq, n_valid, out, mask,
                  cov)


@jit
def score_triplets(floats, ints, triplets, settings, pose, support):
    """Steps 1-5 (``search``): the winning triplet's pose and supporters; returns (NS, E, valid).

    ``pose`` (``K.POSE_*`` slots) and ``support`` (length K, all False on entry) receive the
    winner's; a caller may look at NS before paying for the refinement.
    """
    delta_d = settings[SETTING_DELTA_D]
    coverage = settings[SETTING_COVERAGE] != 0.0
    return search(floats[ROW_BX], floats[ROW_BY], floats[ROW_COS_AZ], floats[ROW_SIN_AZ],
                  floats[ROW_WIDTH], ints[ROW_BEACON_INDEX], triplets, delta_d, coverage,
                  settings[SETTING_DEGENERACY_TOL], pose, support)


@jit
def score_candidate(floats, settings, pose, support):
    """Steps 4-5 (:func:`score_pose`) for one candidate pose found elsewhere; returns (NS, E).

    ``pose`` (``K.POSE_*`` slots) gets its heading normalised and ``support`` (length K, all
    False on entry) its supporters, ready for :func:`refine_winner`.
    """
    return score_pose(floats[ROW_BX], floats[ROW_BY], floats[ROW_COS_AZ], floats[ROW_SIN_AZ],
                      floats[ROW_WIDTH], settings[SETTING_DELTA_D],
                      settings[SETTING_COVERAGE] != 0.0, pose, support)


@jit
def refine_winner(floats, ints, settings, pose, support, n_support, mean_sq, n_valid, out, mask,
                  cov):
    """Step 6 on a winner of :func:`score_triplets` or :func:`score_candidate`.

    ``out``, ``mask`` and ``cov`` are those of :func:`solve_from_triplets`; a winner of fewer
    than MIN_MEASUREMENTS supporters is not refined (``out`` then holds only NS, E and the
    valid count).
    """
    out[OUT_SUPPORT] = n_support
    out[OUT_TRIPLET_MEAN_SQ] = mean_sq
    out[OUT_VALID_TRIPLETS] = n_valid
    if n_support >= MIN_MEASUREMENTS:
        refine_with_covariance(floats[ROW_BX], floats[ROW_BY], floats[ROW_COS_AZ],
                               floats[ROW_SIN_AZ], floats[ROW_WIDTH], support,
                               settings[SETTING_WEIGHTED] != 0.0, settings[SETTING_DELTA_D],
                               settings[SETTING_COVERAGE] != 0.0, pose,
                               int(settings[SETTING_MAX_ITER]), out, cov)
        for m in range(support.size):
            mask[ints[ROW_SOURCE, m]] = support[m]


@jit
def _ransac_frame(ids, azimuth, sorted_ids, sorted_order, xyz, width, triplets, settings, out,
                  mask, cov):
    """The id lookup (``gather``) and steps 1-6 (:func:`solve_ransac`) in one compiled call.

    For exhaustive triplets only.

    ``triplets`` are all triplets of the M measurements in lexicographic order; those within the
    first K (the usable measurements) are exactly all triplets of K. Returns (K, distinct
    beacons); when fewer than MIN_MEASUREMENTS beacons are distinct nothing else is done.
    """
    floats, ints, distinct = gather(ids, azimuth, sorted_ids, sorted_order, xyz, width)
    usable = floats.shape[1]
    if distinct >= MIN_MEASUREMENTS:
        if usable < ids.size:
            triplets = triplets[triplets[:, 2] < usable]
        solve_ransac(floats, ints, triplets, settings, out, mask, cov)
    return usable, distinct


class Ransac(Localizer):
    """RANSAC over beacon triplets with a position-dependent tolerance (Sec. 2.3-2.7).

    Steps 1-4 solve each triplet algebraically (eq. 7-20), count the measurements within the
    tolerance Δα_i = 2 (Δα_d + Δα_c,i) at that pose (eq. 21-26) and their mean squared error
    (eq. 27). Step 5 keeps the triplet with the most supporters, ties broken by the smallest mean
    error; step 6 refines the pose on those supporters by Levenberg-Marquardt (eq. 28-33).

    All C(K, 3) triplets are tried when there are at most ``max_exhaustive`` of them; otherwise N_Q
    random triplets from eq. 6, with N_GOOD = ceil(min_inlier_fraction · K). Unweighted, on a
    frame of 20 triplets or more (K >= 6), a few triplets spread across the view are tried
    first, and the first that every measurement supports ends the search: no triplet can have
    more supporters, and the refinement then uses every measurement whichever of them it starts
    from (``diagnostics["n_triplets"]`` says how many triplets were tried).

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
        random_state: Seed (an integer >= 0), Generator or None for random triplets (only used
            when sampling).
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
        self._validate_once()

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
        check_flag(name, "coverage", self.coverage)
        check_flag(name, "weighted", self.weighted)
        rng = self.random_state
        if not (rng is None or isinstance(rng, np.random.Generator)):
            check_range(name, "random_state", rng, low=0, integer=True)
        self._settings = settings_array(self.delta_alpha_d, bool(self.coverage),
                                        self.degeneracy_tol, bool(self.weighted), self.max_iter)

    def error_model(self) -> ErrorModel:
        """The error model whose bounds set the tolerance (eq. 25)."""
        return ErrorModel(delta_alpha_d=self.delta_alpha_d, coverage=bool(self.coverage))

    def triplets(self, n: int) -> IntArray:
        """The triplets (rows of measurement indices) tried for ``n`` usable measurements."""
        triplets = self._triplets(n).view()
        triplets.setflags(write=False)
        return triplets

    def _triplets(self, n: int) -> IntArray:
        """:meth:`triplets`, as the kernels take them (every triplet: the shared array)."""
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
        count = measurements.ids.size
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
        return self._estimate(out, mask, cov)

    def _localize(self, problem: Problem) -> Estimate:
        triplets = self._triplets(problem.size)
        out = np.empty(OUT_SIZE)
        mask = np.zeros(problem.n_measurements, dtype=np.bool_)
        cov = np.empty((3, 3))
        solve_ransac(problem.floats, problem.ints, triplets, self._settings, out, mask, cov)
        return self._estimate(out, mask, cov)

    @staticmethod
    def _estimate(out: FloatArray, mask: BoolArray, cov: FloatArray) -> Estimate:
        values = out.tolist()  # Python floats: read one by one, far cheaper than numpy scalars
        diagnostics: dict[str, Any] = {"n_triplets": int(values[OUT_TRIED_TRIPLETS]),
                                       "n_valid_triplets": int(values[OUT_VALID_TRIPLETS])}
        if values[OUT_SUPPORT] < MIN_MEASUREMENTS:
            return Estimate.failure(
                "no non-degenerate triplet with at least 3 supporters", mask.size, diagnostics
            )
        diagnostics["triplet_mean_sq_error"] = values[OUT_TRIPLET_MEAN_SQ]
        return package(mask, out, cov, diagnostics)

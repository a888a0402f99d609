"""ng-ransac's compiled search: the consensus first, then the network-guided triplet passes.

:func:`ng_ransac_search` runs it on a frame's usable measurements (``Problem`` rows): it scores
the features' consensus pose with the paper's tolerance (steps 4-5 of ransac, for a pose found
elsewhere) and keeps it when every beacon in view supports it; otherwise the network scores the
measurements and :func:`guided_search` tries the triplets in the order of their joint inlier
probability (:func:`guided_triplets`), then, if no winner is confident, every triplet of the
most probable measurements. The hyperparameters travel in one float array, ransac's
``SETTING_*`` slots followed by the ``SEARCH_*`` slots here (:func:`guided_settings`). The
localizer class, its answer test and its weights are in :mod:`azgym.localize.learned.ng_ransac`.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray
from azgym.jit import jit
from azgym.localize import _kernels as K
from azgym.localize._circles import write_ascending
from azgym.localize.base import MIN_MEASUREMENTS, ROW_BEACON_INDEX, ROW_SOURCE
from azgym.localize.learned.features import (
    CONSENSUS_CANDIDATES,
    CONSENSUS_TOLERANCE,
    N_FEATURES,
    consensus_of,
    fill_features,
)
from azgym.localize.learned.inlier_network import inlier_logits
from azgym.localize.ransac import (
    N_SETTINGS,
    refine_winner,
    score_candidate,
    score_triplets,
    solve_from_triplets,
)

__all__ = ["CONFIDENT_SUPPORT", "CONSENSUS_HYPOTHESES", "confident_support", "guided_search",
           "guided_settings", "guided_triplets", "ng_ransac_search", "support_weight"]


@jit
def guided_triplets(logits, beacon_index, max_ranked, max_hypotheses):
    """The triplets to try, best first: (T, 3) ascending measurement indices, T <= max_hypotheses.

    The ``max_ranked`` measurements with the highest logits form every triplet of three
    different beacons; they are ordered by Σ log σ(z_i) (ties: the lexicographic order of the
    ranked measurements), and the first ``max_hypotheses`` kept.
    """
    ranked = np.argsort(-logits, kind="mergesort")[:max_ranked]
    count = ranked.size
    log_p = np.empty(count)
    for a in range(count):
        z = logits[ranked[a]]
        log_p[a] = -math.log1p(math.exp(-z)) if z > -30.0 else z
    capacity = count * (count - 1) * (count - 2) // 6
    triplets = np.empty((capacity, 3), dtype=np.int64)
    score = np.empty(capacity)
    made = 0
    for a in range(count):
        for b in range(a + 1, count):
            if beacon_index[ranked[a]] == beacon_index[ranked[b]]:
                continue
            for c in range(b + 1, count):
                if beacon_index[ranked[c]] == beacon_index[ranked[a]] or \
                        beacon_index[ranked[c]] == beacon_index[ranked[b]]:
                    continue
                write_ascending(ranked[a], ranked[b], ranked[c], triplets[made])
                score[made] = log_p[a] + log_p[b] + log_p[c]
                made += 1
    order = np.argsort(-score[:made], kind="mergesort")[:max_hypotheses]
    return triplets[order]


# The search's slots follow ransac's ``SETTING_*`` slots in one array (:func:`guided_settings`):
# each argument costs time at the Python/compiled boundary.
SEARCH_RANKED = N_SETTINGS
"""Slot of the guided settings: how many of the most probable measurements the first pass
draws from."""
SEARCH_FIRST = N_SETTINGS + 1
"""Slot of the guided settings: most triplets of the first pass."""
SEARCH_FALLBACK_RANKED = N_SETTINGS + 2
"""Slot of the guided settings: how many form the complete second pass (0: no second pass)."""
SEARCH_CONFIDENT_SHARE = N_SETTINGS + 3
"""Slot of the guided settings: share of the distinct beacons whose support ends the search."""
SEARCH_CONSENSUS_SLACK = N_SETTINGS + 4
"""Slot of the guided settings: most distinct beacons that may not support a consensus pose the
search stops at."""
SEARCH_TOLERANCE = N_SETTINGS + 5
"""Slot of the guided settings: τ, the features' consensus tolerance [rad]."""
GUIDED_SETTINGS_SIZE = N_SETTINGS + 6
"""Length of the guided settings."""
CONSENSUS_HYPOTHESES = tuple(math.comb(n, 3) for n in range(CONSENSUS_CANDIDATES + 1))
"""Triplets the features' consensus solves, by the number of its candidates."""
CONFIDENT_SUPPORT = 4
"""Fewest supporters that end the search after the first pass: three fit any pose."""


@jit
def guided_search(floats, ints, logits, distinct, settings, out, mask, cov):
    """The network-guided passes and the refinement; returns the number of triplets tried.

    The first pass tries the ``SEARCH_FIRST`` best triplets of the ``SEARCH_RANKED`` most
    probable measurements. A winner with at least :func:`confident_support` supporters ends the
    search; otherwise every triplet of the ``SEARCH_FALLBACK_RANKED`` most probable measurements
    is tried, as ransac tries all of them, so a frame the network cannot sort out is never
    searched less than the paper's way.
    """
    fallback = int(settings[SEARCH_FALLBACK_RANKED])
    if _triplet_count(min(fallback, logits.size)) <= 2 * int(settings[SEARCH_FIRST]):
        fallback = 0  # a small frame: one pass over every triplet costs less than two
        triplets = guided_triplets(logits, ints[ROW_BEACON_INDEX], logits.size,
                                   _triplet_count(logits.size))
    else:
        triplets = guided_triplets(logits, ints[ROW_BEACON_INDEX], int(settings[SEARCH_RANKED]),
                                   int(settings[SEARCH_FIRST]))
    pose = np.empty(K.POSE_SIZE)
    support = np.zeros(floats.shape[1], dtype=np.bool_)
    n_support, mean_sq, n_valid = score_triplets(floats, ints, triplets, settings, pose, support)
    tried = triplets.shape[0]
    if n_support < confident_support(settings, distinct) and fallback >= 3:
        everything = guided_triplets(logits, ints[ROW_BEACON_INDEX], fallback,
                                     _triplet_count(fallback))
        if everything.shape[0] > tried:  # else the first pass has tried them all already
            solve_from_triplets(floats, ints, everything, settings, out, mask, cov)
            return tried + everything.shape[0]
    # Only the final winner is refined.
    refine_winner(floats, ints, settings, pose, support, n_support, mean_sq, n_valid, out, mask,
                  cov)
    return tried


@jit(inline="always")
def confident_support(settings, distinct):
    """Supporters that make a winner final: max(CONFIDENT_SUPPORT, share · distinct beacons)."""
    return max(CONFIDENT_SUPPORT, math.ceil(settings[SEARCH_CONFIDENT_SHARE] * distinct))


@jit
def ng_ransac_search(floats, ints, distinct, quality, has_quality, params, hidden, settings,
                     out, mask, cov):
    """The whole search on a frame's usable measurements: consensus first, then the network.

    The features' consensus pose (already solved to compute them) is scored with the paper's
    tolerance; with a confident number of supporters it is refined and final, and the network
    is not needed. Else the
    features are completed, the network scores every measurement and :func:`guided_search`
    runs. ``quality`` is the first quality column of all M measurements (``has_quality`` False:
    none). Returns (triplets the guided search tried, beyond the consensus's; the supporters'
    summed inlier probability, NaN when the network was not consulted).
    """
    tolerance = settings[SEARCH_TOLERANCE]
    q, consensus_support, consensus_pose = consensus_of(floats, ints, quality, has_quality,
                                                        tolerance)
    pose = consensus_pose.copy()
    support = np.zeros(floats.shape[1], dtype=np.bool_)
    n_support, mean_sq = 0, np.inf
    if consensus_support > 0:
        n_support, mean_sq = score_candidate(floats, settings, pose, support)
        if n_support >= max(confident_support(settings, distinct),
                            distinct - settings[SEARCH_CONSENSUS_SLACK]):
            refine_winner(floats, ints, settings, pose, support, n_support, mean_sq, 1, out,
                          mask, cov)
            if n_support < floats.shape[1]:  # else every measurement supports it already
                _local_optimisation(floats, ints, settings, n_support, out, mask, cov)
            return 0, np.nan
    features = np.empty((floats.shape[1], N_FEATURES))
    fill_features(floats, ints, distinct, q, has_quality, consensus_support, consensus_pose,
                  tolerance, features)
    logits = inlier_logits(features, params, hidden)
    if consensus_support > 0 and floats.shape[1] == MIN_MEASUREMENTS:
        # Three measurements make one triplet, the consensus's, already scored: the network
        # has nothing to order, only the answer to test.
        refine_winner(floats, ints, settings, pose, support, n_support, mean_sq, 1, out, mask,
                      cov)
        return 0, support_weight(logits, ints, mask)
    tried = guided_search(floats, ints, logits, distinct, settings, out, mask, cov)
    return tried, support_weight(logits, ints, mask)


@jit(inline="always")
def _triplet_count(n):
    return n * (n - 1) * (n - 2) // 6


@jit
def _local_optimisation(floats, ints, settings, n_support, out, mask, cov):
    """One round of LO-RANSAC (Chum, Matas & Kittler 2003) on an accepted consensus pose.

    The consensus pose is accepted as soon as it is confident, not because no triplet has more
    supporters, and a triplet's noisy pose can leave inliers just outside the tolerance. The
    refined pose's own supporters are counted; when they are more, the pose is refined again on
    them (``out``, ``mask`` and ``cov`` as :func:`solve_from_triplets` fills them).
    """
    refined = out[:K.POSE_SIZE].copy()
    support = np.zeros(floats.shape[1], dtype=np.bool_)
    more, mean_sq = score_candidate(floats, settings, refined, support)
    if more > n_support:
        mask[:] = False
        refine_winner(floats, ints, settings, refined, support, more, mean_sq, 1, out, mask,
                      cov)


@jit
def support_weight(logits, ints, mask):
    """Σ σ(z_u) over the usable measurements ``mask`` (over all M) marks as supporters."""
    weight = 0.0
    for u in range(logits.size):
        if mask[ints[ROW_SOURCE, u]]:
            weight += 1.0 / (1.0 + math.exp(-logits[u]))
    return weight


def guided_settings(settings: FloatArray, max_ranked: int = 8, max_hypotheses: int = 10,
                    fallback_ranked: int = 12, confident_share: float = 0.5,
                    consensus_slack: int = 0,
                    tolerance: float = CONSENSUS_TOLERANCE) -> FloatArray:
    """The guided settings: ransac's ``settings``, then the search's (``SEARCH_*`` slots)."""
    guided = np.empty(GUIDED_SETTINGS_SIZE)
    guided[:N_SETTINGS] = settings
    guided[SEARCH_RANKED] = max_ranked
    guided[SEARCH_FIRST] = max_hypotheses
    guided[SEARCH_FALLBACK_RANKED] = fallback_ranked
    guided[SEARCH_CONFIDENT_SHARE] = confident_share
    guided[SEARCH_CONSENSUS_SLACK] = consensus_slack
    guided[SEARCH_TOLERANCE] = tolerance
    return guided

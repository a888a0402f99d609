"""``ng-ransac``: the paper's RANSAC, guided by a network's inlier probabilities (NG-RANSAC).

Brachmann & Rother's Neural-Guided RANSAC ("Learning Where to Sample Model Hypotheses", ICCV
2019) lets a network score each correspondence's chance of being an inlier and draws minimal
sets by it, so that few hypotheses find the model. Here the correspondences are a frame's
azimuths, the minimal set is the paper's triplet (Rátosi & Simon 2021, eq. 7-20), and:

1. a small set network (:mod:`azgym.learn.network`) gives each usable measurement a logit z_i
   from its features (:mod:`azgym.learn.features`: what sets mirror ghosts, misread ids and
   moved beacons apart from good views, such as a ghost's dimmer blob);
2. the ``max_ranked`` most probable measurements form the candidate triplets, tried in order of
   their joint log-probability Σ log σ(z_i), at most ``max_hypotheses`` of them (a triplet
   with two detections of one beacon is never tried: it cannot be solved);
3. the paper's tolerance scores them and its refinement finishes (ransac's own compiled steps
   1-6, :func:`azgym.localize.ransac.solve_from_triplets`): the winner has the most supporters;
4. the answer stands only if its supporters' summed inlier probability reaches
   ``min_support_weight``: three supporters that the network takes for ghosts are a pose no
   frame can confirm, and the frame is refused rather than answered metres off.

The order is deterministic (the best triplets first, not a random draw), so the same frame gets
the same answer. The network is trained in PyTorch (``azgym train localizer``) and served here
in compiled numpy; this module never imports torch.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from azgym.core import BeaconMap, Estimate, FloatArray, Measurements
from azgym.errors import InvalidInputError
from azgym.hyperparameters import check_flag, check_range
from azgym.jit import jit
from azgym.learn.features import (
    CONSENSUS_CANDIDATES,
    FEATURE_LAYOUT,
    N_FEATURES,
    first_quality_column,
    frame_features,
    measurement_features,
)
from azgym.learn.network import InlierScorer, inlier_logits
from azgym.learn.weights import load_weights, model_path
from azgym.localize.base import (
    MIN_MEASUREMENTS,
    ROW_BEACON_INDEX,
    ROW_SOURCE,
    Localizer,
    Problem,
    gather,
)
from azgym.localize.ransac import (
    OUT_SIZE,
    OUT_SUPPORT,
    OUT_TRIPLET_MEAN_SQ,
    OUT_VALID_TRIPLETS,
    settings_array,
    solve_from_triplets,
)
from azgym.localize.refinement import package

MODEL_NAME = "ng-ransac"
"""The model name a weight file for this localizer must carry."""
SHIPPED_WEIGHTS = Path(__file__).resolve().parent.parent / "learn" / "models" / "ng-ransac.npz"
"""The trained weights that ship inside the package (model card beside them)."""


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
                _ascending(ranked[a], ranked[b], ranked[c], triplets[made])
                score[made] = log_p[a] + log_p[b] + log_p[c]
                made += 1
    order = np.argsort(-score[:made], kind="mergesort")[:max_hypotheses]
    return triplets[order]


SEARCH_RANKED = 0
"""Slot of ``search``: how many of the most probable measurements the first pass draws from."""
SEARCH_FIRST = 1
"""Slot of ``search``: most triplets of the first pass."""
SEARCH_FALLBACK_RANKED = 2
"""Slot of ``search``: how many form the complete second pass (0: no second pass)."""
SEARCH_CONFIDENT_SHARE = 3
"""Slot of ``search``: share of the distinct beacons whose support ends the search."""
SEARCH_SIZE = 4
"""Length of ``search``."""
CONFIDENT_SUPPORT = 4
"""Fewest supporters that end the search after the first pass: three fit any pose."""


@jit
def guided_search(floats, ints, logits, distinct, search, settings, out, mask, cov):
    """The guided search and the refinement; returns the number of triplets tried.

    The first pass tries the ``SEARCH_FIRST`` best triplets of the ``SEARCH_RANKED`` most
    probable measurements. A winner with at least max(CONFIDENT_SUPPORT, share · distinct)
    supporters ends the search; otherwise every triplet of the ``SEARCH_FALLBACK_RANKED`` most
    probable measurements is tried, as ransac tries all of them, so a frame the network cannot
    sort out is never searched less than the paper's way.
    """
    fallback = int(search[SEARCH_FALLBACK_RANKED])
    if _triplet_count(min(fallback, logits.size)) <= 2 * int(search[SEARCH_FIRST]):
        fallback = 0  # a small frame: one pass over every triplet costs less than two
        triplets = guided_triplets(logits, ints[ROW_BEACON_INDEX], logits.size,
                                   _triplet_count(logits.size))
    else:
        triplets = guided_triplets(logits, ints[ROW_BEACON_INDEX], int(search[SEARCH_RANKED]),
                                   int(search[SEARCH_FIRST]))
    solve_from_triplets(floats, ints, triplets, settings, out, mask, cov)
    tried = triplets.shape[0]
    confident = max(CONFIDENT_SUPPORT, math.ceil(search[SEARCH_CONFIDENT_SHARE] * distinct))
    if out[OUT_SUPPORT] >= confident or fallback < 3:
        return tried
    everything = guided_triplets(logits, ints[ROW_BEACON_INDEX], fallback,
                                 _triplet_count(fallback))
    if everything.shape[0] > tried:  # else the first pass has tried them all already
        mask[:] = False
        solve_from_triplets(floats, ints, everything, settings, out, mask, cov)
        tried += everything.shape[0]
    return tried


@jit(inline="always")
def _triplet_count(n):
    return n * (n - 1) * (n - 2) // 6


@jit
def _ng_ransac_frame(ids, azimuth, quality, has_quality, sorted_ids, sorted_order, xyz, width,
                     params, hidden, search, settings, out, mask, cov):
    """The whole frame in one compiled call: id lookup, features, logits, guided search, step 6.

    Returns (distinct beacons, triplets tried by the search, the supporters' summed inlier
    probability); with fewer than MIN_MEASUREMENTS distinct beacons nothing else is done.
    """
    floats, ints, distinct = gather(ids, azimuth, sorted_ids, sorted_order, xyz, width)
    if distinct < MIN_MEASUREMENTS:
        return distinct, 0, 0.0
    features = np.empty((floats.shape[1], N_FEATURES))
    frame_features(floats, ints, distinct, quality, has_quality, features)
    logits = inlier_logits(features, params, hidden)
    tried = guided_search(floats, ints, logits, distinct, search, settings, out, mask, cov)
    return distinct, tried, support_weight(logits, ints, mask)


@jit
def support_weight(logits, ints, mask):
    """Σ σ(z_u) over the usable measurements ``mask`` (over all M) marks as supporters."""
    weight = 0.0
    for u in range(logits.size):
        if mask[ints[ROW_SOURCE, u]]:
            weight += 1.0 / (1.0 + math.exp(-logits[u]))
    return weight


@jit(inline="always")
def _ascending(i, j, k, row):
    """Write the triplet (i, j, k) into ``row`` in ascending order, as the solver takes it."""
    if i > j:
        i, j = j, i
    if j > k:
        j, k = k, j
    if i > j:
        i, j = j, i
    row[0] = i
    row[1] = j
    row[2] = k


def search_array(max_ranked: int = 8, max_hypotheses: int = 10, fallback_ranked: int = 12,
                 confident_share: float = 0.5) -> FloatArray:
    """The search's hyperparameters as :func:`guided_search` takes them (``SEARCH_*`` slots)."""
    search = np.empty(SEARCH_SIZE)
    search[SEARCH_RANKED] = max_ranked
    search[SEARCH_FIRST] = max_hypotheses
    search[SEARCH_FALLBACK_RANKED] = fallback_ranked
    search[SEARCH_CONFIDENT_SHARE] = confident_share
    return search


class NgRansac(Localizer):
    """The paper's RANSAC on the triplets a network ranks first (module docstring).

    Args:
        weights: Path of a weight file (``azgym train localizer --model ng-ransac`` writes one);
            None for the weights shipped with azgym.
        max_hypotheses: Most triplets the guided search solves and scores per frame, beyond
            the at most 20 the features' consensus pose is chosen from.
        max_ranked: How many of the most probable measurements the triplets are formed from.
        fallback_ranked: How many of the most probable measurements form every triplet of the
            second pass, when the first is not confident (0: never a second pass).
        confident_share: Share of the distinct beacons (at least CONFIDENT_SUPPORT) whose
            support makes the first pass's winner final.
        min_support_weight: Least summed inlier probability of the winner's supporters for an
            answer; None for the value calibrated with the weights (in their manifest).
        delta_alpha_d: Δα_d, half-width of the centre-detection error [rad] (eq. 1).
        coverage: Whether the tolerance includes the coverage term Δα_c,i (eq. 2).
        weighted: Weight the refinement by the error model's variances.
        degeneracy_tol: Triplets whose normalised determinant is below this are skipped.
        max_iter: Iteration limit of the refinement.
    """

    name = "ng-ransac"

    def __init__(self, *, weights: str | None = None, max_hypotheses: int = 10,
                 max_ranked: int = 8, fallback_ranked: int = 12, confident_share: float = 0.5,
                 min_support_weight: float | None = None,
                 delta_alpha_d: float = math.radians(0.4), coverage: bool = True,
                 weighted: bool = False, degeneracy_tol: float = 1e-9,
                 max_iter: int = 50) -> None:
        self.weights = weights
        self.max_hypotheses = max_hypotheses
        self.max_ranked = max_ranked
        self.fallback_ranked = fallback_ranked
        self.confident_share = confident_share
        self.min_support_weight = min_support_weight
        self.delta_alpha_d = delta_alpha_d
        self.coverage = coverage
        self.weighted = weighted
        self.degeneracy_tol = degeneracy_tol
        self.max_iter = max_iter
        self._validate_once()

    def _check_params(self) -> None:
        name = type(self).__name__
        check_range(name, "max_hypotheses", self.max_hypotheses, low=1, integer=True)
        check_range(name, "max_ranked", self.max_ranked, low=3, high=64, integer=True)
        check_range(name, "fallback_ranked", self.fallback_ranked, low=0, high=24, integer=True)
        if 0 < self.fallback_ranked < self.max_ranked:
            raise InvalidInputError(f"{name}.fallback_ranked must be 0 (no second pass) or at "
                                    f"least max_ranked={self.max_ranked}, got "
                                    f"{self.fallback_ranked}")
        check_range(name, "confident_share", self.confident_share, low=0.0, high=1.0)
        check_range(name, "delta_alpha_d", self.delta_alpha_d, low=0.0, high=math.pi / 2,
                    high_open=True)
        check_range(name, "degeneracy_tol", self.degeneracy_tol, low=0.0, high=1.0)
        check_range(name, "max_iter", self.max_iter, low=1, integer=True)
        check_flag(name, "coverage", self.coverage)
        check_flag(name, "weighted", self.weighted)
        if self.min_support_weight is not None:
            check_range(name, "min_support_weight", self.min_support_weight, low=0.0)
        self._load_model()
        self._settings = settings_array(self.delta_alpha_d, bool(self.coverage),
                                        self.degeneracy_tol, bool(self.weighted), self.max_iter)
        self._search = search_array(self.max_ranked, self.max_hypotheses,
                                    self.fallback_ranked, self.confident_share)

    def _load_model(self) -> None:
        """Load the weights (once per path): the scorer, its feature layout, its calibration."""
        path = model_path(type(self).__name__, self.weights, SHIPPED_WEIGHTS)
        if getattr(self, "_loaded_from", None) == path:
            return
        arrays, manifest = load_weights(path, MODEL_NAME, feature_layout=FEATURE_LAYOUT)
        self._scorer = InlierScorer(arrays, manifest)
        self._calibrated_weight = float(manifest.get("calibration", {}).get(
            "min_support_weight", 0.0))
        self._loaded_from = path

    def support_threshold(self) -> float:
        """The summed inlier probability an answer's supporters need."""
        if self.min_support_weight is not None:
            return float(self.min_support_weight)
        return self._calibrated_weight

    def inlier_logits(self, problem: Problem, quality: FloatArray | None) -> FloatArray:
        """The network's logit of each usable measurement of ``problem`` being an inlier."""
        return self._scorer.logits(measurement_features(problem, quality))

    def _localize_frame(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        column, has_quality = first_quality_column(measurements.quality, len(measurements))
        out = np.empty(OUT_SIZE)
        mask = np.zeros(len(measurements), dtype=np.bool_)
        cov = np.empty((3, 3))
        distinct, tried, weight = _ng_ransac_frame(
            measurements.ids, measurements.azimuth, column, has_quality,
            *beacons.lookup_tables(), self._scorer.params, self._scorer.hidden, self._search,
            self._settings, out, mask, cov)
        if distinct < MIN_MEASUREMENTS:
            return super()._localize_frame(measurements, beacons)  # the standard refusal
        return self._answer(distinct, tried, weight, out, mask, cov)

    def _localize(self, problem: Problem) -> Estimate:
        """A :class:`Problem` without the frame's quality (the features then do without)."""
        logits = self.inlier_logits(problem, None)
        out = np.empty(OUT_SIZE)
        mask = np.zeros(problem.n_measurements, dtype=np.bool_)
        cov = np.empty((3, 3))
        tried = guided_search(problem.floats, problem.ints, logits, problem.n_distinct,
                              self._search, self._settings, out, mask, cov)
        return self._answer(problem.n_distinct, tried,
                            support_weight(logits, problem.ints, mask), out, mask, cov)

    def _answer(self, distinct: int, tried: int, weight: float, out: FloatArray,
                mask: np.ndarray, cov: FloatArray) -> Estimate:
        """The estimate of a search: refused when its supporters' inlier weight is too low."""
        consensus = math.comb(min(CONSENSUS_CANDIDATES, distinct), 3)
        diagnostics = {"n_hypotheses": consensus + tried,
                       "n_valid_triplets": int(out[OUT_VALID_TRIPLETS])}
        if out[OUT_SUPPORT] < MIN_MEASUREMENTS:
            return Estimate.failure("no non-degenerate triplet with at least 3 supporters",
                                    mask.size, diagnostics)
        diagnostics["support_weight"] = weight
        threshold = self.support_threshold()
        if weight < threshold:
            return Estimate.failure(
                f"the winning pose's supporters look like outliers: their summed inlier "
                f"probability {weight:.2f} is under min_support_weight {threshold:.2f}",
                mask.size, diagnostics)
        diagnostics["triplet_mean_sq_error"] = float(out[OUT_TRIPLET_MEAN_SQ])
        return package(mask, out, cov, diagnostics)

"""``ng-ransac``: the paper's RANSAC, guided by a network's inlier probabilities (NG-RANSAC).

Brachmann & Rother's Neural-Guided RANSAC ("Learning Where to Sample Model Hypotheses", ICCV
2019) lets a network score each correspondence's chance of being an inlier and draws minimal
sets by it, so that few hypotheses find the model. Here the correspondences are a frame's
azimuths, the minimal set is the paper's triplet (Rátosi & Simon 2021, eq. 7-20), and:

1. the features' consensus pose (:mod:`azgym.localize.learned.features`, the best supported
   triplet of up to six measurements of distinct beacons, already solved to compute the features) is
   scored with the paper's tolerance; when every beacon in view supports it (at most
   ``consensus_slack`` do not) and they are at least max(CONFIDENT_SUPPORT, ``confident_share``
   of the distinct beacons), it is refined, locally optimised once, and final: nothing in the
   frame disagrees, so the network has nothing to sort out;
2. otherwise a small set network (:mod:`azgym.localize.learned.inlier_network`) gives each
   usable measurement a logit z_i from its features (what sets mirror ghosts, misread ids and
   moved beacons apart from good views, such as a ghost's dimmer blob);
3. the ``max_ranked`` most probable measurements form the candidate triplets, tried in order of
   their joint log-probability Σ log σ(z_i), at most ``max_hypotheses`` of them (a triplet
   with two detections of one beacon is never tried: it cannot be solved), and, when their
   winner is not confident, every triplet of the ``fallback_ranked`` most probable; the
   paper's tolerance scores them and its refinement finishes the winner (ransac's own
   compiled steps 1-6; the search itself is :mod:`azgym.localize.learned.ng_search`);
4. a guided answer stands only if its supporters' summed inlier probability reaches
   ``min_support_weight``: three supporters that the network takes for ghosts are a pose no
   frame can confirm, and the frame is refused rather than answered metres off.

The features' consensus tolerance scales with ``delta_alpha_d`` (the network reads residuals
in units of the camera's noise), and frames unlike the training frames are refused with the
reason before any of this: a noise, ``field_of_view``, azimuth spread or number of beacons the
weights' training distribution does not hold (:mod:`azgym.localize.learned.distribution`).

The order is deterministic (the best triplets first, not a random draw), so the same frame gets
the same answer. The network is trained in PyTorch (``azgym train localizer``) and served here
in compiled numpy; this module never imports torch.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from azgym.core import BeaconMap, Estimate, FloatArray, Measurements
from azgym.errors import InvalidInputError
from azgym.hyperparameters import check_flag, check_range
from azgym.jit import jit
from azgym.localize._angles import azimuth_spread
from azgym.localize.base import (
    MIN_MEASUREMENTS,
    ROW_AZIMUTH,
    Localizer,
    Problem,
    gather,
)
from azgym.localize.learned.distribution import TrainingDistribution
from azgym.localize.learned.features import (
    CONSENSUS_CANDIDATES,
    FEATURE_LAYOUT,
    consensus_tolerance,
    first_quality_column,
    measurement_features,
)
from azgym.localize.learned.inlier_network import InlierScorer
from azgym.localize.learned.ng_search import (
    CONSENSUS_HYPOTHESES,
    guided_settings,
    ng_ransac_search,
)
from azgym.localize.learned.weights import MODELS, load_weights, model_path
from azgym.localize.ransac import (
    OUT_SIZE,
    OUT_SUPPORT,
    OUT_TRIPLET_MEAN_SQ,
    OUT_VALID_TRIPLETS,
    settings_array,
)
from azgym.localize.refinement import package

__all__ = ["MODEL_NAME", "NgRansac", "SHIPPED_WEIGHTS"]

MODEL_NAME = "ng-ransac"
"""The model name a weight file for this localizer must carry."""
SHIPPED_WEIGHTS = MODELS / f"{MODEL_NAME}.npz"
"""The trained weights that ship inside the package (model card beside them)."""
NO_QUALITY = np.zeros(0)
"""The quality column the kernels get for a frame without quality: read-only, as a frame's own
quality column is, so that the kernels are compiled for one kind of array, not two."""
NO_QUALITY.setflags(write=False)


@jit
def _ng_ransac_frame(ids, azimuth, quality, sorted_ids, sorted_order, xyz, width, params, hidden,
                     settings, out, mask, cov):
    """The whole frame in one compiled call: the id lookup, then :func:`ng_ransac_search`.

    ``quality`` is the first quality column, empty when the frame has none. Returns (distinct
    beacons, their azimuth spread, triplets tried, the supporters' summed inlier probability);
    with fewer than MIN_MEASUREMENTS distinct beacons nothing else is done.
    """
    floats, ints, distinct = gather(ids, azimuth, sorted_ids, sorted_order, xyz, width)
    if distinct < MIN_MEASUREMENTS:
        return distinct, 0.0, 0, np.nan
    spread = azimuth_spread(floats[ROW_AZIMUTH])
    tried, weight = ng_ransac_search(floats, ints, distinct, quality, quality.size > 0, params,
                                     hidden, settings, out, mask, cov)
    return distinct, spread, tried, weight


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
            support makes a winner final: the consensus pose's or the first pass's.
        consensus_slack: Most distinct beacons that may not support the consensus pose for it
            to be final without the network (besides ``confident_share``).
        min_support_weight: Least summed inlier probability of the winner's supporters for an
            answer; None for the value calibrated with the weights (in their manifest).
        delta_alpha_d: Δα_d, half-width of the centre-detection error [rad] (eq. 1).
        coverage: Whether the tolerance includes the coverage term Δα_c,i (eq. 2).
        field_of_view: The camera's full horizontal view [rad]; None: not stated. A view
            narrower than the training frames' azimuth spread is refused.
        weighted: Weight the refinement by the error model's variances.
        degeneracy_tol: Triplets whose normalised determinant is below this are skipped.
        max_iter: Iteration limit of the refinement.
    """

    name = "ng-ransac"

    def __init__(self, *, weights: str | None = None, max_hypotheses: int = 10,
                 max_ranked: int = 8, fallback_ranked: int = 12, confident_share: float = 0.5,
                 consensus_slack: int = 0, min_support_weight: float | None = None,
                 delta_alpha_d: float = math.radians(0.4), coverage: bool = True,
                 field_of_view: float | None = None, weighted: bool = False,
                 degeneracy_tol: float = 1e-9, max_iter: int = 50) -> None:
        self.weights = weights
        self.max_hypotheses = max_hypotheses
        self.max_ranked = max_ranked
        self.fallback_ranked = fallback_ranked
        self.confident_share = confident_share
        self.consensus_slack = consensus_slack
        self.min_support_weight = min_support_weight
        self.delta_alpha_d = delta_alpha_d
        self.coverage = coverage
        self.field_of_view = field_of_view
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
        check_range(name, "consensus_slack", self.consensus_slack, low=0, integer=True)
        check_range(name, "delta_alpha_d", self.delta_alpha_d, low=0.0, high=math.pi / 2,
                    high_open=True)
        check_range(name, "degeneracy_tol", self.degeneracy_tol, low=0.0, high=1.0)
        check_range(name, "max_iter", self.max_iter, low=1, integer=True)
        check_flag(name, "coverage", self.coverage)
        check_flag(name, "weighted", self.weighted)
        if self.min_support_weight is not None:
            check_range(name, "min_support_weight", self.min_support_weight, low=0.0)
        if self.field_of_view is not None:
            check_range(name, "field_of_view", self.field_of_view, low=0.0, high=2 * math.pi,
                        low_open=True)
        self._load_model()
        self._tolerance = consensus_tolerance(self.delta_alpha_d,
                                              self._distribution.trained_delta_alpha_d)
        self._settings = guided_settings(
            settings_array(self.delta_alpha_d, bool(self.coverage), self.degeneracy_tol,
                           bool(self.weighted), self.max_iter),
            self.max_ranked, self.max_hypotheses, self.fallback_ranked, self.confident_share,
            self.consensus_slack, self._tolerance)
        self._off_distribution = self._distribution.settings_reason(self.delta_alpha_d,
                                                                    self.field_of_view)
        self._threshold = self.support_threshold()

    def _load_model(self) -> None:
        """Load the weights (once per path): the scorer, its feature layout, its calibration."""
        path = model_path(type(self).__name__, self.weights, SHIPPED_WEIGHTS)
        if getattr(self, "_loaded_from", None) == path:
            return
        arrays, manifest = load_weights(path, MODEL_NAME, feature_layout=FEATURE_LAYOUT)
        self._scorer = InlierScorer(arrays, manifest)
        self._calibrated_weight = float(manifest.get("calibration", {}).get(
            "min_support_weight", 0.0))
        self._distribution = TrainingDistribution.of_manifest(manifest)
        self._loaded_from = path

    def support_threshold(self) -> float:
        """The summed inlier probability an answer's supporters need."""
        if self.min_support_weight is not None:
            return float(self.min_support_weight)
        return self._calibrated_weight

    def inlier_logits(self, problem: Problem, quality: FloatArray | None) -> FloatArray:
        """The network's logit of each usable measurement of ``problem`` being an inlier."""
        return self._scorer.logits(measurement_features(problem, quality, self._tolerance))

    def _localize_frame(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        if self._off_distribution:
            return self._distribution.refusal(self._off_distribution, len(measurements))
        column, has_quality = first_quality_column(measurements.quality, len(measurements))
        out = np.empty(OUT_SIZE)
        mask = np.zeros(len(measurements), dtype=np.bool_)
        cov = np.empty((3, 3))
        distinct, spread, tried, weight = _ng_ransac_frame(
            measurements.ids, measurements.azimuth, column if has_quality else NO_QUALITY,
            *beacons.lookup_tables(),
            self._scorer.params, self._scorer.hidden, self._settings, out, mask, cov)
        if distinct < MIN_MEASUREMENTS:
            return super()._localize_frame(measurements, beacons)  # the standard refusal
        reason = self._distribution.frame_reason(distinct, spread)
        if reason:
            return self._distribution.refusal(reason, len(measurements))
        return self._answer(distinct, tried, weight, out, mask, cov)

    def _localize(self, problem: Problem) -> Estimate:
        """A :class:`Problem` without the frame's quality (the features then do without)."""
        out = np.empty(OUT_SIZE)
        mask = np.zeros(problem.n_measurements, dtype=np.bool_)
        cov = np.empty((3, 3))
        tried, weight = ng_ransac_search(
            np.ascontiguousarray(problem.floats), np.ascontiguousarray(problem.ints),
            problem.n_distinct, NO_QUALITY, False, self._scorer.params, self._scorer.hidden,
            self._settings, out, mask, cov)
        return self._answer(problem.n_distinct, tried, weight, out, mask, cov)

    def _answer(self, distinct: int, tried: int, weight: float, out: FloatArray,
                mask: np.ndarray, cov: FloatArray) -> Estimate:
        """The estimate of a search: refused when its supporters' inlier weight is too low.

        ``weight`` is NaN when the consensus settled the frame without the network: a
        confident pose needs no answer test (diagnostics ``guided`` False).
        """
        consensus = CONSENSUS_HYPOTHESES[min(CONSENSUS_CANDIDATES, distinct)]
        guided = not math.isnan(weight)
        diagnostics: dict[str, Any] = {"n_hypotheses": consensus + tried,
                                       "n_valid_triplets": int(out[OUT_VALID_TRIPLETS]),
                                       "guided": guided}
        if out[OUT_SUPPORT] < MIN_MEASUREMENTS:
            return Estimate.failure("no non-degenerate triplet with at least 3 supporters",
                                    mask.size, diagnostics)
        threshold = self._threshold
        if guided:
            diagnostics["support_weight"] = weight
        if guided and weight < threshold:
            return Estimate.failure(
                f"the winning pose's supporters look like outliers: their summed inlier "
                f"probability {weight:.2f} is under min_support_weight {threshold:.2f}",
                mask.size, diagnostics)
        diagnostics["triplet_mean_sq_error"] = float(out[OUT_TRIPLET_MEAN_SQ])
        return package(mask, out, cov, diagnostics)

"""``learned``: the pose regressed by a set network from the frame's measurements (PoseNet-style).

The honest baseline of "just learn it": no triplet search, no consensus vote of the pose. A
small permutation-invariant network (:mod:`azgym.localize.learned.pose_network`) reads one token
per usable measurement (its camera-frame azimuth, its beacon's position normalised by the frame's
beacons, and the measurement features of :mod:`azgym.localize.learned.features`) and answers

1. the camera's position (u, v) in the frame's normalised coordinates, mapped back to the map's
   (x = c + s u), with a log-variance per axis (trained as a Gaussian NLL): the estimate's
   position covariance, s² e^{log σ²};
2. a trust logit per measurement (trained on the inlier labels).

The heading is not regressed: with the position known it has a closed form, the circular mean
of β_i − α_i over the measurements (the φ' of eq. 29, :func:`azgym.localize.lsq.heading_sum`),
taken over those the network trusts (trust logit ≥ 0; all of them if none). Its variance is the
position's seen from the trusted beacons (σ²_pos / d_i², averaged) plus the spread of β_i − α_i
(−2 ln R, R their mean resultant length).

Optionally (``refine_rounds`` > 0, the default), a short robust refinement finishes, the paper's
refinement (eq. 28-33, with its error-model covariance:
:func:`azgym.localize.refinement.refine_with_covariance`) on a chosen set per round: the first
round, from the regressed pose, takes every measurement whose trust logit is at least ``min_trust``
(all of them if those see fewer than three beacons); each later round every measurement whose
residual at the current pose is within a gate, trusted or not, the gates shrinking by
``GATE_GROWTH`` per round down to ``gate`` (iteratively trimmed least squares, the hard form of
IRLS): the network chooses the basin, the error model the inliers. By default the last gate is the
features' consensus tolerance, 1° at the training noise, so it scales with the camera's noise as the
features do. The defaults (3 rounds, 1°, −2) were chosen with the shipped weights on frames of the
held-out generated layouts (data seed 7, 1,200 frames; never a suite's; ``python
baselines/learned_defaults.py`` prints the table): p75 3.47 cm there, 7.8 % beyond 1 m;
``min_trust`` −4 lets the measurements the network doubts into the first round (p75 12.2 cm), 0
leaves out good views it doubted (9.3 % beyond 1 m); a fourth round or another last gate (0.5°, 2°)
moved p75 by at most 0.35 cm. A round that keeps fewer than three beacons, or whose refinement does
not converge, ends the refinement with the pose before it. ``refine_rounds=0`` is the pure
regression; the model card and the report give both variants' figures. The default is the refinement
because the pure regression is metres off in large warehouses, where a centimetre azimuth fit is
cheap once a start in the right basin is known (the network's job).

A frame of three distinct beacons like the training frames is always answered (the regression
cannot fail); the covariance says how far to trust it. A frame unlike them is refused with the
reason: a noise, ``field_of_view``, azimuth spread or number of beacons the weights' training
distribution does not hold (:mod:`azgym.localize.learned.distribution`); the features' consensus
tolerance scales with ``delta_alpha_d`` (the network reads residuals in units of the camera's
noise). Everything runs in one compiled call (id lookup, features, tokens, network, heading,
refinement); this module never imports torch.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import BeaconMap, Estimate, FloatArray, Measurements
from azgym.hyperparameters import check_flag, check_range
from azgym.jit import jit
from azgym.localize import _kernels as K
from azgym.localize._angles import azimuth_spread
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
from azgym.localize.learned.distribution import TrainingDistribution
from azgym.localize.learned.features import (
    CONSENSUS_TOLERANCE,
    FEATURE_LAYOUT,
    N_FEATURES,
    consensus_tolerance,
    first_quality_column,
    frame_features,
    measurement_features,
)
from azgym.localize.learned.pose_network import (
    N_TOKENS,
    OUTPUTS,
    PoseRegressor,
    frame_tokens,
    regress,
)
from azgym.localize.learned.weights import MODELS, load_weights, model_path
from azgym.localize.lsq import heading_sum
from azgym.localize.refinement import refine_with_covariance

__all__ = ["Learned", "MODEL_NAME", "OUT_ITERATIONS", "OUT_SIZE", "SET_GATE", "SHIPPED_WEIGHTS",
           "settings_array", "solve_regressed"]

MODEL_NAME = "learned"
"""The model name a weight file for this localizer must carry."""
SHIPPED_WEIGHTS = MODELS / f"{MODEL_NAME}.npz"
"""The trained weights that ship inside the package (model card beside them)."""
GATE_GROWTH = 3.0
"""Each refinement round's gate is this times the next one's (the last is ``gate``)."""

# The settings array the compiled frame reads (one array, not six arguments).
(SET_ROUNDS, SET_GATE, SET_MIN_TRUST, SET_DELTA_D, SET_COVERAGE, SET_MAX_ITER, SET_TOLERANCE,
 SET_SIZE) = range(8)
# The output array: the final pose (K.POSE_* slots), then what the diagnostics report.
OUT_REGRESSED_X = K.POSE_SIZE
OUT_REGRESSED_Y = K.POSE_SIZE + 1
OUT_REGRESSED_STD = K.POSE_SIZE + 2
"""The regressed position's standard deviation √(σ_x² + σ_y²) [m]."""
OUT_ITERATIONS = K.POSE_SIZE + 3
OUT_SIZE = K.POSE_SIZE + 4


@jit
def solve_regressed(floats, ints, features, params, hidden, settings, out, cov, inliers):
    """A frame's pose from its usable measurements (module docstring); returns rounds refined.

    ``floats``/``ints`` are a ``Problem``'s, ``features`` its (K, N_FEATURES); writes the pose
    and diagnostics into ``out`` (OUT_SIZE), the covariance into ``cov`` and the measurements
    used into ``inliers`` (over the frame's M measurements, through the source row).
    """
    k = floats.shape[1]
    tokens = np.empty((k, N_TOKENS))
    cx, cy, scale = frame_tokens(floats, features, tokens)
    trust, head = np.empty(k), np.empty(OUTPUTS)
    regress(tokens, params, hidden, trust, head)
    x, y = cx + scale * head[0], cy + scale * head[1]
    var_x, var_y = scale * scale * math.exp(head[2]), scale * scale * math.exp(head[3])
    use = trust >= 0.0
    if not use.any():
        use[:] = True
    ch, sh, var_phi = _closed_form_heading(floats, use, x, y, 0.5 * (var_x + var_y))
    out[K.POSE_X], out[K.POSE_Y], out[K.POSE_COS], out[K.POSE_SIN] = x, y, ch, sh
    out[OUT_REGRESSED_X], out[OUT_REGRESSED_Y] = x, y
    out[OUT_REGRESSED_STD] = math.sqrt(var_x + var_y)
    out[OUT_ITERATIONS] = 0.0
    cov[:, :] = 0.0
    cov[0, 0], cov[1, 1], cov[2, 2] = var_x, var_y, var_phi
    rounds = _refine_rounds(floats, ints, trust, settings, out, cov, use)
    inliers[:] = False
    for u in range(k):
        inliers[ints[ROW_SOURCE, u]] = use[u]
    return rounds


@jit
def _closed_form_heading(floats, use, x, y, var_position):
    """(cos φ, sin φ, var φ) at (x, y) from the measurements in ``use`` (module docstring)."""
    bx, by = floats[ROW_BX], floats[ROW_BY]
    hx, hy = heading_sum(bx, by, floats[ROW_COS_AZ], floats[ROW_SIN_AZ], use, x, y)
    norm = math.hypot(hx, hy)
    count, seen = 0, 0.0
    for u in range(bx.size):
        d2 = (bx[u] - x) ** 2 + (by[u] - y) ** 2
        if use[u] and d2 > 0.0:
            count += 1
            seen += var_position / d2
    if norm == 0.0 or count == 0:
        return 1.0, 0.0, math.pi ** 2 / 3.0  # no direction: a heading uniform on the circle
    spread = -2.0 * math.log(min(norm / count, 1.0))
    return hx / norm, hy / norm, seen / count + spread


@jit
def _refine_rounds(floats, ints, trust, settings, out, cov, use):
    """The gated refinement rounds (module docstring); ``use`` ends as the last round's set."""
    rounds = int(settings[SET_ROUNDS])
    k = floats.shape[1]
    bx, by, ca, sa = floats[ROW_BX], floats[ROW_BY], floats[ROW_COS_AZ], floats[ROW_SIN_AZ]
    trial = np.empty(K.REFINED_SIZE)
    trial_cov = np.empty((3, 3))
    done = 0
    for r in range(rounds):
        gate = settings[SET_GATE] * GATE_GROWTH ** (rounds - 1 - r)
        if r == 0:
            keep = trust >= settings[SET_MIN_TRUST]
        else:
            keep = np.empty(k, dtype=np.bool_)
            for u in range(k):
                keep[u] = abs(_residual(bx[u] - out[K.POSE_X], by[u] - out[K.POSE_Y],
                                        out[K.POSE_COS], out[K.POSE_SIN], ca[u], sa[u])) <= gate
        if _distinct(ints[ROW_BEACON_INDEX], keep) < MIN_MEASUREMENTS:
            if r > 0:
                break
            keep[:] = True  # the first round takes every measurement rather than none
        refine_with_covariance(bx, by, ca, sa, floats[ROW_WIDTH], keep, False,
                               settings[SET_DELTA_D], settings[SET_COVERAGE] > 0.0, out,
                               int(settings[SET_MAX_ITER]), trial, trial_cov)
        finite = math.isfinite(trial[K.POSE_X]) and math.isfinite(trial[K.POSE_Y])
        if trial[K.REFINED_STATUS] != K.CONVERGED or not finite:
            break
        for slot in range(K.POSE_SIZE):
            out[slot] = trial[slot]
        out[OUT_ITERATIONS] += trial[K.REFINED_ITERATIONS]
        cov[:, :] = trial_cov
        use[:] = keep
        done += 1
    return done


@jit(inline="always")
def _residual(dx, dy, ch, sh, ca, sa):
    """Measured minus predicted azimuth [rad] of a beacon at (dx, dy) from a camera heading φ."""
    px = dx * ch + dy * sh  # the beacon's direction in the camera frame (rotated by −φ)
    py = dy * ch - dx * sh
    return math.atan2(px * sa - py * ca, px * ca + py * sa)


@jit(inline="always")
def _distinct(beacon, keep):
    """Distinct beacons among the kept measurements."""
    count = 0
    for u in range(beacon.size):
        if keep[u]:
            first = True
            for v in range(u):
                first &= not (keep[v] and beacon[v] == beacon[u])
            count += first
    return count


@jit
def _learned_frame(ids, azimuth, quality, has_quality, sorted_ids, sorted_order, xyz, width,
                   params, hidden, settings, out, cov, inliers):
    """The whole frame in one compiled call.

    Returns (distinct beacons, their azimuth spread, rounds refined); with fewer than
    MIN_MEASUREMENTS distinct beacons nothing else is done.
    """
    floats, ints, distinct = gather(ids, azimuth, sorted_ids, sorted_order, xyz, width)
    if distinct < MIN_MEASUREMENTS:
        return distinct, 0.0, 0
    features = np.empty((floats.shape[1], N_FEATURES))
    frame_features(floats, ints, distinct, quality, has_quality, settings[SET_TOLERANCE],
                   features)
    return distinct, azimuth_spread(floats[ROW_AZIMUTH]), solve_regressed(
        floats, ints, features, params, hidden, settings, out, cov, inliers)


class Learned(Localizer):
    """The pose regressed by a set network, optionally refined (module docstring).

    Args:
        weights: Path of a weight file (``azgym train localizer --model learned`` writes one);
            None for the weights shipped with azgym.
        refine_rounds: Gated refinement rounds after the regression (0: the pure regression).
        gate: The last round's residual gate [rad]; earlier rounds' grow by ``GATE_GROWTH``.
            None: the features' consensus tolerance, 1° at the training noise and scaled with
            ``delta_alpha_d`` like it (:func:`azgym.localize.learned.features.consensus_tolerance`).
        min_trust: Least trust logit of a measurement the first refinement round starts from.
        delta_alpha_d: Δα_d, half-width of the centre-detection error [rad] (eq. 1), for the
            refinement's covariance.
        coverage: Whether the covariance includes the coverage term Δα_c,i (eq. 2).
        field_of_view: The camera's full horizontal view [rad]; None: not stated. A view
            narrower than the training frames' azimuth spread is refused.
        max_iter: Iteration limit of each refinement round.
    """

    name = "learned"

    def __init__(self, *, weights: str | None = None, refine_rounds: int = 3,
                 gate: float | None = None, min_trust: float = -2.0,
                 delta_alpha_d: float = math.radians(0.4), coverage: bool = True,
                 field_of_view: float | None = None, max_iter: int = 50) -> None:
        self.weights = weights
        self.refine_rounds = refine_rounds
        self.gate = gate
        self.min_trust = min_trust
        self.delta_alpha_d = delta_alpha_d
        self.coverage = coverage
        self.field_of_view = field_of_view
        self.max_iter = max_iter
        self._validate_once()

    def _check_params(self) -> None:
        name = type(self).__name__
        check_range(name, "refine_rounds", self.refine_rounds, low=0, high=10, integer=True)
        if self.gate is not None:
            check_range(name, "gate", self.gate, low=0.0, high=math.pi, low_open=True)
        check_range(name, "min_trust", self.min_trust, low=-50.0, high=50.0)
        check_range(name, "delta_alpha_d", self.delta_alpha_d, low=0.0, high=math.pi / 2,
                    high_open=True)
        check_range(name, "max_iter", self.max_iter, low=1, integer=True)
        check_flag(name, "coverage", self.coverage)
        if self.field_of_view is not None:
            check_range(name, "field_of_view", self.field_of_view, low=0.0, high=2 * math.pi,
                        low_open=True)
        self._load_model()
        self._tolerance = consensus_tolerance(self.delta_alpha_d,
                                              self._distribution.trained_delta_alpha_d)
        gate = self._tolerance if self.gate is None else self.gate
        self._settings = settings_array(self.refine_rounds, gate, self.min_trust,
                                        self.delta_alpha_d, bool(self.coverage), self.max_iter,
                                        self._tolerance)
        self._off_distribution = self._distribution.settings_reason(self.delta_alpha_d,
                                                                    self.field_of_view)

    def _load_model(self) -> None:
        """Load the weights (once per path)."""
        path = model_path(type(self).__name__, self.weights, SHIPPED_WEIGHTS)
        if getattr(self, "_loaded_from", None) == path:
            return
        arrays, manifest = load_weights(path, MODEL_NAME, feature_layout=FEATURE_LAYOUT)
        self._regressor = PoseRegressor(arrays, manifest)
        self._distribution = TrainingDistribution.of_manifest(manifest)
        self._loaded_from = path

    def _localize_frame(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        if self._off_distribution:
            return self._distribution.refusal(self._off_distribution, len(measurements))
        column, has_quality = first_quality_column(measurements.quality, len(measurements))
        out, cov = np.empty(OUT_SIZE), np.empty((3, 3))
        inliers = np.zeros(len(measurements), dtype=np.bool_)
        distinct, spread, rounds = _learned_frame(
            measurements.ids, measurements.azimuth, column, has_quality,
            *beacons.lookup_tables(), self._regressor.params, self._regressor.hidden,
            self._settings, out, cov, inliers)
        if distinct < MIN_MEASUREMENTS:
            return super()._localize_frame(measurements, beacons)  # the standard refusal
        reason = self._distribution.frame_reason(distinct, spread)
        if reason:
            return self._distribution.refusal(reason, len(measurements))
        return _answer(rounds, out, cov, inliers)

    def _localize(self, problem: Problem) -> Estimate:
        """A :class:`Problem` without the frame's quality (the features then do without)."""
        out, cov = np.empty(OUT_SIZE), np.empty((3, 3))
        inliers = np.zeros(problem.n_measurements, dtype=np.bool_)
        rounds = solve_regressed(problem.floats, problem.ints,
                                 measurement_features(problem, None, self._tolerance),
                                 self._regressor.params,
                                 self._regressor.hidden, self._settings, out, cov, inliers)
        return _answer(rounds, out, cov, inliers)


def settings_array(refine_rounds: int = 3, gate: float = math.radians(1.0),
                   min_trust: float = -2.0, delta_alpha_d: float = math.radians(0.4),
                   coverage: bool = True, max_iter: int = 50,
                   tolerance: float = CONSENSUS_TOLERANCE) -> FloatArray:
    """The compiled frame's settings (``SET_*`` slots), the localizer's defaults unless told."""
    settings = np.empty(SET_SIZE)
    settings[SET_ROUNDS], settings[SET_GATE], settings[SET_MIN_TRUST] = \
        refine_rounds, gate, min_trust
    settings[SET_DELTA_D], settings[SET_COVERAGE], settings[SET_MAX_ITER] = \
        delta_alpha_d, float(coverage), max_iter
    settings[SET_TOLERANCE] = tolerance
    return settings


def _answer(rounds: int, out: FloatArray, cov: FloatArray, inliers: np.ndarray) -> Estimate:
    """The estimate: the final pose, its covariance, what the regression said."""
    diagnostics = {"refinement_rounds": int(rounds),
                   "n_iterations": int(out[OUT_ITERATIONS]),
                   "regressed_x": float(out[OUT_REGRESSED_X]),
                   "regressed_y": float(out[OUT_REGRESSED_Y]),
                   "regressed_std_m": float(out[OUT_REGRESSED_STD])}
    x, y = float(out[K.POSE_X]), float(out[K.POSE_Y])
    heading = math.atan2(out[K.POSE_SIN], out[K.POSE_COS])
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(heading)):
        return Estimate.failure("the network's output is not finite", inliers.size, diagnostics)
    return Estimate(x=x, y=y, heading=heading, inliers=inliers, covariance=cov.copy(),
                    diagnostics=diagnostics)

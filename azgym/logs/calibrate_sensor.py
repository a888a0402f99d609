"""The azimuth fits of ``azgym calibrate``: eq. 1-3's noise and the field of view.

This module holds their rules and arithmetic, and the block bootstrap every bootstrap
interval of the calibration (:mod:`azgym.logs.calibrate`) comes from:

* **Azimuth noise** (eq. 1-3). A detection's residual is its azimuth minus the one predicted from
  the true pose and the map; ids not in the map are left out. Gross outliers (misread ids,
  ghosts) are trimmed by eq. 25's rule: a residual beyond RANSAC's inlier tolerance
  2 (Δα_d + Δα_c,i) is no inlier, Δα_d refitted on the inliers until they stop changing (Δα_d
  starts at twice the median |residual|). On the inliers, the two uniforms of eq. 3 give
  E[r²] = v_i = (Δα_d² + Δα_c,i²) / 3 with the coverage term (Δα_d² / 3 without), and Δα_d solves
  the quasi-likelihood equation Σ (r_i² − v_i) / v_i² = 0: unbiased whatever the noise's shape
  (uniform, or a real camera's bell), and weighing each detection by how sharp its bound is, so
  that a near beacon's wide coverage bound (and an outlier it hides) counts little. ``coverage``
  is the variance model with the larger Gaussian quasi-likelihood on the inliers of the wider
  rule (a tie, as when beacon widths are zero, is false). Δα_d's interval: a BCa bootstrap (one
  Newton step of the equation per resample) over 5 s blocks of frames
  (:func:`azgym.metrics.bootstrap_blocks`), so that correlated frames move together.
* **Field of view**: twice the largest |azimuth| among the half of the inliers with the tighter
  bound Δα_d + Δα_c,i (there eq. 25 trims best: an outlier cannot widen the view); all round
  (2π) when that reaches :data:`ALL_ROUND`. Its interval runs from
  twice the largest (|azimuth| − its bound), where the noise may have carried an inlier from, to
  twice (largest + ε), ε = ln 20 / (inliers per radian in the outer tenth of the view): the
  edge a further inlier would push it to with probability 5 %.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from azgym.core import FloatArray, wrap_angle
from azgym.logs.read import Log
from azgym.site.error_model import ErrorModel

__all__ = ["ALL_ROUND", "MIN_DETECTIONS", "RESAMPLES", "AzimuthFit", "block_interval",
           "fit_azimuth"]

ALL_ROUND = math.radians(150.0)
"""Inliers this far off the camera's axis [rad] make the view all round (2π): a camera that sees
past ±150° is an omnidirectional one whose blind spots are the map's, not its own."""
MIN_DETECTIONS = 10
"""The fewest detections of map beacons the azimuth fits are made from."""
RESAMPLES = 1999
"""Bootstrap resamples per interval."""
TRIM_ROUNDS = 50
"""At most this many rounds of trimming and refitting."""
EDGE_SHARE = 0.1
"""The outer share of the view whose inliers set how far the edge may lie beyond the largest."""


@dataclass(frozen=True, eq=False)
class AzimuthFit:
    """What the detections say about the camera.

    Attributes:
        delta_alpha_d: Δα_d [rad].
        delta_interval: Its 95 % interval, or None when the frames make fewer than two
            bootstrap blocks (:func:`block_interval`).
        coverage: Whether eq. 2's coverage term applies.
        coverage_gain: Log quasi-likelihood of coverage true minus false, on the same inliers.
        field_of_view: The full view [rad] and its 95 % interval.
        inliers: Detections kept.
        note: The detections left out, in words.
        residuals: Each mapped detection's distance [m], residual [rad] and whether kept.
    """

    delta_alpha_d: float
    delta_interval: tuple[float, float] | None
    coverage: bool
    coverage_gain: float
    field_of_view: tuple[float, float, float]
    inliers: int
    note: str
    residuals: tuple[FloatArray, FloatArray, np.ndarray]


def fit_azimuth(log: Log, frame_blocks: np.ndarray, rng: np.random.Generator
                ) -> AzimuthFit | None:
    """Fit Δα_d, coverage and the field of view to a log whose truth has headings.

    None when fewer than :data:`MIN_DETECTIONS` detections are of beacons in the map.

    Args:
        log: The log.
        frame_blocks: Each frame's bootstrap block.
        rng: The bootstrap's generator.
    """
    detections, frames = log.detections, log.frames
    row = detections["frame"]
    index = log.beacons.index_of(detections["id"])
    mapped = index >= 0
    if mapped.sum() < MIN_DETECTIONS:
        return None
    row, index, azimuth = row[mapped], index[mapped], detections["azimuth"][mapped]
    dx = log.beacons.xyz[index, 0] - frames["x"][row]
    dy = log.beacons.xyz[index, 1] - frames["y"][row]
    residual = wrap_angle(azimuth - (np.arctan2(dy, dx) - frames["heading"][row]))
    distance = np.hypot(dx, dy)
    width = log.beacons.width[index]
    bound = ErrorModel(0.0, True).coverage_bound(distance, width)
    wide, _ = _trimmed(residual, distance, width, True)
    gain = _gaussian_loglik(residual[wide], bound[wide], True) \
        - _gaussian_loglik(residual[wide], bound[wide], False)
    coverage = bool(gain > 0.0)
    kept, delta = _trimmed(residual, distance, width, coverage)
    cover = bound[kept] if coverage else np.zeros(int(kept.sum()))
    blocks = np.unique(frame_blocks[row[kept]], return_inverse=True)[1]
    score, slope = _score(residual[kept], cover, delta**2)
    block_score = np.bincount(blocks, weights=score)
    block_slope = np.bincount(blocks, weights=slope)

    def statistic(pick: np.ndarray) -> np.ndarray:  # one Newton step from the fit
        return np.sqrt(np.maximum(
            delta**2 - block_score[pick].sum(-1) / block_slope[pick].sum(-1), 0.0))

    interval = block_interval(statistic, block_score.size, delta, rng)
    note = (f"detections: {int(detections['id'].size)}; ids not in the map: "
            f"{int((~mapped).sum())}; trimmed as gross outliers (eq. 25): "
            f"{int((~kept).sum())}; inliers: {int(kept.sum())}")
    reach = delta + cover
    tight = reach <= np.median(reach)
    return AzimuthFit(delta, interval, coverage, float(gain),
                      _field_of_view(azimuth[kept][tight], reach[tight]), int(kept.sum()), note,
                      (distance, residual, kept))


def _score(residual: FloatArray, cover: FloatArray, square: float
           ) -> tuple[FloatArray, FloatArray]:
    """Each detection's quasi-likelihood score for θ = Δα_d², and the score's slope, at ``square``.

    With v = (θ + Δα_c²) / 3 the variance of eq. 3, the score (r² − v) / v² has mean zero at the
    true θ whatever the noise's shape, and weighs a detection by how sharp its bound is.
    """
    variance = np.maximum((square + cover**2) / 3.0, 1e-30)
    return (residual**2 - variance) / variance**2, -(2 * residual**2 - variance) / (3 * variance**3)


def _delta(residual: FloatArray, cover: FloatArray) -> float:
    """Δα_d solving the summed score for zero.

    0 when the coverage term alone already accounts for the residuals' spread.
    """
    if residual.size == 0 or _score(residual, cover, 0.0)[0].sum() <= 0.0:
        return 0.0
    high = 3.0 * float(np.max(residual**2)) + 1e-30
    from scipy.optimize import brentq  # imported here: a calibration's cost, not every command's

    root = brentq(lambda square: _score(residual, cover, square)[0].sum(), 0.0,
                 high, xtol=1e-30, rtol=1e-12)
    return min(math.sqrt(root), math.pi / 2 - 1e-9)


def _trimmed(residual: FloatArray, distance: FloatArray, width: FloatArray, coverage: bool
             ) -> tuple[np.ndarray, float]:
    """The inliers of eq. 25's rule and Δα_d fitted on them (module docstring)."""
    delta = min(2.0 * float(np.median(np.abs(residual))), math.pi / 2 - 1e-9) \
        if residual.size else 0.0
    kept = np.zeros(residual.size, dtype=bool)
    for _ in range(TRIM_ROUNDS):
        model = ErrorModel(delta, coverage)
        now = np.abs(residual) <= model.tolerance(distance, width)
        if np.array_equal(now, kept):
            break
        kept = now
        delta = _delta(residual[kept], model.coverage_bound(distance, width)[kept])
    return kept, delta


def _gaussian_loglik(residual: FloatArray, bound: FloatArray, coverage: bool) -> float:
    """Gaussian log quasi-likelihood of the residuals under one coverage choice, Δα_d fitted."""
    cover = bound if coverage else np.zeros_like(bound)
    delta = _delta(residual, cover)
    variance = np.maximum((delta**2 + cover**2) / 3.0, 1e-30)
    return float(-0.5 * np.sum(np.log(variance) + residual**2 / variance))


def _field_of_view(azimuth: FloatArray, reach: FloatArray) -> tuple[float, float, float]:
    """The full view and its interval (module docstring of :mod:`azgym.logs.calibrate`).

    Args:
        azimuth: The inliers' azimuths [rad].
        reach: How far each one's noise may reach (Δα_d + Δα_c,i) [rad].
    """
    if azimuth.size == 0:
        return math.nan, math.nan, math.nan
    edge = float(np.abs(azimuth).max())
    if edge >= ALL_ROUND:
        return 2 * math.pi, 2 * math.pi, 2 * math.pi
    outer = max(int(np.sum(np.abs(azimuth) >= (1.0 - EDGE_SHARE) * edge)), 1)
    beyond = math.log(20.0) * EDGE_SHARE * edge / outer
    low = max(float(np.max(np.abs(azimuth) - reach)), 0.0)
    return 2 * edge, 2 * low, min(2 * (edge + beyond), 2 * math.pi)


def block_interval(statistic: Callable[[np.ndarray], np.ndarray], blocks: int, value: float,
                   rng: np.random.Generator) -> tuple[float, float] | None:
    """A 95 % BCa bootstrap interval resampling whole blocks.

    Args:
        statistic: The estimate from picked block numbers, an int array (..., B) → (...).
        blocks: How many blocks there are.
        value: The estimate on the data, returned as both ends when the data are exact (no
            spread among the resamples).
        rng: The generator.

    Returns:
        The interval, or None with fewer than two blocks: one block cannot be resampled, and
        its spread is unknown, not zero.
    """
    if blocks < 2:
        return None
    from scipy.stats import bootstrap  # imported here: a calibration's cost, not every command's

    with warnings.catch_warnings():  # a degenerate (exact) distribution is handled below
        warnings.simplefilter("ignore")
        low, high = bootstrap(
            (np.arange(blocks),), lambda pick, axis=-1: statistic(pick),
            n_resamples=RESAMPLES, vectorized=True, method="BCa", random_state=rng,
        ).confidence_interval
    if not (math.isfinite(low) and math.isfinite(high)):
        return value, value
    return float(low), float(high)

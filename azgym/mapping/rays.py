"""Bearing rays: where a beacon is from the rays that point at it, and whether they can say.

A detection of beacon b from camera pose (x, y, φ) with azimuth α is a ray from (x, y) in the
world direction β = φ + α. With unit normals n_k to the rays, the least-squares point minimizes
Σ w_k (n_kᵀ (b − p_k))²: (Σ w_k n_k n_kᵀ) b = Σ w_k n_k n_kᵀ p_k.

**Observability** (docs/mapping.md). Each ray fixes the beacon across itself only: with an
azimuth error σ at distance d, to σ d. N rays give the information Σ n_k n_kᵀ / (σ d)² =
N / (σ d)² · M, M the mean of n_k n_kᵀ, whose eigenvalues are (1 ± R)/2 with R = |mean e^{2iβ_k}|.
The smaller, λ = (1 − R)/2, lies along the rays' mean direction, so the variance there is
(σ d)² / (N λ): for two rays an angle Δ apart λ = sin²(Δ/2), and the position along the rays
grows as 1/sin² of half their spread. The **spread** of a beacon's rays is Δ = 2 asin √λ (for
two rays, the angle between them); a beacon is observable when Δ ≥ :data:`MIN_SPREAD` and it
was seen by at least :data:`MIN_RAYS` rays. Below that it is reported, never guessed.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray

__all__ = ["INIT_ITERATIONS", "INIT_SCALE", "MIN_RAYS", "MIN_SPREAD", "intersect", "spread"]

MIN_SPREAD = math.radians(10.0)
"""Least spread of a beacon's rays [rad] for it to be observable (module docstring): at 10°
the position along the rays is sin(5°)⁻¹ ≈ 11.5 times less certain than across them, one ray's
σ d = 4 mm at 1 m becoming ~5 cm at 10 m from 10 rays (docs/mapping.md)."""
MIN_RAYS = 3
"""Fewest rays (detections) of an observable beacon: a misread id seen once or twice is none."""
INIT_SCALE = 0.3
"""Cauchy scale of the first guess's reweighting [m]: a ray that misses the point by more (a
mirror image, a misread id) weighs little; dead reckoning's drift over a beacon's sightings
stays below it."""
INIT_ITERATIONS = 8
"""Reweighting passes of the first guess."""


def spread(directions: FloatArray, weights: FloatArray | None = None) -> float:
    """The spread Δ of rays with world directions ``directions`` [rad] (module docstring)."""
    if directions.size == 0:
        return 0.0
    w = np.ones_like(directions) if weights is None else weights
    total = float(w.sum())
    if total <= 0.0:
        return 0.0
    resultant = abs(complex(np.sum(w * np.exp(2j * directions)))) / total
    return 2.0 * math.asin(math.sqrt(max(0.0, (1.0 - min(resultant, 1.0)) / 2.0)))


def intersect(origins: FloatArray, directions: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The point the rays meet at (least squares, reweighted against stray rays).

    Args:
        origins: (N, 2) ray origins [m].
        directions: (N,) world directions [rad].

    Returns:
        The point (2,) and each ray's final weight (N,) in [0, 1] (0: it points away).
    """
    normals = np.column_stack([-np.sin(directions), np.cos(directions)])
    along = np.column_stack([np.cos(directions), np.sin(directions)])
    weights = np.ones(len(directions))
    point = np.full(2, np.nan)
    for _ in range(INIT_ITERATIONS):
        outer = normals[:, :, None] * normals[:, None, :] * weights[:, None, None]
        system = outer.sum(axis=0)
        if np.linalg.cond(system) > 1e12:
            return np.full(2, np.nan), weights
        point = np.linalg.solve(system, np.einsum("kij,kj->i", outer, origins))
        offsets = point - origins
        miss = np.einsum("ki,ki->k", normals, offsets)
        ahead = np.einsum("ki,ki->k", along, offsets) > 0.0
        weights = ahead / (1.0 + (miss / INIT_SCALE) ** 2)
    return point, weights

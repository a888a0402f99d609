"""Bearing rays: where rays from known places meet, and whether they span enough angle to say.

Pure geometry on the floor plane, the one implementation for whatever locates a beacon from the
directions in which it was seen (a tracker repairing its map, the survey's first guesses). A
ray starts at a camera position c_k and points along the world bearing θ_k (the camera's heading
plus the measured azimuth).

**The intersection** is the weighted least-squares point p of the rays as lines
(:func:`meeting_point`): with n_k = (−sin θ_k, cos θ_k) the ray's normal, each ray says
n_kᵀ p = n_kᵀ c_k, and the residual n_kᵀ (p − c_k) is the point's distance off the ray. Two
weightings use it. :func:`intersect_rays` weighs each ray by the inverse variance of that
distance, r_k² σ_θ,k² (the bearing's error at range r_k) plus n_kᵀ Σ_k n_k (the camera
position's), the ranges taken from a first, unweighted solution; the second's inverse normal
matrix is the point's covariance. :func:`intersect_robustly` knows no variances but expects
stray rays (a mirror image, a misread id): it reweighs each ray by a Cauchy weight of its miss
(:data:`STRAY_SCALE`), zero for a ray pointing away from the point, :data:`ROBUST_PASSES` times.

**Observability**: rays that are nearly parallel meet anywhere along their common direction.
N rays give the information Σ n_k n_kᵀ / (σ d)² = N / (σ d)² · M, M the mean of n_k n_kᵀ, whose
eigenvalues are (1 ± R)/2 with R = |mean e^{2iθ_k}|. The smaller, λ = (1 − R)/2, lies along the
rays' mean direction, so the variance there is (σ d)² / (N λ): for two rays an angle Δ apart
λ = sin²(Δ/2), and the position along the rays grows as 1/sin² of half their spread. The
**spread** of rays (:func:`spread`) is Δ = 2 asin √λ (for two rays, the angle between them); a
point is observable when its rays spread at least :data:`MIN_SPREAD` and number at least
:data:`MIN_RAYS`. Unlike the arc the directions cover, the spread is not widened by one stray
ray among many parallel ones: it is the one rule of "enough angle", the survey's and the map
repair's (whose least spread is robust's ``repair_span``).
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError

__all__ = ["MIN_RAYS", "MIN_SPREAD", "PARALLEL_CONDITION", "ROBUST_PASSES", "STRAY_SCALE",
           "agreeing", "crossings", "intersect_rays", "intersect_robustly", "meet",
           "meeting_point", "pair_spread", "ray_misses", "spread"]

MIN_SPREAD = math.radians(10.0)
"""Least spread of a point's rays [rad] for it to be observable (module docstring): at 10° the
position along the rays is sin(5°)⁻¹ ≈ 11.5 times less certain than across them, one ray's
σ d = 4 mm at 1 m becoming ~5 cm at 10 m from 10 rays (docs/mapping.md)."""
MIN_RAYS = 3
"""Fewest rays of an observable point: a misread id seen once or twice is none."""
STRAY_SCALE = 0.3
"""Cauchy scale of :func:`intersect_robustly`'s reweighting [m]: a ray that misses the point by
more (a mirror image, a misread id) weighs little; dead reckoning's drift over a beacon's
sightings stays below it."""
ROBUST_PASSES = 8
"""Reweighting passes of :func:`intersect_robustly`."""
PARALLEL_CONDITION = 1e12
"""Condition number of the normal matrix above which the rays count as parallel."""


def spread(bearings: FloatArray) -> float:
    """The spread Δ [rad] of rays with world directions ``bearings`` [rad] (module docstring).

    Example:
        >>> round(math.degrees(spread(np.radians([0.0, 30.0]))), 6)
        30.0
    """
    if bearings.size == 0:
        return 0.0
    resultant = abs(complex(np.mean(np.exp(2j * bearings))))
    return 2.0 * math.asin(math.sqrt(max(0.0, (1.0 - min(resultant, 1.0)) / 2.0)))


def pair_spread(first: FloatArray, second: FloatArray) -> FloatArray:
    """The :func:`spread` of each pair of rays, directions ``first[i]`` and ``second[i]`` [rad].

    For two rays the spread is the acute angle between their lines, in [0, π/2].

    Example:
        >>> np.degrees(pair_spread(np.radians([0.0, 10.0]), np.radians([30.0, 170.0]))).round(6)
        array([30., 20.])
    """
    return np.arccos(np.minimum(1.0, np.abs(np.cos(second - first))))


def crossings(first_origins: FloatArray, first: FloatArray, second_origins: FloatArray,
              second: FloatArray) -> FloatArray:
    """Where each pair of rays, as lines, crosses (n, 2) [m]: inf or NaN for parallel ones.

    Ray i of each pair starts at ``first_origins[i]`` (n, 2) along ``first[i]`` [rad], its
    partner at ``second_origins[i]`` along ``second[i]``: c1 + t d1 meets c2 + u d2 at
    t = ((c2 − c1) × d2) / sin(θ2 − θ1).
    """
    gap = second_origins - first_origins
    along = (gap[:, 0] * np.sin(second) - gap[:, 1] * np.cos(second)) / np.sin(second - first)
    return first_origins + along[:, None] * np.column_stack((np.cos(first), np.sin(first)))


def intersect_rays(origins: FloatArray, bearings: FloatArray, bearing_variance: FloatArray,
                   origin_covariance: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The weighted least-squares meeting point of rays, its covariance and each ray's miss.

    Args:
        origins: Where each ray starts (K, 2) [m].
        bearings: Each ray's direction in the world (K,) [rad].
        bearing_variance: Each direction's variance (K,) [rad²].
        origin_covariance: Each start's position covariance (K, 2, 2) [m²].

    Returns:
        The point (2,), its covariance (2, 2), and each ray's signed distance from it over its
        standard deviation (K,): squared, chi-square with one degree of freedom when the rays
        are right.

    Raises:
        InvalidInputError: Fewer than two rays, arrays of mismatched shapes, or rays all
            parallel (no single point).
    """
    count = bearings.shape[0]
    if count < 2 or origins.shape != (count, 2) or bearing_variance.shape != (count,) \
            or origin_covariance.shape != (count, 2, 2):
        raise InvalidInputError(
            f"intersect_rays needs two or more rays with origins (K, 2), bearings (K,), "
            f"bearing_variance (K,) and origin_covariance (K, 2, 2); got {origins.shape}, "
            f"{bearings.shape}, {bearing_variance.shape}, {origin_covariance.shape}")
    found = meet(origins, bearings, bearing_variance, origin_covariance)
    if found is None:
        raise InvalidInputError(
            "intersect_rays: the rays are parallel, so they meet at no single point")
    return found


def meet(origins: FloatArray, bearings: FloatArray, bearing_variance: FloatArray,
         origin_covariance: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """:func:`intersect_rays` on arrays already checked: None where it raises for parallel rays.

    Rays that spread yet meet at no single point once weighed (a few rays far tighter than the
    rest, along one line) are a caller's "the rays do not say", not an error.
    """
    normals = _normals(bearings)
    origin_part = np.einsum("ki,kij,kj->k", normals, origin_covariance, normals)
    weights = np.ones(bearings.shape[0])
    point = np.zeros(2)
    for _ in range(2):  # unweighted, then weighted by each ray's spread at its range
        point = meeting_point(origins, bearings, weights)
        if not np.isfinite(point).all():
            return None
        ranges2 = np.sum(np.square(point - origins), axis=1)
        variance = ranges2 * bearing_variance + origin_part
        weights = 1.0 / variance
    covariance = np.asarray(np.linalg.inv((normals * weights[:, None]).T @ normals), np.float64)
    return point, covariance, ray_misses(point, origins, bearings, bearing_variance,
                                         origin_covariance)


def ray_misses(point: FloatArray, origins: FloatArray, bearings: FloatArray,
               bearing_variance: FloatArray, origin_covariance: FloatArray) -> FloatArray:
    """Each ray's signed distance from ``point`` over its standard deviation (K,).

    The arguments are :func:`intersect_rays`'s and a point (2,).
    """
    normals = _normals(bearings)
    variance = np.sum(np.square(point - origins), axis=1) * bearing_variance \
        + np.einsum("ki,kij,kj->k", normals, origin_covariance, normals)
    return np.einsum("kj,kj->k", normals, point - origins) / np.sqrt(variance)


def meeting_point(origins: FloatArray, bearings: FloatArray, weights: FloatArray) -> FloatArray:
    """The weighted least-squares point of rays as lines (module docstring).

    Args:
        origins: Where each ray starts (K, 2) [m].
        bearings: Each ray's direction in the world (K,) [rad].
        weights: Each ray's weight (K,).

    Returns:
        The point (2,); NaN when the weighted rays are parallel (the normal matrix's condition
        number above :data:`PARALLEL_CONDITION`), so that they meet at no single point.
    """
    normals = _normals(bearings)
    weighted = normals * weights[:, None]
    normal_matrix = weighted.T @ normals
    if np.linalg.cond(normal_matrix) > PARALLEL_CONDITION:
        return np.full(2, np.nan)
    return np.linalg.solve(normal_matrix, weighted.T @ np.einsum("kj,kj->k", normals, origins))


def intersect_robustly(origins: FloatArray,
                       bearings: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The point rays meet at, reweighted against stray rays (module docstring).

    Args:
        origins: Where each ray starts (K, 2) [m].
        bearings: Each ray's direction in the world (K,) [rad].

    Returns:
        The point (2,), NaN when the rays are parallel, and each ray's final weight (K,) in
        [0, 1] (0: it points away from the point).
    """
    weights = np.ones(len(bearings))
    along = np.column_stack((np.cos(bearings), np.sin(bearings)))
    normals = _normals(bearings)
    point = np.full(2, np.nan)
    for _ in range(ROBUST_PASSES):
        point = meeting_point(origins, bearings, weights)
        if not np.isfinite(point).all():
            return point, weights
        offsets = point - origins
        miss = np.einsum("ki,ki->k", normals, offsets)
        ahead = np.einsum("ki,ki->k", along, offsets) > 0.0
        weights = ahead / (1.0 + (miss / STRAY_SCALE) ** 2)
    return point, weights


def agreeing(origins: FloatArray, bearings: FloatArray, point: FloatArray) -> np.ndarray:
    """Which rays, from ``origins`` (K, 2) along world ``bearings`` (K,), agree with ``point``.

    Those pointing towards it and passing within :data:`STRAY_SCALE` of it: the rays
    :func:`intersect_robustly` weighs above half; none when the point is not finite.
    """
    if not np.isfinite(point).all():
        return np.zeros(len(bearings), dtype=bool)
    offsets = point - origins
    cos, sin = np.cos(bearings), np.sin(bearings)
    ahead = cos * offsets[:, 0] + sin * offsets[:, 1] > 0.0
    return np.asarray(ahead & (np.abs(cos * offsets[:, 1] - sin * offsets[:, 0]) < STRAY_SCALE))


def _normals(bearings: FloatArray) -> FloatArray:
    """Each ray's unit normal (K, 2): its direction turned a quarter left."""
    return np.column_stack((-np.sin(bearings), np.cos(bearings)))

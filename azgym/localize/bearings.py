"""Bearing rays: where rays from known places meet, and whether they span enough angle to say.

Pure geometry on the floor plane, shared by whatever locates a beacon from the directions in
which it was seen (a tracker repairing its map, a survey). A ray starts at a camera position
c_k and points along the world bearing θ_k (the camera's heading plus the measured azimuth).

**The intersection** (:func:`intersect_rays`) is the weighted least-squares point p of the rays
as lines: with n_k = (−sin θ_k, cos θ_k) the ray's normal, each ray says n_kᵀ p = n_kᵀ c_k, and
the residual n_kᵀ (p − c_k) is the point's distance off the ray. That distance has variance
r_k² σ_θ,k² (the bearing's error at range r_k) plus n_kᵀ Σ_k n_k (the camera position's), so
the ranges from a first, unweighted solution weigh a second one; the second's inverse normal
matrix is the point's covariance.

**Observability** (:func:`angular_span`): rays that are nearly parallel meet anywhere along
their common direction, and the least-squares covariance, linearized at that meeting point,
understates how far off it can be. So a point is only located from rays whose directions span
at least a minimum angle (the smallest arc of the circle holding them all), as well as by its
covariance.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError

__all__ = ["angular_span", "intersect_rays", "ray_misses"]


def angular_span(bearings: FloatArray) -> float:
    """The smallest arc of the circle holding every direction in ``bearings`` [rad], in [0, 2π).

    Example:
        >>> round(math.degrees(angular_span(np.radians([350.0, 10.0, 5.0]))), 6)
        20.0
    """
    if bearings.size < 2:
        return 0.0
    ordered = np.sort(np.mod(bearings, 2.0 * math.pi))
    gaps = np.diff(ordered, append=ordered[0] + 2.0 * math.pi)
    return float(2.0 * math.pi - gaps.max())


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
    normals = np.column_stack((-np.sin(bearings), np.cos(bearings)))
    offsets = np.einsum("kj,kj->k", normals, origins)
    origin_part = np.einsum("ki,kij,kj->k", normals, origin_covariance, normals)
    weights = np.ones(count)
    point = np.zeros(2)
    for _ in range(2):  # unweighted, then weighted by each ray's spread at its range
        normal_matrix = (normals * weights[:, None]).T @ normals
        if np.linalg.cond(normal_matrix) > 1e12:
            raise InvalidInputError(
                "intersect_rays: the rays are parallel, so they meet at no single point")
        point = np.linalg.solve(normal_matrix, (normals * weights[:, None]).T @ offsets)
        ranges2 = np.sum(np.square(point - origins), axis=1)
        variance = ranges2 * bearing_variance + origin_part
        weights = 1.0 / variance
    covariance = np.linalg.inv((normals * weights[:, None]).T @ normals)
    return point, covariance, ray_misses(point, origins, bearings, bearing_variance,
                                         origin_covariance)


def ray_misses(point: FloatArray, origins: FloatArray, bearings: FloatArray,
               bearing_variance: FloatArray, origin_covariance: FloatArray) -> FloatArray:
    """Each ray's signed distance from ``point`` over its standard deviation (K,).

    The arguments are :func:`intersect_rays`'s and a point (2,).
    """
    normals = np.column_stack((-np.sin(bearings), np.cos(bearings)))
    variance = np.sum(np.square(point - origins), axis=1) * bearing_variance \
        + np.einsum("ki,kij,kj->k", normals, origin_covariance, normals)
    return np.einsum("kj,kj->k", normals, point - origins) / np.sqrt(variance)

"""The pose's information from each beacon, and the predicted standard deviation of a fix.

A beacon B at horizontal offset (Δx, Δy) = (x_B − x, y_B − y), distance D, from a camera at
(x, y) with heading φ is seen at the azimuth α = atan2(Δy, Δx) − φ (eq. 21-22). Its gradient
with respect to the pose (x, y, φ) is

    g = (Δy / D², −Δx / D², −1),

and its error has the variance σ² = (Δα_d² + Δα_c²) / 3 of eq. 3 (two independent uniform errors,
eq. 1 and 2; :meth:`azgym.site.error_model.ErrorModel.variance`). A least-squares fix weighted
by 1/σ² has, to first order, the covariance (JᵀWJ)⁻¹ = (Σ_B g gᵀ / σ²)⁻¹: the information
matrix of a layout is the **sum** of its visible beacons' contributions g gᵀ / σ², which is what
lets the optimizer try a beacon by one addition. Neither g nor σ² depends on the heading, so
neither does the prediction.

The predicted position standard deviation is σ_pos = sqrt(C_xx + C_yy), the root of the mean
squared distance of the fix from the truth. The heading is a nuisance here: the xy block of
the inverse is the inverse of the Schur complement S = A − b bᵀ / c of the information matrix
[[A, b], [bᵀ, c]] (c the heading's entry), so σ_pos² = trace(S⁻¹) = (S_xx + S_yy) / det S.
Fewer than three beacons leave the pose undetermined (three unknowns): σ_pos is infinite there,
as it is where the geometry is singular.

**A surveyed map's own error.** A beacon mapped at b + δb instead of b shifts every azimuth of it
by δα = ∂α/∂b · δb = u⊥ · δb / D, u⊥ = (−Δy, Δx) / D the unit vector across the line of sight
(a shift along the line of sight changes nothing): with δb ~ N(0, Σ_b), δα has the variance
m² = u⊥ᵀ Σ_b u⊥ / D². But δb is the same in every frame, so δα is a bias of the fix, not noise
that averages out: the fix p̂ = p + K (ε + δα_map), K = C Jᵀ W the gain of the least-squares fix
weighted by the noise alone, is off by K δα_map at every frame at that cell. Over surveys drawn
from the covariances (one beacon's error independent of another's: survey.csv gives marginal
covariances only), that offset has the covariance K diag(m²) Kᵀ = C M C with
M = Σ_B g gᵀ m² / σ⁴, so its root mean square, the map's **bias floor**, is
σ_map = sqrt(trace of the xy block of C M C). Frame noise and map error are independent, so a
fix's error over frames and surveys has σ_total² = σ_pos² + σ_map². Adding m² to the azimuths'
variances instead (and weighting by the sum) would predict a spread that averages out over
frames and place the weights as if it did; the map's error does neither.
"""

from __future__ import annotations

import numpy as np

from azgym.core import BoolArray, FloatArray, IntArray
from azgym.site.error_model import ErrorModel

__all__ = ["MIN_BEACONS", "SINGULAR", "contributions", "map_contributions", "map_sigma",
           "map_variance", "position_sigma"]

XX, XY, XH, YY, YH, HH = range(6)
"""Slots of a packed symmetric 3×3 information matrix over (x, y, heading)."""
ENTRIES = 6
"""Length of a packed information matrix."""
MIN_BEACONS = 3
"""Beacons a fix needs: three azimuths for three unknowns (x, y, heading)."""
SINGULAR = 1e-12
"""det S below this share of (trace S)² / 4 counts as singular: the beacons' directions do not
pin the position down (e.g. the camera on the circle through three beacons)."""


def contributions(points: FloatArray, beacon_xy: FloatArray, beacon_width: FloatArray,
                  error_model: ErrorModel, seen: BoolArray) -> FloatArray:
    """Each beacon's information g gᵀ / σ² at each point, packed, shape (P, B, ENTRIES).

    A beacon not seen from a point (``seen`` False) contributes nothing there.

    Args:
        points: Camera positions (x, y), shape (P, 2) [m].
        beacon_xy: Beacon positions (x, y), shape (B, 2) [m].
        beacon_width: Beacon widths W, shape (B,) [m] (eq. 2's coverage error).
        error_model: The azimuth error model (eq. 1-3).
        seen: Which beacon each point sees, shape (P, B).
    """
    variance = _variance(points, beacon_xy, beacon_width, error_model)
    with np.errstate(divide="ignore"):
        return _packed(points, beacon_xy, np.where(seen, 1.0 / variance, 0.0))


def map_variance(points: FloatArray, beacon_xy: FloatArray, covariance: FloatArray) -> FloatArray:
    """Each azimuth's variance m² = u⊥ᵀ Σ_b u⊥ / D² from its beacon's map error, shape (P, B).

    Args:
        points: Camera positions (x, y), shape (P, 2) [m].
        beacon_xy: Beacon positions (x, y), shape (B, 2) [m].
        covariance: Each beacon position's covariance Σ_b, shape (B, 2, 2) [m²].
    """
    dx = beacon_xy[None, :, 0] - points[:, None, 0]
    dy = beacon_xy[None, :, 1] - points[:, None, 1]
    squared = dx * dx + dy * dy
    across = (dy * dy * covariance[None, :, 0, 0] - 2 * dx * dy * covariance[None, :, 0, 1]
              + dx * dx * covariance[None, :, 1, 1])  # u⊥ᵀ Σ_b u⊥ · D²
    with np.errstate(divide="ignore", invalid="ignore"):
        return across / (squared * squared)


def map_contributions(points: FloatArray, beacon_xy: FloatArray, beacon_width: FloatArray,
                      covariance: FloatArray, error_model: ErrorModel,
                      seen: BoolArray) -> FloatArray:
    """Each beacon's share g gᵀ m² / σ⁴ of M (module docstring), packed, shape (P, B, ENTRIES).

    Args:
        points: Camera positions (x, y), shape (P, 2) [m].
        beacon_xy: Beacon positions (x, y), shape (B, 2) [m].
        beacon_width: Beacon widths W, shape (B,) [m].
        covariance: Each beacon position's covariance Σ_b, shape (B, 2, 2) [m²].
        error_model: The azimuth error model (eq. 1-3).
        seen: Which beacon each point sees, shape (P, B).
    """
    variance = _variance(points, beacon_xy, beacon_width, error_model)
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = np.where(seen, map_variance(points, beacon_xy, covariance) / variance ** 2, 0.0)
    return _packed(points, beacon_xy, weight)


def _variance(points: FloatArray, beacon_xy: FloatArray, beacon_width: FloatArray,
              error_model: ErrorModel) -> FloatArray:
    """Eq. 3's azimuth variance σ² of each beacon from each point, shape (P, B)."""
    dx = beacon_xy[None, :, 0] - points[:, None, 0]
    dy = beacon_xy[None, :, 1] - points[:, None, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(error_model.variance(np.sqrt(dx * dx + dy * dy), beacon_width))


def _packed(points: FloatArray, beacon_xy: FloatArray, weight: FloatArray) -> FloatArray:
    """The g gᵀ · weight of each beacon from each point, packed, shape (P, B, ENTRIES).

    ``weight`` is 0 where a beacon is not seen, and its gradient is taken as 0 there too.
    """
    dx = beacon_xy[None, :, 0] - points[:, None, 0]
    dy = beacon_xy[None, :, 1] - points[:, None, 1]
    squared = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        gx = np.where(weight != 0, dy / squared, 0.0)
        gy = np.where(weight != 0, -dx / squared, 0.0)
    packed = np.empty((*squared.shape, ENTRIES))
    packed[..., XX] = gx * gx * weight
    packed[..., XY] = gx * gy * weight
    packed[..., XH] = -gx * weight
    packed[..., YY] = gy * gy * weight
    packed[..., YH] = -gy * weight
    packed[..., HH] = weight
    return packed


def position_sigma(information: FloatArray, beacon_count: IntArray) -> FloatArray:
    """σ_pos = sqrt(C_xx + C_yy) of packed information matrices (module docstring) [m].

    Args:
        information: Packed information matrices, shape (..., ENTRIES).
        beacon_count: How many beacons each sums over, shape (...); under three gives inf.
    """
    c = information[..., HH]
    with np.errstate(divide="ignore", invalid="ignore"):
        sxx = information[..., XX] - information[..., XH] ** 2 / c
        syy = information[..., YY] - information[..., YH] ** 2 / c
        sxy = information[..., XY] - information[..., XH] * information[..., YH] / c
        det = sxx * syy - sxy * sxy
        trace = sxx + syy
        sigma = np.sqrt(trace / det)
    undetermined = (beacon_count < MIN_BEACONS) | ~(det > SINGULAR * 0.25 * trace * trace)
    return np.where(undetermined, np.inf, sigma)


def map_sigma(information: FloatArray, map_information: FloatArray,
              beacon_count: IntArray) -> FloatArray:
    """The map's bias floor σ_map = sqrt(trace_xy(C M C)), C the inverse of I (module docstring).

    Args:
        information: Packed information matrices I, shape (..., ENTRIES).
        map_information: Packed M of the same cells, shape (..., ENTRIES).
        beacon_count: How many beacons each sums over, shape (...); inf where
            :func:`position_sigma` is.
    """
    undetermined = ~np.isfinite(position_sigma(information, beacon_count))
    safe = np.where(undetermined[..., None], _IDENTITY, information)
    covariance = np.linalg.inv(_unpacked(safe))
    spread = covariance @ _unpacked(map_information) @ covariance
    floor = np.sqrt(np.maximum(spread[..., 0, 0] + spread[..., 1, 1], 0.0))
    return np.where(undetermined, np.inf, floor)


_IDENTITY = np.array([1.0, 0.0, 0.0, 1.0, 0.0, 1.0])
"""The packed identity: stands in for an undetermined cell's information before inverting."""


def _unpacked(packed: FloatArray) -> FloatArray:
    """Packed symmetric 3×3 matrices as arrays, shape (..., 3, 3)."""
    rows = ((XX, XY, XH), (XY, YY, YH), (XH, YH, HH))
    return np.stack([np.stack([packed[..., k] for k in row], axis=-1) for row in rows], axis=-2)

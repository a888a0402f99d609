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
"""

from __future__ import annotations

import numpy as np

from azgym.core import BoolArray, FloatArray, IntArray
from azgym.site.error_model import ErrorModel

__all__ = ["MIN_BEACONS", "SINGULAR", "contributions", "position_sigma"]

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
    dx = beacon_xy[None, :, 0] - points[:, None, 0]
    dy = beacon_xy[None, :, 1] - points[:, None, 1]
    squared = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = np.where(seen, 1.0 / error_model.variance(np.sqrt(squared), beacon_width), 0.0)
        gx = np.where(seen, dy / squared, 0.0)
        gy = np.where(seen, -dx / squared, 0.0)
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

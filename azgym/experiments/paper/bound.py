"""The accuracy limit of the paper's setting: the optimally weighted least-squares covariance.

At a pose, with J the Jacobian of the azimuths with respect to (x, y, φ) — ∂α_i/∂x = (y_i − y)/D²,
∂α_i/∂y = −(x_i − x)/D², ∂α_i/∂φ = −1 — and Σ the error model's variances (eq. 3: two independent
uniform errors, Δα_d²/3 + Δα_c,i²/3), the best linear unbiased estimator has covariance
(JᵀΣ⁻¹J)⁻¹. Its position block gives the RMS error and, for a Gaussian error with that covariance,
the mean error. The errors of eq. 3 are uniform, not Gaussian, so this is the limit of
(weighted) least squares — which is what every localizer here computes in the end — rather than a
Cramér-Rao bound, which does not exist for bounded noise.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ellipe

from azgym.core import BeaconMap, BoolArray
from azgym.site.error_model import ErrorModel

__all__ = ["wls_position_error"]


def wls_position_error(
    x: float, y: float, beacons: BeaconMap, error_model: ErrorModel, use: BoolArray | None = None
) -> tuple[float, float]:
    """RMS and mean 2-D position error [m] of optimally weighted least squares at (x, y).

    Args:
        x: Camera position, east [m].
        y: Camera position, north [m].
        beacons: The beacon map.
        error_model: The azimuth error model.
        use: Which beacons are measured correctly (default: all). Beacons at the camera's position
            carry no direction and are left out.

    Returns:
        (RMS error, mean error) [m]; inf when the geometry does not determine the pose.
    """
    dx = beacons.xy[:, 0] - x
    dy = beacons.xy[:, 1] - y
    d2 = dx * dx + dy * dy
    keep = d2 > 1e-18 if use is None else (d2 > 1e-18) & np.asarray(use, dtype=bool)
    if np.count_nonzero(keep) < 3:
        return math.inf, math.inf
    dx, dy, d2 = dx[keep], dy[keep], d2[keep]
    variance = error_model.variance(np.sqrt(d2), beacons.width[keep])
    jacobian = np.column_stack([dy / d2, -dx / d2, -np.ones_like(d2)])
    information = jacobian.T @ (jacobian / variance[:, None])
    try:
        covariance = np.linalg.inv(information)
    except np.linalg.LinAlgError:
        return math.inf, math.inf
    eigen = np.linalg.eigvalsh(covariance[:2, :2])
    if eigen.min() <= 0 or not np.isfinite(eigen).all():
        return math.inf, math.inf
    small, large = float(eigen[0]), float(eigen[1])
    rms = math.sqrt(small + large)
    # Mean norm of a 2-D Gaussian with variances (large, small) (the Hoyt distribution's mean):
    # sqrt(2/π) ∫₀^{π/2} sqrt(a² cos² t + b² sin² t) dt = sqrt(2/π) · a · E(1 − b²/a²).
    mean = math.sqrt(2.0 / math.pi) * math.sqrt(large) * float(ellipe(1.0 - small / large))
    return rms, mean

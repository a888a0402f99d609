"""The paper's synthetic measurements (Rátosi & Simon 2021): every beacon seen from a known pose.

Ideal azimuths (eq. 19-22 run forward), the errors of eq. 3, and the outlier injection of the
simulation protocol (Sec. 3.1). No scene: nothing is occluded or mirrored (for that, see
:mod:`azgym.sensing.geometry`).
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import BeaconMap, BoolArray, FloatArray, Measurements, wrap_angle
from azgym.errors import InvalidInputError
from azgym.site.error_model import ErrorModel

__all__ = ["derangement", "ideal_azimuths", "inject_outliers", "noisy_measurements"]


def ideal_azimuths(
    x: float, y: float, heading: float, beacons: BeaconMap
) -> tuple[FloatArray, FloatArray]:
    """Ideal azimuths α_i = β_i − φ (eq. 21-22) and horizontal distances D_i (eq. 24).

    Returns:
        Azimuths in the camera frame [rad], wrapped to (−π, π], and distances [m], shape (N,).
    """
    dx = beacons.xyz[:, 0] - x
    dy = beacons.xyz[:, 1] - y
    return wrap_angle(np.arctan2(dy, dx) - heading), np.hypot(dx, dy)


def noisy_measurements(
    x: float,
    y: float,
    heading: float,
    beacons: BeaconMap,
    error_model: ErrorModel,
    rng: np.random.Generator,
) -> Measurements:
    """Every beacon measured once with the errors of eq. 3 drawn from ``rng``."""
    azimuth, distance = ideal_azimuths(x, y, heading, beacons)
    noise = error_model.sample(distance, beacons.width, rng)
    return Measurements(beacons.ids, wrap_angle(azimuth + noise))


OUTLIER_MIN = math.radians(10.0)
OUTLIER_MAX = math.radians(170.0)


def inject_outliers(
    azimuth: FloatArray, k: int, rng: np.random.Generator
) -> tuple[FloatArray, BoolArray]:
    """Corrupt ``k`` of the measured azimuths the way Sec. 3.1 does.

    * k = 1: one random measurement gets an error drawn uniformly from ±[10°, 170°];
    * k >= 2: k random measurements swap their values by a uniformly drawn derangement, so none
      keeps its own (this imitates k wrong beacon identifications).

    Args:
        azimuth: The measured azimuths [rad], shape (M,).
        k: Number of outliers, 0 <= k <= M (and k != 1 needs M >= 2... k >= 2 needs k <= M).
        rng: The generator every draw comes from.

    Returns:
        The corrupted azimuths (a new array) and a mask of the measurements made outliers.
    """
    azimuth = np.asarray(azimuth, dtype=np.float64)
    m = azimuth.size
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k <= m:
        raise InvalidInputError(f"inject_outliers: k must be an integer in [0, {m}], got {k!r}")
    corrupted = azimuth.copy()
    mask = np.zeros(m, dtype=bool)
    if k == 0:
        return corrupted, mask
    chosen = rng.choice(m, size=k, replace=False)
    mask[chosen] = True
    if k == 1:
        magnitude = rng.uniform(OUTLIER_MIN, OUTLIER_MAX)
        sign = 1.0 if rng.random() < 0.5 else -1.0
        corrupted[chosen[0]] = wrap_angle(azimuth[chosen[0]] + sign * magnitude)
        return corrupted, mask
    corrupted[chosen] = azimuth[chosen[derangement(k, rng)]]
    return corrupted, mask


def derangement(k: int, rng: np.random.Generator) -> np.ndarray:
    """A permutation of range(k) with no fixed point, uniform over all such (by rejection)."""
    if k < 2:
        raise InvalidInputError(f"derangement: k must be >= 2, got {k}")
    while True:
        perm = rng.permutation(k)
        if not (perm == np.arange(k)).any():
            return perm

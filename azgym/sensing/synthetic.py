"""Ideal and noisy azimuths of beacons seen from a known pose (eq. 19-22 forward, eq. 3 noise)."""

from __future__ import annotations

import numpy as np

from azgym.core import BeaconMap, FloatArray, Measurements, wrap_angle
from azgym.sensing.error_model import ErrorModel


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

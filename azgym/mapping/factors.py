"""The factor graph's variables and factors, as GTSAM builds them (shared by both solves).

The keys of the unknowns (:func:`pose_key`, :func:`beacon_key`, :func:`sensor_key`); the robust
loss of the azimuths and the map (:func:`robust_loss`); a detection's bearing factor
(:func:`bearing`), an anchor's prior (:func:`anchor`), a beacon's map prior
(:func:`map_prior`), a link's between factor at zero
sensor errors (:func:`between`) and the odometry's error with its derivatives
(:func:`odometry_error`), which the batch solve linearizes (:mod:`azgym.mapping.graph`) and the
frame-by-frame one (:mod:`azgym.mapping.sweep`) shares. Every function takes the ``gtsam``
module, imported by its caller when a survey runs.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from azgym.core import FloatArray
from azgym.mapping.problem import Settings

__all__ = ["ANCHOR_STD", "anchor", "beacon_key", "bearing", "between", "map_prior",
           "odometry_error", "pose_key", "robust_loss", "sensor_key"]

ANCHOR_STD = 0.002
"""Standard deviation of a surveyed anchor's position [m] (a total station's)."""


def pose_key(gtsam: Any, k: int) -> int:
    """The GTSAM key of camera pose ``k``."""
    return int(gtsam.symbol("x", k))


def beacon_key(gtsam: Any, b: int) -> int:
    """The GTSAM key of beacon ``b``."""
    return int(gtsam.symbol("l", b))


def sensor_key(gtsam: Any, k: int) -> int:
    """The GTSAM key of link ``k``'s turn-rate bias and scale error."""
    return int(gtsam.symbol("s", k))


def robust_loss(gtsam: Any, settings: Settings) -> Any:
    """The robust loss of the azimuth factors, at ``loss_scale`` standard deviations."""
    estimators = {"cauchy": gtsam.noiseModel.mEstimator.Cauchy,
                  "huber": gtsam.noiseModel.mEstimator.Huber}
    return estimators[settings.loss].Create(float(settings.loss_scale))


def anchor(gtsam: Any, beacon: int, xy: FloatArray) -> Any:
    """Beacon ``beacon`` held at its map position ``xy`` as an anchor (:data:`ANCHOR_STD`)."""
    return gtsam.PriorFactorPoint2(beacon_key(gtsam, beacon), gtsam.Point2(*xy),
                                   gtsam.noiseModel.Isotropic.Sigma(2, ANCHOR_STD))


def map_prior(gtsam: Any, loss: Any, settings: Settings, beacon: int, xy: FloatArray) -> Any:
    """Beacon ``beacon`` held at its map position ``xy`` by the map's accuracy, behind ``loss``.

    The robust loss lets a beacon the drive shows elsewhere break away: at ``loss_scale``
    standard deviations off (3 cm as shipped) its prior weighs half, at 1 m a thousandth.
    """
    noise = gtsam.noiseModel.Robust.Create(
        loss, gtsam.noiseModel.Isotropic.Sigma(2, settings.map_sigma))
    return gtsam.PriorFactorPoint2(beacon_key(gtsam, beacon), gtsam.Point2(*xy), noise)


def between(gtsam: Any, first: int, second: int, move: FloatArray, covariance: FloatArray,
            jacobian: FloatArray, sensor_std: FloatArray) -> Any:
    """A link's between factor at zero sensor errors, their spread counted in it.

    Args:
        gtsam: The gtsam module.
        first: The link's first pose index.
        second: Its second.
        move: (3,) the link's relative pose at zero sensor errors.
        covariance: (3, 3) its covariance.
        jacobian: (3, 2) its derivative with respect to the turn-rate bias and scale error.
        sensor_std: (2,) their spread.
    """
    spread = jacobian @ np.diag(sensor_std**2) @ jacobian.T
    return gtsam.BetweenFactorPose2(
        pose_key(gtsam, first), pose_key(gtsam, second), gtsam.Pose2(*move),
        gtsam.noiseModel.Gaussian.Covariance(covariance + spread))


def bearing(gtsam: Any, loss: Any, pose: int, beacon: int, azimuth: float,
            sigma: float) -> Any:
    """One detection's bearing factor, behind the robust ``loss``."""
    noise = gtsam.noiseModel.Robust.Create(loss, gtsam.noiseModel.Isotropic.Sigma(1, sigma))
    return gtsam.BearingFactor2D(pose_key(gtsam, pose), beacon_key(gtsam, beacon),
                                 gtsam.Rot2(azimuth), noise)


def odometry_error(gtsam: Any, first: Any, second: Any, sensors: FloatArray, move: FloatArray,
                   jacobian: FloatArray) -> tuple[FloatArray, tuple[FloatArray, ...]]:
    """One link's error and its derivatives with respect to both poses and the sensor errors.

    The odometry says the camera moved by Δ = ``move`` + ``jacobian`` (b, k) (x, y, heading in
    the first camera's frame) given the link's turn-rate bias b and scale error k
    (``sensors``); the poses say it moved by ``first``⁻¹ ``second``. The error is the latter in
    Δ's own frame, Logmap(Δ⁻¹ ``first``⁻¹ ``second``): GTSAM's between factor's, with Δ
    depending on (b, k). A pose's tangent (u, v, w) moves (x, y, θ) by (R(θ) (u, v), w), so
    d(Δ's tangent)/d(b, k) is blockdiag(R(θ)ᵀ, 1) ``jacobian``.

    Args:
        gtsam: The gtsam module.
        first: The first camera pose (``gtsam.Pose2``).
        second: The next one.
        sensors: (b, k) [rad/s, 1].
        move: (3,) the relative pose at zero bias and scale error.
        jacobian: (3, 2) its derivative with respect to (b, k).

    Returns:
        The error (3,) and its derivatives (3, 3), (3, 3), (3, 2) with respect to ``first``,
        ``second`` (their tangents) and ``sensors``.
    """
    x, y, theta = move + jacobian @ sensors
    measured = gtsam.Pose2(x, y, theta)
    d_first, d_second = np.zeros((3, 3), order="F"), np.zeros((3, 3), order="F")
    moved = first.between(second, d_first, d_second)
    d_measured, d_moved = np.zeros((3, 3), order="F"), np.zeros((3, 3), order="F")
    found = measured.localCoordinates(moved, d_measured, d_moved)
    c, s = math.cos(theta), math.sin(theta)
    tangent = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return np.asarray(found).reshape(3), (d_moved @ d_first, d_moved @ d_second,
                                          d_measured @ tangent @ jacobian)

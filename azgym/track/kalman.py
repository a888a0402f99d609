"""The Kalman filter's two steps on small explicit matrices, and Plotter's inertial prediction.

:func:`predict` and :func:`update` are the textbook linear steps (Dang et al. 2015, eq. 4-9):
x⁻ = F x + u, P⁻ = F P Fᵀ + Q; then K = P⁻ Hᵀ (H P⁻ Hᵀ + R)⁻¹, x = x⁻ + K (z − H x⁻),
P = (I − K H) P⁻. An observation may be nonlinear (an extended filter's step): the caller passes
h(x) and its Jacobian H. An innovation whose squared Mahalanobis distance exceeds a gate is
refused (an outlier fix must not pull the state).

:func:`inertial_step` is the prediction of the trackers in :mod:`azgym.track.inertial_kalman` over
one IMU sample. The state is (x, y, vₓ, v_y, φ, b): the IMU's position, velocity and heading and the
gyro's bias b. The body-frame acceleration, turned into the world frame by the heading, is
integrated as eq. 4 does (constant acceleration over the sample); the heading by the gyro's yaw
rate less its bias (which random-walks: the fixes' headings estimate it). It is an extended
filter's step: F carries the derivative of the rotated acceleration with respect to φ, so a
heading error feeds the position's uncertainty.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray

__all__ = ["HEADING", "SIZE", "VX", "VY", "camera_observation", "inertial_step", "predict",
           "scalar_update", "update"]

X, Y, VX, VY, HEADING, BIAS = range(6)
SIZE = 6


def predict(x: FloatArray, P: FloatArray, F: FloatArray, Q: FloatArray,
            u: FloatArray | None = None) -> None:
    """Predict in place (eq. 4-5): x ← F x + u, P ← F P Fᵀ + Q."""
    x[:] = F @ x if u is None else F @ x + u
    P[:] = F @ P @ F.T + Q


def update(x: FloatArray, P: FloatArray, z: FloatArray, predicted: FloatArray, H: FloatArray,
           R: FloatArray, angles: tuple[int, ...] = (), gate: float = math.inf) -> float:
    """Correct the state with an observation z ~ N(h(x), R) (eq. 6-9), in place.

    Args:
        x: State, updated in place.
        P: Its covariance, updated in place.
        z: The observation.
        predicted: h(x), what the state predicts z to be (H x for a linear observation).
        H: The Jacobian of h at x (the observation matrix of eq. 6).
        R: The observation's covariance.
        angles: Positions in ``z`` that are angles: their innovation is wrapped to (−π, π].
        gate: Largest squared Mahalanobis distance of the innovation accepted.

    Returns:
        The innovation's squared Mahalanobis distance; the state is left alone when it exceeds
        ``gate``.
    """
    innovation = z - predicted
    for i in angles:
        innovation[i] = math.remainder(innovation[i], math.tau)
    PHt = P @ H.T
    S_inv = np.linalg.inv(H @ PHt + R)
    distance = float(innovation @ S_inv @ innovation)
    if not distance <= gate:
        return distance
    K = PHt @ S_inv
    x += K @ innovation
    P -= K @ PHt.T
    P[:] = 0.5 * (P + P.T)  # keep it symmetric against rounding
    return distance


def scalar_update(x: FloatArray, P: FloatArray, innovation: float, H: FloatArray,
                  variance: float) -> None:
    """Correct the state with one scalar observation (eq. 6-9 without a matrix inverse).

    Args:
        x: State, updated in place.
        P: Its covariance, updated in place.
        innovation: The observation less what the state predicts.
        H: The observation's Jacobian row, (SIZE,).
        variance: The observation's variance.
    """
    PHt = P @ H
    gain = PHt / (float(H @ PHt) + variance)
    x += gain * innovation
    P -= np.outer(gain, PHt)
    P[:] = 0.5 * (P + P.T)


def camera_observation(x: FloatArray, ahead: float) -> tuple[FloatArray, FloatArray]:
    """The camera pose a state predicts, ``ahead`` metres in front of the IMU, and its Jacobian.

    h(x) = (x + r cos φ, y + r sin φ, φ): a fix sees the camera, the state follows the IMU.
    """
    c, s = math.cos(x[HEADING]), math.sin(x[HEADING])
    H = np.zeros((3, SIZE))
    H[0, X] = H[1, Y] = H[2, HEADING] = 1.0
    H[0, HEADING], H[1, HEADING] = -ahead * s, ahead * c
    return np.array([x[X] + ahead * c, x[Y] + ahead * s, x[HEADING]]), H


def inertial_step(x: FloatArray, P: FloatArray, accel: tuple[float, float], yaw_rate: float,
                  dt: float, accel_var: float, yaw_rate_var: float, bias_walk_var: float) -> None:
    """Move (x, y, vₓ, v_y, φ, b) and its covariance over one IMU sample of ``dt`` seconds.

    Args:
        x: State, updated in place.
        P: Its covariance, updated in place.
        accel: The acceleration in the body frame (forward, left) [m/s²].
        yaw_rate: The gyro's turn rate [rad/s], its bias b included.
        dt: How long the sample holds [s].
        accel_var: Variance of each acceleration axis [(m/s²)²]: white, held over the sample,
            so it adds B Bᵀ σ² to P (the (dt²/2, dt) of eq. 4).
        yaw_rate_var: Variance of the yaw rate's white noise [(rad/s)²], likewise.
        bias_walk_var: Growth of the bias's variance [(rad/s)²/s].
    """
    c, s = math.cos(x[HEADING]), math.sin(x[HEADING])
    ax, ay = c * accel[0] - s * accel[1], s * accel[0] + c * accel[1]
    half = 0.5 * dt * dt
    x[X] += x[VX] * dt + ax * half
    x[Y] += x[VY] * dt + ay * half
    x[VX] += ax * dt
    x[VY] += ay * dt
    x[HEADING] = math.remainder(x[HEADING] + (yaw_rate - x[BIAS]) * dt, math.tau)
    F = np.eye(SIZE)
    F[X, VX] = F[Y, VY] = dt
    F[X, HEADING], F[Y, HEADING] = -ay * half, ax * half  # d(rotated accel)/dφ = (−a_y, a_x)
    F[VX, HEADING], F[VY, HEADING] = -ay * dt, ax * dt
    F[HEADING, BIAS] = -dt
    P[:] = F @ P @ F.T
    q_pp, q_pv, q_vv = accel_var * half * half, accel_var * half * dt, accel_var * dt * dt
    P[X, X] += q_pp
    P[Y, Y] += q_pp
    P[X, VX] += q_pv
    P[VX, X] += q_pv
    P[Y, VY] += q_pv
    P[VY, Y] += q_pv
    P[VX, VX] += q_vv
    P[VY, VY] += q_vv
    P[HEADING, HEADING] += yaw_rate_var * dt * dt
    P[BIAS, BIAS] += bias_walk_var * dt

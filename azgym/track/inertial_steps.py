"""The compiled steps of Plotter's inertial Kalman filters: a frame's samples, then its fix.

The trackers of :mod:`azgym.track.inertial_kalman` move their state (x, y, vₓ, v_y, φ, b) (the
IMU's position, velocity and heading and the gyro's bias b) from one frame to the next through
every IMU and odometry sample in between, in time order, then correct it by the frame's fix.
:func:`predict_samples` does all of a frame's samples in one compiled call and
:func:`fix_update` the correction (:func:`camera_estimate` the answer): a frame holds a handful
to dozens of samples, each a 6 × 6 covariance step, which as numpy calls cost several times the
frame's fix.

Between samples the held readings move the state (:func:`inertial_step`): the body-frame
acceleration, turned into the world frame by the heading, is integrated as Plotter's eq. 4 does
(constant acceleration over the interval); the heading by the yaw rate less the bias (which
random-walks: the fixes' headings estimate it). It is an extended filter's step: F carries the
derivative of the rotated acceleration with respect to φ, so a heading error feeds the position's
uncertainty. At each sample:

- an IMU sample corrects the heading by its orientation reading when it has one, then starts
  its acceleration (through the first-order low-pass :func:`low_pass`, for ``lpkf``) and, when
  the turn rate comes from the gyro, its yaw rate, held until the next sample;
- an odometry sample corrects the velocity along the heading by its speed (times the speed
  factor) when asked, and across it (as zero) when there is no accelerometer; when the turn
  rate comes from the odometry, it starts the sample's rate held.

On a repeated time stamp the IMU's sample comes first.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray
from azgym.jit import jit, wrap_compiled
from azgym.localize._levenberg_marquardt import solve3

__all__ = ["ACCEL_VAR", "BIAS", "BIAS_WALK_VAR", "HEADING", "HEADING_VAR", "HELD_SIZE",
           "LOW_PASS_RC", "NOISE_SIZE", "SIZE", "SPEED_FACTOR", "SPEED_VAR", "UNMEASURED_ACCEL_VAR",
           "VX", "VY", "X", "Y", "YAW_RATE_VAR", "camera_estimate", "fix_update", "inertial_step",
           "low_pass", "new_held", "predict_samples"]

X, Y, VX, VY, HEADING, BIAS = range(6)
SIZE = 6
"""The state's layout: the IMU's position [m], velocity [m/s] and heading [rad], the gyro's bias
[rad/s]."""

ACCEL_FORWARD, ACCEL_LEFT, YAW_RATE, LAST_SAMPLE, FILTERED, FILTERED_FORWARD, FILTERED_LEFT = \
    range(7)
HELD_SIZE = 7
"""What a tracker holds between samples: the acceleration and yaw rate in force, the time of the
last IMU sample, and the low-pass filter's state (1.0 once it has a value, and the value)."""

NOISE_SIZE = 8
ACCEL_VAR, YAW_RATE_VAR, BIAS_WALK_VAR, HEADING_VAR, SPEED_VAR, SPEED_FACTOR, LOW_PASS_RC, \
    UNMEASURED_ACCEL_VAR = range(NOISE_SIZE)
"""A tracker's constants, in one array: the variances of a measured acceleration axis, of the yaw
rate's white noise, of the bias's walk (per second), of an IMU heading reading and of an odometry
speed; the odometry's speed factor; the low-pass filter's RC [s] (0: no filter); the variance of
the acceleration when the IMU measures none."""


def new_held() -> FloatArray:
    """The held readings at a tracker's start: at rest, no sample seen, the filter empty."""
    held = np.zeros(HELD_SIZE)
    held[LAST_SAMPLE] = -math.inf
    return held


@jit
def inertial_step(x, P, accel_forward, accel_left, yaw_rate, dt, accel_var, yaw_rate_var,
                  bias_walk_var):
    """Move (x, y, vₓ, v_y, φ, b) and its covariance over ``dt`` seconds of held readings.

    Args:
        x: State, updated in place.
        P: Its covariance, updated in place.
        accel_forward: The acceleration in the body frame, forward [m/s²].
        accel_left: Likewise, leftward [m/s²].
        yaw_rate: The turn rate [rad/s], the gyro's bias b included.
        dt: How long the readings hold [s].
        accel_var: Variance of each acceleration axis [(m/s²)²]: white, held over the interval,
            so it adds B Bᵀ σ² to P (the (dt²/2, dt) of eq. 4).
        yaw_rate_var: Variance of the yaw rate's white noise [(rad/s)²], likewise.
        bias_walk_var: Growth of the bias's variance [(rad/s)²/s].
    """
    c, s = math.cos(x[HEADING]), math.sin(x[HEADING])
    ax, ay = c * accel_forward - s * accel_left, s * accel_forward + c * accel_left
    half = 0.5 * dt * dt
    x[X] += x[VX] * dt + ax * half
    x[Y] += x[VY] * dt + ay * half
    x[VX] += ax * dt
    x[VY] += ay * dt
    x[HEADING] = wrap_compiled(x[HEADING] + (yaw_rate - x[BIAS]) * dt)
    F = np.eye(SIZE)
    F[X, VX] = F[Y, VY] = dt
    F[X, HEADING], F[Y, HEADING] = -ay * half, ax * half  # d(rotated accel)/dφ = (−a_y, a_x)
    F[VX, HEADING], F[VY, HEADING] = -ay * dt, ax * dt
    F[HEADING, BIAS] = -dt
    FP = np.zeros((SIZE, SIZE))
    for i in range(SIZE):
        for k in range(SIZE):
            if F[i, k] != 0.0:
                for j in range(SIZE):
                    FP[i, j] += F[i, k] * P[k, j]
    for i in range(SIZE):
        for j in range(SIZE):
            total = 0.0
            for k in range(SIZE):
                total += FP[i, k] * F[j, k]
            P[i, j] = total
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


@jit
def low_pass(held, forward, left, dt, rc):
    """The first-order low-pass (RC = ``rc`` seconds) of an acceleration ``dt`` after the last.

    y ← y + α (x − y) with α = dt / (RC + dt), RC = 1 / (2π f_c): the discrete RC filter for
    irregularly spaced samples. The first sample passes unchanged (no start-up transient from
    zero). The state is ``held``'s filter slots, updated in place; returns the filtered pair.
    """
    if held[FILTERED] == 0.0:
        held[FILTERED] = 1.0
        held[FILTERED_FORWARD], held[FILTERED_LEFT] = forward, left
    else:
        alpha = dt / (rc + dt)
        held[FILTERED_FORWARD] += alpha * (forward - held[FILTERED_FORWARD])
        held[FILTERED_LEFT] += alpha * (left - held[FILTERED_LEFT])
    return held[FILTERED_FORWARD], held[FILTERED_LEFT]


@jit(inline="always")
def _correct(x, P, innovation, H, variance):
    """Correct the state by one scalar observation with Jacobian row H (eq. 6-9, no inverse).

    K = P Hᵀ / (H P Hᵀ + σ²), x += K ν, P −= K (P Hᵀ)ᵀ, then P is made symmetric again.
    """
    PHt = np.zeros(SIZE)
    for i in range(SIZE):
        for j in range(SIZE):
            PHt[i] += P[i, j] * H[j]
    spread = 0.0
    for j in range(SIZE):
        spread += H[j] * PHt[j]
    spread += variance
    for i in range(SIZE):
        x[i] += PHt[i] / spread * innovation
    for i in range(SIZE):
        for j in range(SIZE):
            P[i, j] -= PHt[i] / spread * PHt[j]
    for i in range(SIZE):
        for j in range(i):
            P[i, j] = P[j, i] = 0.5 * (P[i, j] + P[j, i])


@jit(inline="always")
def _heading_reading(x, P, heading, variance):
    """Correct the state by the IMU's heading reading, the innovation wrapped to (−π, π]."""
    innovation = wrap_compiled(heading - x[HEADING])
    if not innovation * innovation / (P[HEADING, HEADING] + variance) <= math.inf:
        return  # a NaN covariance: the reading is refused, as any gate would
    H = np.zeros(SIZE)
    H[HEADING] = 1.0
    _correct(x, P, innovation, H, variance)


@jit(inline="always")
def _speed_reading(x, P, speed, variance, accelerometer):
    """Correct the velocity along the heading by an odometry speed, across it by zero without IMU.

    Without an accelerometer nothing else turns the velocity with the heading, so the sample also
    observes the velocity across the heading as zero: the tracked point is then taken on the
    turning axis (the camera's offset ahead of it is the tracker's ``camera_from_imu``).
    """
    c, s = math.cos(x[HEADING]), math.sin(x[HEADING])
    along, across = x[VX] * c + x[VY] * s, -x[VX] * s + x[VY] * c
    H = np.zeros(SIZE)
    H[VX], H[VY], H[HEADING] = c, s, across
    _correct(x, P, speed - along, H, variance)
    if not accelerometer:
        c, s = math.cos(x[HEADING]), math.sin(x[HEADING])
        H = np.zeros(SIZE)
        H[VX], H[VY], H[HEADING] = -s, c, -(x[VX] * c + x[VY] * s)
        _correct(x, P, x[VX] * s - x[VY] * c, H, variance)


@jit
def predict_samples(x, P, imu_time, imu_accel, imu_yaw_rate, imu_heading, odometry_time,
                    odometry_speed, odometry_rate, odometry_used, clock, end, held, noise,
                    accelerometer, use_speed, gyro_yaw):
    """Move the state from ``clock`` to ``end`` through a frame's samples (module docstring).

    Args:
        x: State (x, y, vₓ, v_y, φ, b), updated in place.
        P: Its covariance, updated in place.
        imu_time: The IMU samples' times [s], in order.
        imu_accel: Their accelerations (forward, left) [m/s²], (K, 2).
        imu_yaw_rate: Their gyro's yaw rates [rad/s].
        imu_heading: Their orientation sensor's headings [rad] (NaN: none).
        odometry_time: The odometry samples' times [s], in order.
        odometry_speed: Their speeds [m/s].
        odometry_rate: Their turn rates [rad/s] (unused when ``gyro_yaw``).
        odometry_used: How many of the odometry's samples are stepped through, from the first
            (0: the odometry unused).
        clock: The time the state is at [s].
        end: The frame's time [s].
        held: The readings in force (:data:`HELD_SIZE` slots), updated in place.
        noise: The tracker's constants (:data:`NOISE_SIZE` slots).
        accelerometer: Whether the IMU measures accelerations (else they are taken as zero, with
            the unmeasured variance, and the speed samples observe the velocity across too).
        use_speed: Whether the odometry's speed samples correct the velocity.
        gyro_yaw: Whether the turn rate is the gyro's (else the odometry's).
    """
    i = j = 0
    while i < imu_time.size or j < odometry_used:
        if j == odometry_used or (i < imu_time.size and imu_time[i] <= odometry_time[j]):
            _hold(x, P, imu_time[i] - clock, held, noise, accelerometer)
            clock = imu_time[i]
            if not math.isnan(imu_heading[i]):
                _heading_reading(x, P, imu_heading[i], noise[HEADING_VAR])
            _hold_imu(held, imu_time[i], imu_accel[i, 0], imu_accel[i, 1], noise[LOW_PASS_RC])
            if gyro_yaw:
                held[YAW_RATE] = imu_yaw_rate[i]
            i += 1
            continue
        _hold(x, P, odometry_time[j] - clock, held, noise, accelerometer)
        clock = odometry_time[j]
        if use_speed:
            _speed_reading(x, P, noise[SPEED_FACTOR] * odometry_speed[j], noise[SPEED_VAR],
                           accelerometer)
        if not gyro_yaw:
            held[YAW_RATE] = odometry_rate[j]
        j += 1
    _hold(x, P, end - clock, held, noise, accelerometer)


@jit(inline="always")
def _hold(x, P, dt, held, noise, accelerometer):
    """Move the state ``dt`` seconds with the acceleration and turn rate in force."""
    if accelerometer and not math.isnan(held[ACCEL_FORWARD]):
        inertial_step(x, P, held[ACCEL_FORWARD], held[ACCEL_LEFT], held[YAW_RATE], dt,
                      noise[ACCEL_VAR], noise[YAW_RATE_VAR], noise[BIAS_WALK_VAR])
    else:
        inertial_step(x, P, 0.0, 0.0, held[YAW_RATE], dt, noise[UNMEASURED_ACCEL_VAR],
                      noise[YAW_RATE_VAR], noise[BIAS_WALK_VAR])


@jit(inline="always")
def _hold_imu(held, time, forward, left, rc):
    """Hold an IMU sample's acceleration, low-passed when ``rc`` > 0 (and it has one)."""
    if rc > 0.0 and not math.isnan(forward):
        forward, left = low_pass(held, forward, left, time - held[LAST_SAMPLE], rc)
    held[LAST_SAMPLE] = time
    held[ACCEL_FORWARD], held[ACCEL_LEFT] = forward, left


@jit
def fix_update(x, P, fix_x, fix_y, fix_heading, R, ahead, gate):
    """Correct the state by a camera fix z = (x, y, φ) with covariance R (eq. 6-9), in place.

    The fix sees the camera, ``ahead`` metres in front of the IMU the state follows:
    h(x) = (x + r cos φ, y + r sin φ, φ), linearised (an extended filter's step); the heading's
    innovation is wrapped to (−π, π]. K = P Hᵀ S⁻¹ with S = H P Hᵀ + R, x += K ν, P −= K (P Hᵀ)ᵀ,
    then P is made symmetric again.

    Returns:
        The innovation's squared Mahalanobis distance νᵀ S⁻¹ ν. The state is left alone when it
        exceeds ``gate``, or is NaN (a singular S), and when R is not finite: then −1.
    """
    for r in range(3):
        for k in range(3):
            if not math.isfinite(R[r, k]):
                return -1.0
    H, innovation = _camera_rows(x, ahead)
    innovation[0] = fix_x - innovation[0]
    innovation[1] = fix_y - innovation[1]
    innovation[2] = wrap_compiled(fix_heading - innovation[2])
    PHt = np.zeros((SIZE, 3))
    for i in range(SIZE):
        for k in range(3):
            for j in range(SIZE):
                PHt[i, k] += P[i, j] * H[k, j]
    spread = np.empty((3, 3))
    for r in range(3):
        for k in range(3):
            total = 0.0
            for j in range(SIZE):
                total += H[r, j] * PHt[j, k]
            spread[r, k] = total + R[r, k]
    spread_inv = _inverse3(spread)
    distance = 0.0
    for r in range(3):
        for k in range(3):
            distance += innovation[r] * spread_inv[r, k] * innovation[k]
    if not distance <= gate:
        return distance
    gain = np.zeros((SIZE, 3))
    for i in range(SIZE):
        for k in range(3):
            for r in range(3):
                gain[i, k] += PHt[i, r] * spread_inv[r, k]
    for i in range(SIZE):
        for k in range(3):
            x[i] += gain[i, k] * innovation[k]
    for i in range(SIZE):
        for j in range(SIZE):
            for k in range(3):
                P[i, j] -= gain[i, k] * PHt[j, k]
    for i in range(SIZE):
        for j in range(i):
            P[i, j] = P[j, i] = 0.5 * (P[i, j] + P[j, i])
    return distance


@jit
def camera_estimate(x, P, ahead, covariance):
    """The camera's pose h(x) as x, y, φ (wrapped), its covariance H P Hᵀ into ``covariance``.

    The camera is ``ahead`` metres in front of the IMU. The caller makes the 3 × 3 array: numba
    takes longer to hand a new array back than numpy takes to make one.
    """
    H, pose = _camera_rows(x, ahead)
    for r in range(3):
        for k in range(3):
            total = 0.0
            for i in range(SIZE):
                for j in range(SIZE):
                    total += H[r, i] * P[i, j] * H[k, j]
            covariance[r, k] = total
    return pose[0], pose[1], wrap_compiled(pose[2])


@jit(inline="always")
def _camera_rows(x, ahead):
    """The observation's Jacobian H (3 × 6) at x, and h(x): the camera's (x, y, φ)."""
    c, s = math.cos(x[HEADING]), math.sin(x[HEADING])
    H = np.zeros((3, SIZE))
    H[0, X] = H[1, Y] = H[2, HEADING] = 1.0
    H[0, HEADING], H[1, HEADING] = -ahead * s, ahead * c
    pose = np.empty(3)
    pose[0], pose[1], pose[2] = x[X] + ahead * c, x[Y] + ahead * s, x[HEADING]
    return H, pose


@jit(inline="always")
def _inverse3(a):
    """The inverse of a 3 × 3 matrix, column by column by :func:`solve3` (NaN if singular)."""
    inverse = np.empty((3, 3))
    unit, column = np.zeros(3), np.empty(3)
    for k in range(3):
        unit[k] = 1.0
        if solve3(a, unit, column) == 0.0:
            inverse.fill(np.nan)
            return inverse
        unit[k] = 0.0
        for r in range(3):
            inverse[r, k] = column[r]
    return inverse

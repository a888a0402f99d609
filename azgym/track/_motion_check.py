"""The compiled check of a tracker's motion samples (:func:`azgym.track.base.check_motion`).

The check runs on every frame of every route; as numpy calls it cost about 15 µs a frame, more
than a per-frame localizer itself, so it is a compiled loop, in a module of its own so that the
kernel cache depends on nothing else.
"""

from __future__ import annotations

import numpy as np

from azgym.jit import jit

OUT_OF_ORDER, NOT_FINITE, PARTLY_GIVEN = 1, 2, 3
"""What :func:`stream_fault` finds wrong (0: nothing)."""
_GIVEN, _LEFT_OUT = -1, -2
"""What :func:`_column` finds in a sound column."""


@jit
def stream_fault(after, until, time, first, second, third, optional):
    """What is wrong with one stream of samples, which column, and which columns it gives.

    Sample times must be finite, after ``after``, never decreasing (a repeated time stamp is
    allowed) and at most ``until``. A value must be finite, except that a column marked
    ``optional`` may be left out: NaN in every sample.

    Args:
        after: The previous frame's time [s].
        until: This frame's time [s].
        time: The sample times, (K,).
        first: The first value column, (K,).
        second: The second, (K,).
        third: The third, (K,).
        optional: Which of the three may be left out, (3,).

    Returns:
        (fault, column, given): fault is 0, OUT_OF_ORDER (column −1), NOT_FINITE (an infinite
        value or a NaN in a column that must be given; column −1 for a time) or PARTLY_GIVEN (NaN
        in some samples of an optional column only); ``given`` has bit c set when column c holds
        values (0 for a stream without samples).
    """
    previous = after
    for k in range(time.size):
        t = time[k]
        if not np.isfinite(t):
            return NOT_FINITE, -1, 0
        if not (t > after and t >= previous and t <= until):
            return OUT_OF_ORDER, -1, 0
        previous = t
    found = (_column(first, optional[0]), _column(second, optional[1]),
             _column(third, optional[2]))
    given = 0
    for c in range(3):
        if found[c] >= 0:
            return found[c], c, 0
        if found[c] == _GIVEN and time.size:
            given |= 1 << c
    return 0, -1, given


@jit
def motion_fault(after, until, odometry_time, speed, steer, odometry_yaw_rate, imu_time,
                 imu_yaw_rate, accel, odometry_optional, imu_optional):
    """:func:`stream_fault` of the odometry, then of the IMU, in one call.

    ``accel`` is the IMU's (K, 2) accelerations (columns ax, ay); the ``*_optional`` flags are
    each stream's, as :func:`stream_fault` takes them.

    Returns:
        (stream, fault, column, odometry's given, IMU's given): ``stream`` is 0 (the odometry)
        or 1 (the IMU) for the first stream at fault, with its fault and column, else −1.
    """
    fault, column, odometry_given = stream_fault(after, until, odometry_time, speed, steer,
                                                 odometry_yaw_rate, odometry_optional)
    if fault:
        return 0, fault, column, 0, 0
    fault, column, imu_given = stream_fault(after, until, imu_time, imu_yaw_rate, accel[:, 0],
                                            accel[:, 1], imu_optional)
    if fault:
        return 1, fault, column, 0, 0
    return -1, 0, -1, odometry_given, imu_given


@jit
def _column(values, optional):
    """_GIVEN, _LEFT_OUT (NaN throughout, where ``optional``), NOT_FINITE or PARTLY_GIVEN."""
    missing = 0
    for value in values:
        if np.isnan(value):
            missing += 1
        elif not np.isfinite(value):
            return NOT_FINITE
    if missing == 0:
        return _GIVEN
    if not optional:
        return NOT_FINITE
    return _LEFT_OUT if missing == values.size else PARTLY_GIVEN

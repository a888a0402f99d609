"""The motion model the trackers share: the vehicles' kinematics and how samples span time.

Wheel odometry reports the speed v of the turning axis: a forklift's reference axle (the one
that does not steer), a differential drive's wheel axle. A forklift's odometry reports the
steering angle δ, and it turns at ω = v tan δ / L (:mod:`azgym.world.forklift`'s bicycle
model); a differential drive's odometry reports ω itself (``OdometrySamples.yaw_rate``). A point
``ahead`` metres in front of the turning axis along the heading (the camera; negative: behind
it) moves at v along the heading plus ω·ahead across it, on either vehicle.

Samples hold over time the way the simulator's physics uses them: a reading holds from its own
time until the next one (a zero-order hold). pymunk moves a body with the velocity it had after
the previous step, so the yaw rate and speed read at t_k are what turns and moves the forklift
over (t_k, t_k+1]. :func:`held_spans` turns sample times into those intervals, so the dead
reckoning and the Kalman filters integrate the same way.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray, wrap_scalar
from azgym.errors import InvalidInputError
from azgym.profile import DIFFERENTIAL_DRIVE, FORKLIFT
from azgym.sensing.motion import OdometrySamples
from azgym.track.base import COLUMNS
from azgym.world.forklift import ForkliftSpec

__all__ = ["CAMERA_AHEAD", "CAMERA_FROM_IMU", "WHEELBASE", "advance", "held_spans",
           "odometry_yaw_rates", "yaw_rates"]

_SPEC = ForkliftSpec()
WHEELBASE = _SPEC.wheelbase
"""The default forklift's wheelbase L [m]."""
CAMERA_AHEAD = _SPEC.camera_offset[0] - 0.5 * _SPEC.wheelbase * (1 if _SPEC.rear_steer else -1)
"""How far the default forklift's camera is ahead of its non-steering axle [m] (negative: behind;
the rear-steered forklift's reference is the front axle, 0.8 m ahead of the body centre)."""
CAMERA_FROM_IMU = _SPEC.camera_offset[0]
"""How far the default forklift's camera is ahead of its body centre, where the IMU sits [m]."""


_STEER = 1 << COLUMNS["odometry"].index("steer")
_YAW_RATE = 1 << COLUMNS["odometry"].index("yaw_rate")
"""The steering angle's and the turn rate's bits in :func:`~azgym.track.base.check_motion`'s
columns of the odometry."""


def held_spans(times: FloatArray, start: float, end: float) -> FloatArray:
    """How long each reading holds between ``start`` and ``end``: shape (K + 1,) for K samples.

    The first span (``start`` to the first sample) belongs to the reading held from before, the
    others each to one sample, up to the next sample or ``end``.
    """
    return np.diff(np.concatenate(([start], times, [end])))


def yaw_rates(speed: FloatArray, steer: FloatArray, wheelbase: float) -> FloatArray:
    """ω = v tan δ / L of the bicycle model [rad/s]."""
    return speed * np.tan(steer) / wheelbase


def odometry_yaw_rates(odometry: OdometrySamples, vehicle: str, wheelbase: float,
                       columns: int | None = None) -> FloatArray:
    """The turn rate the odometry reports, per sample [rad/s].

    Its ``yaw_rate`` when it reports one (a differential drive's, or any odometry that reports
    its turn rate); else, on a forklift, the bicycle model's v tan δ / L from its steering angle.
    ``columns``: which of the odometry's :data:`~azgym.track.base.COLUMNS` the samples give, as
    :func:`~azgym.track.base.check_motion` found them (given throughout or NaN throughout), which
    saves looking for NaN again; None: look.

    Raises:
        InvalidInputError: The odometry reports no turn rate and, on a forklift, no steering
            angle either: the turn rate must then come from the IMU's gyro.
    """
    if not odometry.time.size:
        return odometry.yaw_rate
    if columns is None:
        reports_yaw_rate = odometry.reports_yaw_rate
        reports_steer = not np.isnan(odometry.steer).any()
    else:
        reports_yaw_rate, reports_steer = bool(columns & _YAW_RATE), bool(columns & _STEER)
    if reports_yaw_rate:
        return odometry.yaw_rate
    if vehicle == FORKLIFT and reports_steer:
        return yaw_rates(odometry.speed, odometry.steer, wheelbase)
    if vehicle == DIFFERENTIAL_DRIVE and reports_steer:
        raise InvalidInputError(
            "vehicle='differential-drive' turns at the odometry's yaw_rate, but this odometry "
            "reports a steering angle instead: set vehicle='forklift', or take the turn rate "
            "from the IMU (yaw_source='gyro')")
    raise InvalidInputError(
        "the odometry reports neither a yaw_rate nor a steering angle: take the turn rate "
        "from the IMU (yaw_source='gyro')")


def advance(pose: tuple[float, float, float], speed: float, yaw_rate: float, ahead: float,
            dt: float) -> tuple[float, float, float]:
    """Move a point ``ahead`` of the reference axle for ``dt`` at constant speed and yaw rate.

    Its velocity is v along the heading and ω·ahead across it, taken at the midpoint heading
    (second-order accurate in dt).
    """
    x, y, heading = pose
    middle = heading + 0.5 * yaw_rate * dt
    c, s = math.cos(middle), math.sin(middle)
    across = yaw_rate * ahead
    return (x + (speed * c - across * s) * dt, y + (speed * s + across * c) * dt,
            wrap_scalar(heading + yaw_rate * dt))


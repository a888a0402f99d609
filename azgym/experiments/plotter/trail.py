"""Plotter's simulated motion (Dang et al. 2015, Sec. V-A): a square trail and its sensor data.

The phone moves round a 0.22 m square in the x-y plane, starting at a corner at rest; on each
edge it accelerates uniformly for half the edge and decelerates for the other half, so it stops
at every corner. Its heading stays fixed (it translates, as the paper's phone does). The IMU is
azgym's (:class:`azgym.sensing.motion.Imu`) with the paper's noise (``ImuModel.plotter()``: 26 Hz,
accelerometer variance 0.011 (m/s²)², orientation variance 0.235 deg²), sampled from the exact
motion. The paper's observation (camera key points) is replaced by azimuths to beacons around
the trail (:func:`beacon_ring`), which the trackers localize with ransac each frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from azgym.core import BeaconMap, FloatArray
from azgym.sensing.motion import Imu, ImuModel, ImuSamples

__all__ = ["CAMERA_HZ", "LAP", "SIDE", "TrailState", "beacon_ring", "imu_samples", "peak_accel",
           "trail_state"]

SIDE = 0.22
"""The square's side [m] (the paper's 0.22 m × 0.22 m trail)."""
LAP = 10.0
"""Time for one lap [s]: the paper's 10-second runs, taken as one lap of the square."""
CAMERA_HZ = 15.0
"""Camera frames per second (the paper's 15 fps)."""
IMU_STEP = 1.0 / 260.0
"""Step [s] at which the IMU model is offered the true motion (10 offers per 26 Hz sample)."""
_CORNERS = np.array([(0.0, 0.0), (SIDE, 0.0), (SIDE, SIDE), (0.0, SIDE)])


@dataclass(frozen=True)
class TrailState:
    """The true position [m], velocity [m/s] and acceleration [m/s²] at one time, each (2,)."""

    position: FloatArray
    velocity: FloatArray
    accel: FloatArray


def peak_accel(side: float = SIDE, lap: float = LAP) -> float:
    """The acceleration [m/s²] that covers an edge in a quarter lap, stopping at its end."""
    edge = lap / 4.0
    return 4.0 * side / edge ** 2


def trail_state(time: float, side: float = SIDE, lap: float = LAP) -> TrailState:
    """Where the phone is at ``time`` [s] on the square (laps repeat)."""
    edge_time = lap / 4.0
    edge, t = divmod(time % lap, edge_time)
    start, end = _CORNERS[int(edge)] * (side / SIDE), _CORNERS[(int(edge) + 1) % 4] * (side / SIDE)
    direction = (end - start) / side
    a, half = peak_accel(side, lap), 0.5 * edge_time
    if t < half:
        s, v, acc = 0.5 * a * t * t, a * t, a
    else:
        u = edge_time - t
        s, v, acc = side - 0.5 * a * u * u, a * u, -a
    return TrailState(start + s * direction, v * direction, acc * direction)


def imu_samples(duration: float, heading: float, rng: np.random.Generator,
                model: ImuModel | None = None) -> ImuSamples:
    """The IMU's readings over ``duration`` seconds of the trail, the phone at ``heading``."""
    imu = Imu(model or ImuModel.plotter(), rng)
    c, s = math.cos(heading), math.sin(heading)
    for k in range(1, int(round(duration / IMU_STEP)) + 1):
        time = k * IMU_STEP
        ax, ay = trail_state(time).accel
        imu.update(time, 0.0, (c * ax + s * ay, -s * ax + c * ay), heading)
    return imu.take()


def beacon_ring(count: int = 6, radius: float = 2.0, height: float = 2.5) -> BeaconMap:
    """Beacons on a circle round the trail's centre, at ceiling height: what the camera sees."""
    angles = np.linspace(0.0, math.tau, count, endpoint=False) + 0.3
    centre = SIDE / 2.0
    xyz = np.column_stack([centre + radius * np.cos(angles), centre + radius * np.sin(angles),
                           np.full(count, height)])
    return BeaconMap(np.arange(1, count + 1), xyz)

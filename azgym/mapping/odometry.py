"""Odometry between frames: the trackers' motion model turned into relative camera poses.

Each frame's motion samples go through the trackers' own steps and prediction
(:class:`~azgym.track.unicycle.MotionSteps`, :func:`~azgym.track.unicycle.predict`), started
from the previous camera pose taken as the origin: the state it ends in is the camera's pose
relative to the previous one, and the covariance it carries is that relative pose's, from the
profile's motion noise (the turn rate's bias and the odometry's scale error counted afresh in
each step, as unknowns of that step). The covariance is then expressed in the relative pose's
own frame, as a factor graph's between factor wants it.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray
from azgym.mapping.problem import Drive, Settings
from azgym.sensing.motion import ImuModel, OdometryModel
from azgym.track.unicycle import IBIAS, ISCALE, STATE_SIZE, MotionSteps, predict

__all__ = ["COVARIANCE_FLOOR", "compose", "relative_poses"]

COVARIANCE_FLOOR = np.array([1e-4, 1e-4, math.radians(0.01)]) ** 2
"""Added to every relative pose's covariance (x, y [m²], heading [rad²]): a frame at the same
time as the previous one (no motion, no noise) must still give an invertible factor."""
PERIOD = 1.0 / OdometryModel().rate_hz
"""Sample period assumed for a motion stream until its samples show their own [s]."""


def relative_poses(drive: Drive, settings: Settings) -> tuple[FloatArray, FloatArray]:
    """Each frame's camera pose relative to the previous frame's, and its covariance.

    Returns:
        (K − 1, 3) relative poses (x, y, heading change) in the previous camera's frame and
        (K − 1, 3, 3) covariances in the relative pose's own frame (the between factor's).
    """
    steps = MotionSteps(PERIOD, settings.turn_source, settings.vehicle,
                        float(settings.wheelbase), float(settings.speed_factor))
    count = len(drive.frames)
    moves = np.zeros((max(count - 1, 0), 3))
    covariances = np.zeros((max(count - 1, 0), 3, 3))
    for k, frame in enumerate(drive.frames):
        frame_steps = steps.steps(frame.motion)
        if k == 0:
            continue
        state = np.zeros(STATE_SIZE)
        cov = np.zeros((STATE_SIZE, STATE_SIZE))
        cov[IBIAS, IBIAS] = ImuModel().gyro_bias ** 2
        cov[ISCALE, ISCALE] = settings.noise.speed_scale ** 2
        for step in frame_steps:
            predict(state, cov, step, settings.lever, settings.noise)
        c, s = math.cos(state[2]), math.sin(state[2])
        turn = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        moves[k - 1] = state[:3]
        covariances[k - 1] = turn @ cov[:3, :3] @ turn.T + np.diag(COVARIANCE_FLOOR)
    return moves, covariances


def compose(start: FloatArray, moves: FloatArray) -> FloatArray:
    """Dead reckoning: the poses reached from ``start`` by the relative ``moves`` in turn."""
    poses = np.zeros((len(moves) + 1, 3))
    poses[0] = start
    for k, (dx, dy, dphi) in enumerate(moves):
        x, y, phi = poses[k]
        c, s = math.cos(phi), math.sin(phi)
        poses[k + 1] = (x + c * dx - s * dy, y + s * dx + c * dy,
                        math.remainder(phi + dphi, 2.0 * math.pi))
    return poses

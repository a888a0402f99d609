"""Odometry between frames: the trackers' motion model turned into relative camera poses.

Each frame's motion samples go through the trackers' own steps and prediction
(:class:`~azgym.track.unicycle.MotionSteps`, :func:`~azgym.track.unicycle.predict`), started
from the previous camera pose taken as the origin: the state it ends in is the camera's pose
relative to the previous one, and the covariance it carries is that relative pose's from the
sensors' white noise and the model's error (the profile's motion noise).

The turn rate's bias and the odometry's scale error are not noise of one frame: they hold from
frame to frame (a 0.005 rad/s gyro bias turns a 2-minute drive by 35°), so counting them afresh
in each frame, as independent unknowns, tells the graph that a drift the azimuths must then
bend the map to absorb averages out. They are the graph's own unknowns instead
(:mod:`azgym.mapping.graph`): each relative pose comes with its derivative with respect to them
(:attr:`Odometry.jacobians`, the pose a bias b and a scale error k give being the pose at zero
plus that derivative times (b, k)), and with how far they wander over the frame
(:attr:`Odometry.walks`). The covariance is expressed in the relative pose's own frame, as a
factor graph's between factor wants it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from azgym.core import FloatArray
from azgym.mapping.problem import Drive, Settings
from azgym.sensing.motion import OdometryModel
from azgym.track.unicycle import IBIAS, ISCALE, STATE_SIZE, MotionNoise, MotionSteps, predict

__all__ = ["COVARIANCE_FLOOR", "Odometry", "compose", "motion_steps", "relative_poses"]

COVARIANCE_FLOOR = np.array([1e-4, 1e-4, math.radians(0.01)]) ** 2
"""Added to every relative pose's covariance (x, y [m²], heading [rad²]): a frame at the same
time as the previous one (no motion, no noise) must still give an invertible factor."""
PERIOD = 1.0 / OdometryModel().rate_hz
"""Sample period assumed for a motion stream until its samples show their own [s]."""
SENSOR_ERRORS = [IBIAS, ISCALE]
"""The state's entries the graph estimates: the turn rate's bias and the odometry's scale error."""


class Odometry(NamedTuple):
    """A drive's relative camera poses, frame to frame (K frames: K − 1 of each).

    Attributes:
        moves: (K − 1, 3) relative poses (x, y, heading change) in the previous camera's frame,
            with no turn-rate bias and no scale error.
        covariances: (K − 1, 3, 3) their covariances in the relative pose's own frame (the
            between factor's), from the white noise and the model's error.
        jacobians: (K − 1, 3, 2) each move's derivative with respect to the turn rate's bias
            [rad/s] and the odometry's scale error [1] at the frame's start.
        walks: (K − 1, 2) how far the bias and the scale error wander over each frame (their
            random walks' standard deviations).
    """

    moves: FloatArray
    covariances: FloatArray
    jacobians: FloatArray
    walks: FloatArray


def motion_steps(settings: Settings) -> MotionSteps:
    """A fresh stepper of the trackers' motion model for one drive, as the settings give it."""
    return MotionSteps(PERIOD, settings.turn_source, settings.vehicle,
                       float(settings.wheelbase), float(settings.speed_factor))


def relative_poses(drive: Drive, settings: Settings) -> Odometry:
    """Each frame's camera pose relative to the previous frame's (:class:`Odometry`)."""
    steps = motion_steps(settings)
    noise = settings.noise
    still = MotionNoise(**{name: 0.0 for name in MotionNoise.__dataclass_fields__})
    count = max(len(drive.frames) - 1, 0)
    found = Odometry(np.zeros((count, 3)), np.zeros((count, 3, 3)), np.zeros((count, 3, 2)),
                     np.zeros((count, 2)))
    for k, frame in enumerate(drive.frames):
        frame_steps = steps.steps(frame.motion)
        if k == 0:
            continue
        state, cov = np.zeros(STATE_SIZE), np.zeros((STATE_SIZE, STATE_SIZE))
        tangent = np.zeros((STATE_SIZE, STATE_SIZE))
        tangent[SENSOR_ERRORS, SENSOR_ERRORS] = 1.0
        for step in frame_steps:
            # the tangent's propagation without noise carries d(pose)/d(bias, scale) in its
            # cross terms (the bias and scale rows of the step's Jacobian are the identity's)
            predict(state.copy(), tangent, step, settings.lever, still)
            predict(state, cov, step, settings.lever, noise)
        c, s = math.cos(state[2]), math.sin(state[2])
        turn = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        seconds = max(frame.time - drive.frames[k - 1].time, 0.0)
        found.moves[k - 1] = state[:3]
        found.covariances[k - 1] = turn @ cov[:3, :3] @ turn.T + np.diag(COVARIANCE_FLOOR)
        found.jacobians[k - 1] = tangent[:3][:, SENSOR_ERRORS]
        found.walks[k - 1] = np.array([noise.bias_walk, noise.scale_walk]) * math.sqrt(seconds)
    return found


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

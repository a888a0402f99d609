"""The factor graph: camera poses and beacon positions, solved with GTSAM.

One ``Pose2`` per frame (the camera's), one ``Point2`` per observable beacon; a between factor
per pair of consecutive frames (:mod:`azgym.mapping.odometry`); a ``BearingFactor2D`` per
detection, its azimuth the bearing in the camera frame with eq. 1-3's standard deviation at the
first guess's distance, behind a robust loss (Cauchy by default: docs/mapping.md); a prior on
each drive's known start pose and on each anchor. Levenberg-Marquardt solves it, and GTSAM's
marginals give each beacon's covariance. gtsam is imported here only, when a survey runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.errors import require
from azgym.mapping.problem import Settings

__all__ = ["ANCHOR_STD", "START_STD", "Graph", "Solution", "solve"]

START_STD = (0.005, 0.005, math.radians(0.05))
"""Standard deviations of a known start pose (x, y [m], heading [rad]): a dock's survey. The
map is only as well placed as this: a heading off by 0.05° turns a beacon 20 m away by 1.7 cm."""
ANCHOR_STD = 0.002
"""Standard deviation of a surveyed anchor's position [m] (a total station's)."""
MAX_ITERATIONS = 100
"""Levenberg-Marquardt's iteration limit."""


@dataclass(frozen=True, eq=False)
class Graph:
    """The problem, as arrays (built by :mod:`azgym.mapping.survey`).

    Attributes:
        poses: (K, 3) first guesses of every camera pose, drives one after another.
        links: (K', 2) pose indices joined by odometry; ``moves`` (K', 3) and ``move_cov``
            (K', 3, 3) its relative poses and covariances.
        starts: Pose indices with a known pose, and ``start_poses`` (S, 3) those poses.
        beacons: (B, 2) first guesses of the beacons; ``anchors`` the indices held by a prior
            at their guess.
        rows: (D, 2) the detections' pose and beacon indices; ``azimuths`` (D,) and ``sigmas``
            (D,) their azimuths and standard deviations [rad].
    """

    poses: FloatArray
    links: IntArray
    moves: FloatArray
    move_cov: FloatArray
    starts: IntArray
    start_poses: FloatArray
    beacons: FloatArray
    anchors: IntArray
    rows: IntArray
    azimuths: FloatArray
    sigmas: FloatArray


@dataclass(frozen=True, eq=False)
class Solution:
    """What the solver found.

    Poses (K, 3), beacons (B, 2), their covariances (B, 2, 2), each detection's residual
    [rad] (D,) and Levenberg-Marquardt's iterations.
    """

    poses: FloatArray
    beacons: FloatArray
    covariances: FloatArray
    residuals: FloatArray
    iterations: int


def solve(graph: Graph, settings: Settings) -> Solution:
    """Build the graph in GTSAM, solve it, and take each beacon's marginal covariance.

    Raises:
        DependencyNotInstalled: gtsam is missing (``pip install "azgym[mapping]"``).
    """
    require("gtsam", "mapping")
    import gtsam

    factors = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    pose_key = [gtsam.symbol("x", k) for k in range(len(graph.poses))]
    beacon_key = [gtsam.symbol("l", b) for b in range(len(graph.beacons))]
    for k, (x, y, phi) in enumerate(graph.poses.tolist()):
        values.insert(pose_key[k], gtsam.Pose2(x, y, phi))
    for b, (x, y) in enumerate(graph.beacons.tolist()):
        values.insert(beacon_key[b], gtsam.Point2(x, y))
    start_noise = gtsam.noiseModel.Diagonal.Sigmas(np.array(START_STD))
    for k, pose in zip(graph.starts.tolist(), graph.start_poses.tolist(), strict=True):
        factors.add(gtsam.PriorFactorPose2(pose_key[k], gtsam.Pose2(*pose), start_noise))
    anchor_noise = gtsam.noiseModel.Isotropic.Sigma(2, ANCHOR_STD)
    for b in graph.anchors.tolist():
        factors.add(gtsam.PriorFactorPoint2(beacon_key[b], gtsam.Point2(*graph.beacons[b]),
                                            anchor_noise))
    for (i, j), move, cov in zip(graph.links.tolist(), graph.moves, graph.move_cov, strict=True):
        factors.add(gtsam.BetweenFactorPose2(pose_key[i], pose_key[j], gtsam.Pose2(*move),
                                             gtsam.noiseModel.Gaussian.Covariance(cov)))
    loss = _loss(gtsam, settings)
    for (k, b), azimuth, sigma in zip(graph.rows.tolist(), graph.azimuths.tolist(),
                                      graph.sigmas.tolist(), strict=True):
        noise = gtsam.noiseModel.Robust.Create(loss, gtsam.noiseModel.Isotropic.Sigma(1, sigma))
        factors.add(gtsam.BearingFactor2D(pose_key[k], beacon_key[b], gtsam.Rot2(azimuth),
                                          noise))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(MAX_ITERATIONS)
    optimizer = gtsam.LevenbergMarquardtOptimizer(factors, values, params)
    result = optimizer.optimize()
    poses = np.array([[p.x(), p.y(), p.theta()] for p in
                      (result.atPose2(key) for key in pose_key)]).reshape(-1, 3)
    beacons = np.array([result.atPoint2(key) for key in beacon_key]).reshape(-1, 2)
    covariances = np.full((len(beacon_key), 2, 2), np.nan)
    if beacon_key:
        marginals = gtsam.Marginals(factors, result)
        for b, key in enumerate(beacon_key):
            covariances[b] = marginals.marginalCovariance(key)
    return Solution(poses, beacons, covariances, residuals(poses, beacons, graph),
                    int(optimizer.iterations()))


def residuals(poses: FloatArray, beacons: FloatArray, graph: Graph) -> FloatArray:
    """Each detection's measured minus predicted azimuth, wrapped [rad]."""
    if graph.rows.size == 0:
        return np.zeros(0)
    pose = poses[graph.rows[:, 0]]
    point = beacons[graph.rows[:, 1]]
    predicted = np.arctan2(point[:, 1] - pose[:, 1], point[:, 0] - pose[:, 0]) - pose[:, 2]
    return np.remainder(graph.azimuths - predicted + math.pi, 2.0 * math.pi) - math.pi


def _loss(gtsam: Any, settings: Settings) -> Any:
    """The robust loss of the azimuth factors, at ``loss_scale`` standard deviations."""
    estimators = {"cauchy": gtsam.noiseModel.mEstimator.Cauchy,
                  "huber": gtsam.noiseModel.mEstimator.Huber}
    return estimators[settings.loss].Create(float(settings.loss_scale))

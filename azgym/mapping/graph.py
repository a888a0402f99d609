"""The factor graph: camera poses and beacon positions, solved with GTSAM.

One ``Pose2`` per frame (the camera's), one ``Point2`` per observable beacon; a between factor
per pair of consecutive frames (:mod:`azgym.mapping.odometry`); a ``BearingFactor2D`` per
detection, its azimuth the bearing in the camera frame with eq. 1-3's standard deviation at the
first guess's distance, behind a robust loss (Cauchy by default: docs/mapping.md); a prior on
each drive's known start pose and on each anchor. Levenberg-Marquardt solves it
(:func:`solve`), and GTSAM's marginals give each beacon's covariance (:func:`covariances`), once
the beacons found unobservable after the solve are left out. gtsam is imported here only, when
a survey runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.errors import InvalidInputError, require
from azgym.mapping.problem import Settings

__all__ = ["ANCHOR_STD", "START_STD", "Graph", "Solution", "covariances", "residuals",
           "solve"]

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

    Poses (K, 3), beacons (B, 2), each detection's residual [rad] (D,) and
    Levenberg-Marquardt's iterations.
    """

    poses: FloatArray
    beacons: FloatArray
    residuals: FloatArray
    iterations: int


def solve(graph: Graph, settings: Settings) -> Solution:
    """Build the graph in GTSAM and solve it.

    Raises:
        DependencyNotInstalled: gtsam is missing (``pip install "azgym[mapping]"``).
    """
    require("gtsam", "mapping")
    import gtsam

    every = np.ones(len(graph.beacons), dtype=bool)
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(MAX_ITERATIONS)
    optimizer = gtsam.LevenbergMarquardtOptimizer(
        _factors(gtsam, graph, settings, every), _values(gtsam, graph.poses, graph.beacons, every),
        params)
    result = optimizer.optimize()
    poses = np.array([[p.x(), p.y(), p.theta()] for p in
                      (result.atPose2(_pose_key(gtsam, k)) for k in range(len(graph.poses)))]
                     ).reshape(-1, 3)
    beacons = np.array([result.atPoint2(_beacon_key(gtsam, b))
                        for b in range(len(graph.beacons))]).reshape(-1, 2)
    return Solution(poses, beacons, residuals(poses, beacons, graph),
                    int(optimizer.iterations()))


def covariances(graph: Graph, solution: Solution, settings: Settings,
                kept: np.ndarray) -> FloatArray:
    """GTSAM's marginal covariance (B, 2, 2) of each ``kept`` beacon at ``solution``.

    The beacons not kept (found unobservable once solved) and their azimuths are left out of
    the graph first: a beacon whose rays no longer spread leaves it indeterminate. Theirs are
    NaN.

    Raises:
        InvalidInputError: The graph is indeterminate even so (GTSAM's message quoted).
    """
    import gtsam

    found = np.full((len(graph.beacons), 2, 2), np.nan)
    if not kept.any():
        return found
    try:
        marginals = gtsam.Marginals(
            _factors(gtsam, graph, settings, kept),
            _values(gtsam, solution.poses, solution.beacons, kept))
    except RuntimeError as error:
        raise InvalidInputError(
            "the survey's solved graph is indeterminate, so its covariances are unknown: "
            + " ".join(str(error).split())) from None
    for b in np.flatnonzero(kept).tolist():
        found[b] = marginals.marginalCovariance(_beacon_key(gtsam, b))
    return found


def _pose_key(gtsam: Any, k: int) -> int:
    """The GTSAM key of camera pose ``k``."""
    return int(gtsam.symbol("x", k))


def _beacon_key(gtsam: Any, b: int) -> int:
    """The GTSAM key of beacon ``b``."""
    return int(gtsam.symbol("l", b))


def _values(gtsam: Any, poses: FloatArray, beacons: FloatArray, kept: np.ndarray) -> Any:
    """Every camera pose and each kept beacon as GTSAM values."""
    values = gtsam.Values()
    for k, (x, y, phi) in enumerate(poses.tolist()):
        values.insert(_pose_key(gtsam, k), gtsam.Pose2(x, y, phi))
    for b in np.flatnonzero(kept).tolist():
        values.insert(_beacon_key(gtsam, b), gtsam.Point2(*beacons[b]))
    return values


def _factors(gtsam: Any, graph: Graph, settings: Settings, kept: np.ndarray) -> Any:
    """The factor graph (module docstring), with the azimuths and anchors of kept beacons."""
    factors = gtsam.NonlinearFactorGraph()
    start_noise = gtsam.noiseModel.Diagonal.Sigmas(np.array(START_STD))
    for k, pose in zip(graph.starts.tolist(), graph.start_poses.tolist(), strict=True):
        factors.add(gtsam.PriorFactorPose2(_pose_key(gtsam, k), gtsam.Pose2(*pose),
                                           start_noise))
    anchor_noise = gtsam.noiseModel.Isotropic.Sigma(2, ANCHOR_STD)
    for b in graph.anchors.tolist():
        if kept[b]:
            factors.add(gtsam.PriorFactorPoint2(_beacon_key(gtsam, b),
                                                gtsam.Point2(*graph.beacons[b]), anchor_noise))
    for (i, j), move, cov in zip(graph.links.tolist(), graph.moves, graph.move_cov, strict=True):
        factors.add(gtsam.BetweenFactorPose2(_pose_key(gtsam, i), _pose_key(gtsam, j),
                                             gtsam.Pose2(*move),
                                             gtsam.noiseModel.Gaussian.Covariance(cov)))
    loss = _loss(gtsam, settings)
    for (k, b), azimuth, sigma in zip(graph.rows.tolist(), graph.azimuths.tolist(),
                                      graph.sigmas.tolist(), strict=True):
        if kept[b]:
            noise = gtsam.noiseModel.Robust.Create(loss,
                                                   gtsam.noiseModel.Isotropic.Sigma(1, sigma))
            factors.add(gtsam.BearingFactor2D(_pose_key(gtsam, k), _beacon_key(gtsam, b),
                                              gtsam.Rot2(azimuth), noise))
    return factors


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

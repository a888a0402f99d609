"""The factor graph: camera poses and beacon positions, solved with GTSAM.

One ``Pose2`` per frame (the camera's), one ``Point2`` per observable beacon; per pair of
consecutive frames an odometry factor (:func:`~azgym.mapping.factors.odometry_error`: the
relative pose :mod:`azgym.mapping.odometry` integrated, corrected by that frame's turn-rate bias
and odometry scale error, themselves unknowns: a 2-vector per frame, held near the previous
frame's by their random walks and near zero at a drive's start by the sensors' spread); a
``BearingFactor2D`` per detection, its azimuth the bearing in the camera frame with eq. 1-3's
standard deviation at the first guess's distance, behind a robust loss (Cauchy by default:
docs/mapping.md); a prior on each drive's known start pose and on each anchor; a prior on each
beacon of a site's map given as the survey's prior, at its map position with the map's accuracy
and behind the same robust loss, so that a moved beacon breaks away (:func:`left_out` gives its
position without it). The factors themselves are built by :mod:`azgym.mapping.factors`.
Levenberg-Marquardt solves it (:func:`solve`), from poses the drives solved frame by frame give
(:class:`Sweep`), and GTSAM's marginals give each beacon's covariance (:func:`covariances`),
once the beacons found unobservable after the solve are left out. gtsam is imported only when a
survey runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.errors import InvalidInputError, require
from azgym.mapping.factors import (
    anchor,
    beacon_key,
    bearing,
    between,
    map_prior,
    odometry_error,
    pose_key,
    robust_loss,
    sensor_key,
)
from azgym.mapping.first_guess import azimuth_residuals
from azgym.mapping.odometry import Odometry
from azgym.mapping.problem import Drive, Settings

__all__ = ["START_STD", "Graph", "Solution", "covariances", "left_out",
           "residuals", "skeleton", "solve"]

START_STD = (0.005, 0.005, math.radians(0.05))
"""Standard deviations of a known start pose (x, y [m], heading [rad]): a dock's survey. The
map is only as well placed as this: a heading off by 0.05° turns a beacon 20 m away by 1.7 cm."""
WALK_FLOOR = 1e-6
"""Least standard deviation of the sensor errors at a drive's start and of their change between
links: a profile without such an error, or two frames at the same time, must still give an
invertible factor."""
MAX_ITERATIONS = 100
"""Levenberg-Marquardt's iteration limit, per solve."""
RELINEARIZATIONS = 4
"""Most solves with the odometry linearized about the previous solve's answer."""
SETTLED = 1e-4
"""A relinearization moving no pose or beacon coordinate more than this [m, rad] ends them."""


@dataclass(frozen=True, eq=False)
class Graph:
    """The problem, as arrays (built by :mod:`azgym.mapping.survey`).

    Attributes:
        poses: (K, 3) first guesses of every camera pose, drives one after another.
        links: (K', 2) pose indices joined by odometry; ``moves`` (K', 3) and ``move_cov``
            (K', 3, 3) its relative poses and covariances, ``move_jac`` (K', 3, 2) their
            derivatives with respect to the link's turn-rate bias and scale error, ``walks``
            (K', 2) how far those wander over the link (:class:`~azgym.mapping.odometry.Odometry`).
        sensor_std: (2,) spread of the turn-rate bias [rad/s] and the scale error [1] at a
            drive's start.
        starts: Pose indices with a known pose, and ``start_poses`` (S, 3) those poses.
        beacons: (B, 2) first guesses of the beacons; ``anchors`` the indices held by a prior
            at their guess.
        priors: Indices of the beacons a site's map holds
            (:attr:`~azgym.mapping.problem.Prior.mapped`), and ``prior_xy`` (P, 2) their map
            positions.
        rows: (D, 2) the detections' pose and beacon indices; ``azimuths`` (D,) and ``sigmas``
            (D,) their azimuths and standard deviations [rad].
    """

    poses: FloatArray
    links: IntArray
    moves: FloatArray
    move_cov: FloatArray
    move_jac: FloatArray
    walks: FloatArray
    sensor_std: FloatArray
    starts: IntArray
    start_poses: FloatArray
    beacons: FloatArray
    anchors: IntArray
    priors: IntArray
    prior_xy: FloatArray
    rows: IntArray
    azimuths: FloatArray
    sigmas: FloatArray


@dataclass(frozen=True, eq=False)
class Solution:
    """What the solver found.

    Poses (K, 3), beacons (B, 2), each link's turn-rate bias and scale error (K', 2), each
    detection's residual [rad] (D,) and Levenberg-Marquardt's iterations.
    """

    poses: FloatArray
    beacons: FloatArray
    sensors: FloatArray
    residuals: FloatArray
    iterations: int


def skeleton(drives: list[Drive], offsets: IntArray, odometry: list[Odometry],
              poses: FloatArray, settings: Settings) -> Graph:
    """The graph's poses, odometry and start priors (drives from ``offsets``); no beacon yet."""
    links = np.concatenate([np.column_stack([np.arange(o, o + len(m)), np.arange(o + 1,
                                                                              o + len(m) + 1)])
                            for o, m in zip(offsets[:-1], (o.moves for o in odometry),
                                            strict=True)])
    return Graph(
        poses=poses, links=links.astype(np.int64),
        moves=np.concatenate([o.moves for o in odometry]).reshape(-1, 3),
        move_cov=np.concatenate([o.covariances for o in odometry]).reshape(-1, 3, 3),
        move_jac=np.concatenate([o.jacobians for o in odometry]).reshape(-1, 3, 2),
        walks=np.concatenate([o.walks for o in odometry]).reshape(-1, 2),
        sensor_std=np.array([settings.turn_rate_bias, settings.noise.speed_scale]),
        starts=np.array([o for o, d in zip(offsets[:-1], drives, strict=True)
                         if d.start is not None], dtype=np.int64),
        start_poses=np.array([d.start for d in drives if d.start is not None]).reshape(-1, 3),
        beacons=np.zeros((0, 2)), anchors=np.zeros(0, np.int64), priors=np.zeros(0, np.int64),
        prior_xy=np.zeros((0, 2)), rows=np.zeros((0, 2), np.int64), azimuths=np.zeros(0),
        sigmas=np.zeros(0))


def solve(graph: Graph, settings: Settings) -> Solution:
    """Build the graph in GTSAM and solve it.

    First with a between factor per link whose covariance counts the sensor errors' spread
    afresh (no sensor error to estimate: a start near the answer), then with the odometry
    linearized about the previous answer and the sensor errors estimated, until a solve moves
    nothing by more than :data:`SETTLED` (at most :data:`RELINEARIZATIONS` times).

    Raises:
        DependencyNotInstalled: gtsam is missing (``pip install "azgym[mapping]"``).
    """
    require("gtsam", "mapping")
    import gtsam

    every = np.ones(len(graph.beacons), dtype=bool)
    solution = Solution(graph.poses, graph.beacons, np.zeros((len(graph.links), 2)),
                        np.zeros(0), 0)
    iterations = 0
    fixed = _fixed(gtsam, graph, settings, every)
    for stage in range(1 + RELINEARIZATIONS):
        about = solution if stage else None
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(MAX_ITERATIONS)
        optimizer = gtsam.LevenbergMarquardtOptimizer(
            _factors(gtsam, graph, fixed, about),
            _values(gtsam, solution, every, stage > 0), params)
        result = optimizer.optimize()
        iterations += int(optimizer.iterations())
        solution = _read(gtsam, result, graph, iterations)
        if about is not None and _settled(about, solution):
            break
    return solution


def _read(gtsam: Any, result: Any, graph: Graph, iterations: int) -> Solution:
    """The solution in GTSAM's ``result``."""
    poses = np.array([[p.x(), p.y(), p.theta()] for p in
                      (result.atPose2(pose_key(gtsam, k)) for k in range(len(graph.poses)))]
                     ).reshape(-1, 3)
    beacons = np.array([result.atPoint2(beacon_key(gtsam, b))
                        for b in range(len(graph.beacons))]).reshape(-1, 2)
    sensors = np.array([result.atVector(sensor_key(gtsam, k)) if result.exists(
        sensor_key(gtsam, k)) else np.zeros(2) for k in range(len(graph.links))]).reshape(-1, 2)
    return Solution(poses, beacons, sensors, residuals(poses, beacons, graph), iterations)


def _settled(previous: Solution, solution: Solution) -> bool:
    """Whether relinearizing moved no pose nor beacon by more than :data:`SETTLED`."""
    moved = np.concatenate([np.abs(solution.poses - previous.poses).ravel(),
                            np.abs(solution.beacons - previous.beacons).ravel()])
    return bool(moved.size == 0 or moved.max() < SETTLED)


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
            _factors(gtsam, graph, _fixed(gtsam, graph, settings, kept), solution),
            _values(gtsam, solution, kept, True))
    except RuntimeError as error:
        raise InvalidInputError(
            "the survey's solved graph is indeterminate, so its covariances are unknown: "
            + " ".join(str(error).split())) from None
    for b in np.flatnonzero(kept).tolist():
        found[b] = marginals.marginalCovariance(beacon_key(gtsam, b))
    return found


def _values(gtsam: Any, solution: Solution, kept: np.ndarray, sensors: bool) -> Any:
    """``solution``'s camera poses, kept beacons and, with ``sensors``, sensor errors."""
    values = _pose_values(gtsam, solution, sensors)
    for b in np.flatnonzero(kept).tolist():
        values.insert(beacon_key(gtsam, b), gtsam.Point2(*solution.beacons[b]))
    return values


def _pose_values(gtsam: Any, solution: Solution, sensors: bool) -> Any:
    """``solution``'s camera poses and, with ``sensors``, sensor errors as GTSAM values."""
    values = gtsam.Values()
    for k, (x, y, phi) in enumerate(solution.poses.tolist()):
        values.insert(pose_key(gtsam, k), gtsam.Pose2(x, y, phi))
    for k, errors in enumerate(solution.sensors if sensors else ()):
        values.insert(sensor_key(gtsam, k), errors)
    return values


def _factors(gtsam: Any, graph: Graph, fixed: Any, about: Solution | None) -> Any:
    """The factor graph (module docstring): the ``fixed`` factors (:func:`_fixed`), odometry.

    The odometry is linearized ``about`` a solution (:func:`_add_odometry`), or, without one,
    a between factor per link at zero sensor errors whose covariance counts their spread afresh
    in each link (the first solve, whose answer the linearization starts from).
    """
    factors = gtsam.NonlinearFactorGraph()
    factors.push_back(fixed)
    if about is None:
        for k, (i, j) in enumerate(graph.links.tolist()):
            factors.add(between(gtsam, i, j, graph.moves[k], graph.move_cov[k],
                                 graph.move_jac[k], graph.sensor_std))
    else:
        _add_odometry(gtsam, factors, graph, about)
    return factors


def _fixed(gtsam: Any, graph: Graph, settings: Settings, kept: np.ndarray) -> Any:
    """The factors no solve changes: start priors, the ``kept`` beacons' anchors and azimuths."""
    factors = gtsam.NonlinearFactorGraph()
    start_noise = gtsam.noiseModel.Diagonal.Sigmas(np.array(START_STD))
    for k, pose in zip(graph.starts.tolist(), graph.start_poses.tolist(), strict=True):
        factors.add(gtsam.PriorFactorPose2(pose_key(gtsam, k), gtsam.Pose2(*pose),
                                           start_noise))
    for b in graph.anchors.tolist():
        if kept[b]:
            factors.add(anchor(gtsam, b, graph.beacons[b]))
    loss = robust_loss(gtsam, settings)
    for b, xy in zip(graph.priors.tolist(), graph.prior_xy, strict=True):
        if kept[b]:
            factors.add(map_prior(gtsam, loss, settings, b, xy))
    for (k, b), azimuth, sigma in zip(graph.rows.tolist(), graph.azimuths.tolist(),
                                      graph.sigmas.tolist(), strict=True):
        if kept[b]:
            factors.add(bearing(gtsam, loss, k, b, azimuth, sigma))
    return factors


def left_out(graph: Graph, solution: Solution, settings: Settings,
             covariances: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Each map-held beacon's position and covariance as the rest of the graph puts it.

    That is without its own map prior (leave-its-prior-out), so that testing it against the map
    neither calls it moved by its prior's pull nor misses a move because of it. In the
    linearized graph the beacon's marginal information Σ⁻¹ is what the rest gives, A, plus its
    prior's, w I / σ² (σ the map's accuracy, w the robust loss's weight at the prior's residual,
    as GTSAM weighs it), and its position x the information-weighted mean of the rest's x₀ and
    the map's m: A = Σ⁻¹ − w I / σ², x₀ = m + A⁻¹ Σ⁻¹ (x − m).

    Args:
        graph: The graph solved (its ``priors`` and ``prior_xy``).
        solution: Its solution.
        settings: The map's accuracy and the loss.
        covariances: (B, 2, 2) the beacons' marginal covariances at ``solution``
            (:func:`covariances`; NaN: not kept).

    Returns:
        Per entry of ``graph.priors``, the position (P, 2) and covariance (P, 2, 2); NaN where
        the beacon was not kept or the rest leaves it indeterminate (A not positive definite).
    """
    import gtsam

    loss = robust_loss(gtsam, settings)
    positions = np.full((len(graph.priors), 2), np.nan)
    found = np.full((len(graph.priors), 2, 2), np.nan)
    for n, (b, xy) in enumerate(zip(graph.priors.tolist(), graph.prior_xy, strict=True)):
        if not np.isfinite(covariances[b]).all():
            continue
        offset = solution.beacons[b] - xy
        weight = float(loss.weight(math.hypot(*offset) / settings.map_sigma))
        information = np.linalg.inv(covariances[b])
        rest = information - weight / settings.map_sigma**2 * np.eye(2)
        rest = 0.5 * (rest + rest.T)
        if np.linalg.eigvalsh(rest)[0] <= 0.0:
            continue
        found[n] = np.linalg.inv(rest)
        positions[n] = xy + found[n] @ information @ offset
    return positions, found


def _add_odometry(gtsam: Any, factors: Any, graph: Graph, about: Solution) -> None:
    """Each link's odometry factor linearized ``about`` a solution, and its sensor errors' walk.

    The sensor errors are held near zero at a drive's start (``sensor_std``), else near the
    previous link's (their random walk over the link, ``walks``).

    :func:`~azgym.mapping.factors.odometry_error`'s first-order expansion about the solution's
    poses and sensor errors (GTSAM's linear container: a Jacobian factor, whitened by the link's
    covariance, held at its linearization point): GTSAM's Python custom factors would hand the
    whole set of values to Python at each evaluation, a cost growing with the square of the
    drive's length.
    """
    start_noise = gtsam.noiseModel.Diagonal.Sigmas(np.maximum(graph.sensor_std, WALK_FLOOR))
    zero = np.zeros(2)
    point = _pose_values(gtsam, about, True)
    unit = gtsam.noiseModel.Unit.Create(3)
    for k, (i, j) in enumerate(graph.links.tolist()):
        keys = [pose_key(gtsam, i), pose_key(gtsam, j), sensor_key(gtsam, k)]
        found, derivatives = odometry_error(
            gtsam, gtsam.Pose2(*about.poses[i]), gtsam.Pose2(*about.poses[j]),
            about.sensors[k], graph.moves[k], graph.move_jac[k])
        whiten = np.linalg.inv(np.linalg.cholesky(graph.move_cov[k]))
        linear = gtsam.JacobianFactor(keys[0], whiten @ derivatives[0], keys[1],
                                      whiten @ derivatives[1], keys[2], whiten @ derivatives[2],
                                      -(whiten @ found), unit)
        factors.add(gtsam.LinearContainerFactor(linear, point))
        if k == 0 or graph.links[k - 1, 1] != i:  # a drive's first link
            factors.add(gtsam.PriorFactorVector(keys[2], zero, start_noise))
        else:
            walk = gtsam.noiseModel.Diagonal.Sigmas(np.maximum(graph.walks[k], WALK_FLOOR))
            factors.add(gtsam.BetweenFactorVector(sensor_key(gtsam, k - 1), keys[2], zero,
                                                  walk))


def residuals(poses: FloatArray, beacons: FloatArray, graph: Graph) -> FloatArray:
    """Each detection's measured minus predicted azimuth, wrapped [rad]."""
    if graph.rows.size == 0:
        return np.zeros(0)
    return azimuth_residuals(poses[graph.rows[:, 0]], beacons[graph.rows[:, 1]], graph.azimuths)

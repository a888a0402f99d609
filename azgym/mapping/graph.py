"""The factor graph: camera poses and beacon positions, solved with GTSAM.

One ``Pose2`` per frame (the camera's), one ``Point2`` per observable beacon; per pair of
consecutive frames an odometry factor (:func:`odometry_error`: the relative pose
:mod:`azgym.mapping.odometry` integrated, corrected by that frame's turn-rate bias and odometry
scale error, themselves unknowns: a 2-vector per frame, held near the previous frame's by their
random walks and near zero at a drive's start by the sensors' spread); a ``BearingFactor2D`` per
detection, its azimuth the bearing in the camera frame with eq. 1-3's standard deviation at the
first guess's distance, behind a robust loss (Cauchy by default: docs/mapping.md); a prior on
each drive's known start pose and on each anchor. Levenberg-Marquardt solves it
(:func:`solve`), from poses the drives solved frame by frame give (:class:`Sweep`), and GTSAM's
marginals give each beacon's covariance (:func:`covariances`), once the beacons found
unobservable after the solve are left out. gtsam is imported here only, when a survey runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.errors import InvalidInputError, require
from azgym.mapping.odometry import Odometry
from azgym.mapping.problem import Drive, Settings

__all__ = ["ANCHOR_STD", "START_STD", "Graph", "Solution", "covariances", "odometry_error",
           "residuals", "skeleton", "solve"]

START_STD = (0.005, 0.005, math.radians(0.05))
"""Standard deviations of a known start pose (x, y [m], heading [rad]): a dock's survey. The
map is only as well placed as this: a heading off by 0.05° turns a beacon 20 m away by 1.7 cm."""
ANCHOR_STD = 0.002
"""Standard deviation of a surveyed anchor's position [m] (a total station's)."""
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
        beacons=np.zeros((0, 2)), anchors=np.zeros(0, np.int64), rows=np.zeros((0, 2), np.int64),
        azimuths=np.zeros(0), sigmas=np.zeros(0))


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
                      (result.atPose2(_pose_key(gtsam, k)) for k in range(len(graph.poses)))]
                     ).reshape(-1, 3)
    beacons = np.array([result.atPoint2(_beacon_key(gtsam, b))
                        for b in range(len(graph.beacons))]).reshape(-1, 2)
    sensors = np.array([result.atVector(_sensor_key(gtsam, k)) if result.exists(
        _sensor_key(gtsam, k)) else np.zeros(2) for k in range(len(graph.links))]).reshape(-1, 2)
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
        found[b] = marginals.marginalCovariance(_beacon_key(gtsam, b))
    return found


def _pose_key(gtsam: Any, k: int) -> int:
    """The GTSAM key of camera pose ``k``."""
    return int(gtsam.symbol("x", k))


def _beacon_key(gtsam: Any, b: int) -> int:
    """The GTSAM key of beacon ``b``."""
    return int(gtsam.symbol("l", b))


def _sensor_key(gtsam: Any, k: int) -> int:
    """The GTSAM key of link ``k``'s turn-rate bias and scale error."""
    return int(gtsam.symbol("s", k))


def _values(gtsam: Any, solution: Solution, kept: np.ndarray, sensors: bool) -> Any:
    """``solution``'s camera poses, kept beacons and, with ``sensors``, sensor errors."""
    values = _pose_values(gtsam, solution, sensors)
    for b in np.flatnonzero(kept).tolist():
        values.insert(_beacon_key(gtsam, b), gtsam.Point2(*solution.beacons[b]))
    return values


def _pose_values(gtsam: Any, solution: Solution, sensors: bool) -> Any:
    """``solution``'s camera poses and, with ``sensors``, sensor errors as GTSAM values."""
    values = gtsam.Values()
    for k, (x, y, phi) in enumerate(solution.poses.tolist()):
        values.insert(_pose_key(gtsam, k), gtsam.Pose2(x, y, phi))
    for k, errors in enumerate(solution.sensors if sensors else ()):
        values.insert(_sensor_key(gtsam, k), errors)
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
            factors.add(_between(gtsam, graph, k, i, j))
    else:
        _add_odometry(gtsam, factors, graph, about)
    return factors


def _fixed(gtsam: Any, graph: Graph, settings: Settings, kept: np.ndarray) -> Any:
    """The factors no solve changes: start priors, the ``kept`` beacons' anchors and azimuths."""
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
    loss = _loss(gtsam, settings)
    for (k, b), azimuth, sigma in zip(graph.rows.tolist(), graph.azimuths.tolist(),
                                      graph.sigmas.tolist(), strict=True):
        if kept[b]:
            factors.add(_bearing(gtsam, loss, k, b, azimuth, sigma))
    return factors


def _between(gtsam: Any, graph: Graph, link: int, first: int, second: int) -> Any:
    """Link ``link``'s between factor at zero sensor errors, their spread counted in it."""
    jacobian = graph.move_jac[link]
    spread = jacobian @ np.diag(graph.sensor_std**2) @ jacobian.T
    return gtsam.BetweenFactorPose2(
        _pose_key(gtsam, first), _pose_key(gtsam, second), gtsam.Pose2(*graph.moves[link]),
        gtsam.noiseModel.Gaussian.Covariance(graph.move_cov[link] + spread))


def _bearing(gtsam: Any, loss: Any, pose: int, beacon: int, azimuth: float,
             sigma: float) -> Any:
    """One detection's bearing factor, behind the robust ``loss``."""
    noise = gtsam.noiseModel.Robust.Create(loss, gtsam.noiseModel.Isotropic.Sigma(1, sigma))
    return gtsam.BearingFactor2D(_pose_key(gtsam, pose), _beacon_key(gtsam, beacon),
                                 gtsam.Rot2(azimuth), noise)


def _add_odometry(gtsam: Any, factors: Any, graph: Graph, about: Solution) -> None:
    """Each link's odometry factor linearized ``about`` a solution, and its sensor errors' walk.

    The sensor errors are held near zero at a drive's start (``sensor_std``), else near the
    previous link's (their random walk over the link, ``walks``).

    :func:`odometry_error`'s first-order expansion about the solution's poses and sensor errors
    (GTSAM's linear container: a Jacobian factor, whitened by the link's covariance, held at its
    linearization point): GTSAM's Python custom factors would hand the whole set of values to
    Python at each evaluation, a cost growing with the square of the drive's length.
    """
    start_noise = gtsam.noiseModel.Diagonal.Sigmas(np.maximum(graph.sensor_std, WALK_FLOOR))
    zero = np.zeros(2)
    point = _pose_values(gtsam, about, True)
    unit = gtsam.noiseModel.Unit.Create(3)
    for k, (i, j) in enumerate(graph.links.tolist()):
        keys = [_pose_key(gtsam, i), _pose_key(gtsam, j), _sensor_key(gtsam, k)]
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
            factors.add(gtsam.BetweenFactorVector(_sensor_key(gtsam, k - 1), keys[2], zero,
                                                  walk))


def odometry_error(gtsam: Any, first: Any, second: Any, sensors: FloatArray, move: FloatArray,
                   jacobian: FloatArray) -> tuple[FloatArray, tuple[FloatArray, ...]]:
    """One link's error and its derivatives with respect to both poses and the sensor errors.

    The odometry says the camera moved by Δ = ``move`` + ``jacobian`` (b, k) (x, y, heading in
    the first camera's frame) given the link's turn-rate bias b and scale error k
    (``sensors``); the poses say it moved by ``first``⁻¹ ``second``. The error is the latter in
    Δ's own frame, Logmap(Δ⁻¹ ``first``⁻¹ ``second``): GTSAM's between factor's, with Δ
    depending on (b, k). A pose's tangent (u, v, w) moves (x, y, θ) by (R(θ) (u, v), w), so
    d(Δ's tangent)/d(b, k) is blockdiag(R(θ)ᵀ, 1) ``jacobian``.

    Args:
        gtsam: The gtsam module.
        first: The first camera pose (``gtsam.Pose2``).
        second: The next one.
        sensors: (b, k) [rad/s, 1].
        move: (3,) the relative pose at zero bias and scale error.
        jacobian: (3, 2) its derivative with respect to (b, k).

    Returns:
        The error (3,) and its derivatives (3, 3), (3, 3), (3, 2) with respect to ``first``,
        ``second`` (their tangents) and ``sensors``.
    """
    x, y, theta = move + jacobian @ sensors
    measured = gtsam.Pose2(x, y, theta)
    d_first, d_second = np.zeros((3, 3), order="F"), np.zeros((3, 3), order="F")
    moved = first.between(second, d_first, d_second)
    d_measured, d_moved = np.zeros((3, 3), order="F"), np.zeros((3, 3), order="F")
    found = measured.localCoordinates(moved, d_measured, d_moved)
    c, s = math.cos(theta), math.sin(theta)
    tangent = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return np.asarray(found).reshape(3), (d_moved @ d_first, d_moved @ d_second,
                                          d_measured @ tangent @ jacobian)


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

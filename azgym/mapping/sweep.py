"""The drives solved frame by frame (GTSAM's iSAM2): the batch solve's first guess.

Dead reckoning drifts without bound, and the batch solve (:mod:`azgym.mapping.graph`) started
from it falls into a wrong minimum; :class:`Sweep` keeps every pose and beacon near where the
azimuths put them as it goes. It shares the batch graph's factors
(:mod:`azgym.mapping.factors`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError, require
from azgym.mapping.factors import (
    anchor,
    beacon_key,
    bearing,
    between,
    map_prior,
    pose_key,
    robust_loss,
)
from azgym.mapping.graph import START_STD, Graph
from azgym.mapping.problem import Settings

__all__ = ["GUESS_STD", "PLACED_STD", "Sweep"]

PLACED_STD = (0.5, 0.5, math.radians(5.0))
"""Standard deviations of the first pose of a drive without a known start, where the anchors it
observes placed it (:class:`Sweep`'s first guess only)."""
GUESS_STD = 10.0
"""Standard deviation of a weak prior holding each beacon the sweep places at its first guess
[m]: with the azimuths behind a robust loss, a beacon whose rays the loss then sets aside would
leave the sweep's system indeterminate."""


class Sweep:
    """The drives solved as they go (GTSAM's iSAM2): the batch solve's first guess.

    Dead reckoning drifts without bound (a differential drive's turn-rate bias turns it by
    degrees a second), and the batch solve started from it falls into a wrong minimum. Solved
    frame by frame instead, each new pose starts from the latest estimate of the one before,
    and a beacon joins once its rays from the estimated poses place it (the caller's rule),
    so that neither ever starts far from where the azimuths put it.

    ``graph`` holds the links, moves and start priors (its beacons and detections are not
    read); the caller adds beacons (:meth:`place`), detections (:meth:`observe`) and frames
    (:meth:`extend`), then :meth:`update` folds them in. The ``anchors`` and the beacons a site's
    map holds (``mapped``: held by :func:`~azgym.mapping.factors.map_prior`) are placed from the
    start, at their map positions, so that the map keeps the poses from drifting.
    """

    def __init__(self, graph: Graph, settings: Settings, anchors: dict[int, FloatArray],
                 mapped: dict[int, FloatArray]) -> None:
        require("gtsam", "mapping")
        import gtsam

        self.gtsam, self.graph = gtsam, graph
        self.loss = robust_loss(gtsam, settings)
        self.isam = gtsam.ISAM2(gtsam.ISAM2Params())
        self.factors, self.values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        self.poses = graph.poses.copy()
        self.count = 0
        self.placed: set[int] = set()
        self.next_link = {int(i): k for k, (i, _) in enumerate(graph.links.tolist())}
        self.start = dict(zip(graph.starts.tolist(), graph.start_poses, strict=True))
        for b, xy in anchors.items():
            self.place(b, xy)
            self.factors.add(anchor(gtsam, b, xy))
        for b, xy in mapped.items():
            self._add(b, xy, map_prior(gtsam, self.loss, settings, b, xy))

    def extend(self, count: int) -> None:
        """Add the poses up to (not including) ``count``, each from the one before."""
        gtsam, graph = self.gtsam, self.graph
        for k in range(self.count, count):
            if k in self.start or k - 1 not in self.next_link:
                # a drive's first pose: its known start, else where it was placed (loosely)
                self.poses[k] = self.start.get(k, self.poses[k])
                self.factors.add(gtsam.PriorFactorPose2(
                    pose_key(gtsam, k), gtsam.Pose2(*self.poses[k]),
                    gtsam.noiseModel.Diagonal.Sigmas(np.array(
                        START_STD if k in self.start else PLACED_STD))))
            else:
                link = self.next_link[k - 1]
                pose = gtsam.Pose2(*self.poses[k - 1]).compose(
                    gtsam.Pose2(*graph.moves[link]))
                self.poses[k] = (pose.x(), pose.y(), pose.theta())
                self.factors.add(between(gtsam, k - 1, k, graph.moves[link],
                                         graph.move_cov[link], graph.move_jac[link],
                                         graph.sensor_std))
            self.values.insert(pose_key(gtsam, k), gtsam.Pose2(*self.poses[k]))
        self.count = max(self.count, count)

    def place(self, beacon: int, xy: FloatArray) -> None:
        """Add beacon ``beacon`` at ``xy`` (held there by :data:`GUESS_STD`)."""
        gtsam = self.gtsam
        self._add(beacon, xy, gtsam.PriorFactorPoint2(
            beacon_key(gtsam, beacon), gtsam.Point2(*xy),
            gtsam.noiseModel.Isotropic.Sigma(2, GUESS_STD)))

    def _add(self, beacon: int, xy: FloatArray, held: Any) -> None:
        """Add beacon ``beacon`` at ``xy`` with the factor ``held`` holding it."""
        self.values.insert(beacon_key(self.gtsam, beacon), self.gtsam.Point2(*xy))
        self.factors.add(held)
        self.placed.add(beacon)

    def observe(self, pose: int, beacon: int, azimuth: float, sigma: float) -> None:
        """Add a detection of a placed beacon."""
        self.factors.add(bearing(self.gtsam, self.loss, pose, beacon, azimuth, sigma))

    def update(self) -> None:
        """Fold the new frames, beacons and detections in; the latest pose's estimate read.

        The others keep their first guesses (from an estimate a few frames back) until
        :meth:`estimate`.

        Raises:
            InvalidInputError: GTSAM found the system indeterminate (its message quoted).
        """
        try:
            self.isam.update(self.factors, self.values)
        except RuntimeError as error:
            raise InvalidInputError(
                "the survey's frame-by-frame solve is indeterminate: "
                + " ".join(str(error).split())) from None
        self.factors, self.values = self.gtsam.NonlinearFactorGraph(), self.gtsam.Values()
        if self.count:  # the latest pose, which the next ones start from
            pose = self.isam.calculateEstimatePose2(pose_key(self.gtsam, self.count - 1))
            self.poses[self.count - 1] = (pose.x(), pose.y(), pose.theta())

    def estimate(self) -> FloatArray:
        """Every pose's current estimate (those not yet added: their first guess)."""
        result = self.isam.calculateEstimate()
        for k in range(self.count):
            pose = result.atPose2(pose_key(self.gtsam, k))
            self.poses[k] = (pose.x(), pose.y(), pose.theta())
        return self.poses

"""The algebraic three-beacon solution of Sec. 2.5 as a localizer of its own."""

from __future__ import annotations

import math

import numpy as np

from azgym.core import Estimate
from azgym.hyperparameters import check_range
from azgym.jit import jit
from azgym.localize import _kernels as K
from azgym.localize._circles import distinct_beacons, pair_table, solve_triplet
from azgym.localize.base import Localizer, Problem

__all__ = ["DEGENERACY_TOL", "Triplet"]

DEGENERACY_TOL = 1e-2
"""Triplet's default ``degeneracy_tol``: the smallest normalised determinant it answers from.

Each azimuth enters the circle equations through sin and cos of angle differences, so an error
of δ radians changes the normalised determinant by about δ; with Δα_d = 0.4° (7e-3 rad) a
triplet below 1e-2 could be degenerate up to noise, and its answers were seen metres (up to 20 m)
off. ransac keeps its own, much smaller tolerance: there a triplet is only a candidate, scored by
its supporters and then refined on all of them.
"""


@jit
def _best_triplet(bx, by, ca, sa, beacon_index, degeneracy_tol, pose, chosen):
    """Solve every triplet of distinct beacons; keep the best-conditioned one.

    Writes its pose array (``K.POSE_*`` slots) into ``pose`` and its measurements into ``chosen``;
    returns its quality (``solve_triplet``), −1 when every triplet is degenerate.
    """
    n = bx.size
    rows, ox, oy, scale = pair_table(bx, by, ca, sa)
    best = -1.0
    for i in range(n):
        for j in range(i + 1, n):
            for k in range(j + 1, n):
                if not distinct_beacons(beacon_index[i], beacon_index[j], beacon_index[k]):
                    continue
                ok, x, y, hx, hy, quality = solve_triplet(rows, ox, oy, scale, bx, by, ca, sa,
                                                          i, j, k, degeneracy_tol)
                if ok and quality > best:
                    best = quality
                    norm = math.hypot(hx, hy)
                    pose[K.POSE_X] = x
                    pose[K.POSE_Y] = y
                    pose[K.POSE_COS] = hx / norm
                    pose[K.POSE_SIN] = hy / norm
                    chosen[0] = i
                    chosen[1] = j
                    chosen[2] = k
    return best


class Triplet(Localizer):
    """Closed-form pose from three azimuths (eq. 7-20), no redundancy, no refinement.

    With exactly three usable measurements it solves them. With more, it solves every triplet and
    answers with the best-conditioned one (largest normalised determinant), ignoring the rest: the
    minimal-data baseline that shows what redundancy buys.

    A triplet is only as good as its geometry: when its normalised determinant (the
    ``conditioning`` diagnostic is its square) is small, an azimuth error of a few milliradians
    moves the solution by metres, so the localizer refuses (``ok=False``) rather than answer from
    such a triplet.

    Args:
        degeneracy_tol: Triplets whose normalised determinant |det| / Hadamard bound is below this
            are rejected (beacons nearly collinear with the camera, or the camera near their
            circle). The default, DEGENERACY_TOL = 1e-2, is about the relative change an azimuth
            error of Δα_d = 0.4° makes to the determinant: below it the triplet is degenerate
            within the noise.
    """

    name = "triplet"

    def __init__(self, *, degeneracy_tol: float = DEGENERACY_TOL) -> None:
        self.degeneracy_tol = degeneracy_tol
        self._validate_once()

    def _check_params(self) -> None:
        check_range(type(self).__name__, "degeneracy_tol", self.degeneracy_tol, low=0.0,
                    high=1.0)

    def _localize(self, problem: Problem) -> Estimate:
        pose = np.empty(K.POSE_SIZE)
        chosen = np.empty(3, dtype=np.int64)
        quality = _best_triplet(problem.bx, problem.by, problem.cos_az, problem.sin_az,
                                problem.beacon_index, float(self.degeneracy_tol), pose, chosen)
        if quality < 0.0:
            return Estimate.failure(
                f"every triplet is degenerate or ill-conditioned (normalised determinant below "
                f"degeneracy_tol={self.degeneracy_tol:g}: beacons nearly collinear with the "
                "camera, or the camera near their circle)", problem.n_measurements,
            )
        used = np.zeros(problem.size, dtype=bool)
        used[chosen] = True
        return Estimate(
            x=float(pose[K.POSE_X]), y=float(pose[K.POSE_Y]),
            heading=math.atan2(pose[K.POSE_SIN], pose[K.POSE_COS]),
            inliers=problem.expand(used), diagnostics={"conditioning": float(quality)},
        )

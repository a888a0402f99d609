"""Recursive leave-one-out outlier discrimination (Packi & Hanebeck, Sec. III, Fig. 2)."""

from __future__ import annotations

import math

import numpy as np

from azgym.core import Estimate
from azgym.hyperparameters import check_range
from azgym.localize import _kernels as K
from azgym.localize.base import MIN_MEASUREMENTS, Localizer, Problem
from azgym.localize.lsq import fit_subset
from azgym.localize.refinement import refine_estimate
from azgym.site.error_model import ErrorModel

__all__ = ["LeaveOneOut"]


class LeaveOneOut(Localizer):
    """Drop, one at a time, the measurement whose removal lowers the mean squared residual most.

    Each level fits the least-squares pose (:func:`~azgym.localize.lsq.fit_subset`) without each
    remaining measurement in turn, removes the one whose absence gives the smallest quality z (the
    mean squared azimuth residual, eq. 31), and goes one level deeper while z > z_max, more than
    k_min measurements remain and the depth is below r_max (Fig. 2's three exit conditions).

    One deliberate difference from Fig. 2: the full set is tested first, so a frame whose residual
    is already below z_max keeps every measurement (Fig. 2 always removes at least one, which only
    costs accuracy when nothing is wrong).

    Args:
        z_max: Quality threshold [rad²]; None uses Δα_d², three times the variance of the
            centre-detection error.
        k_min: Never go below this many measurements (4: three fit any pose exactly).
        r_max: Maximum recursion depth (measurements removed).
        delta_alpha_d: Δα_d of the error model [rad] (default z_max and the covariance).
        max_iter: Iteration limit of each least-squares fit.
    """

    name = "loo"

    def __init__(
        self,
        *,
        z_max: float | None = None,
        k_min: int = 4,
        r_max: int = 8,
        delta_alpha_d: float = math.radians(0.4),
        max_iter: int = 50,
    ) -> None:
        self.z_max = z_max
        self.k_min = k_min
        self.r_max = r_max
        self.delta_alpha_d = delta_alpha_d
        self.max_iter = max_iter
        self._validate_once()

    def _check_params(self) -> None:
        name = type(self).__name__
        if self.z_max is not None:
            check_range(name, "z_max", self.z_max, low=0.0)
        check_range(name, "k_min", self.k_min, low=MIN_MEASUREMENTS + 1, integer=True)
        check_range(name, "r_max", self.r_max, low=0, integer=True)
        check_range(name, "delta_alpha_d", self.delta_alpha_d, low=0.0, high=math.pi / 2,
                    high_open=True)
        check_range(name, "max_iter", self.max_iter, low=1, integer=True)

    def _localize(self, problem: Problem) -> Estimate:
        z_max = self.delta_alpha_d**2 if self.z_max is None else self.z_max
        args = (problem.bx, problem.by, problem.cos_az, problem.sin_az, problem.beacon_index)
        use = np.ones(problem.size, dtype=np.bool_)
        pose = np.empty(K.POSE_SIZE)
        z = fit_subset(*args, use, self.max_iter, pose)
        removed: list[int] = []
        trial_pose = np.empty(K.POSE_SIZE)
        while (z > z_max or not math.isfinite(z)) and use.sum() > self.k_min \
                and len(removed) < self.r_max:
            best_z, best_m, best_pose = math.inf, -1, pose
            for m in np.flatnonzero(use):
                use[m] = False
                z_m = fit_subset(*args, use, self.max_iter, trial_pose)
                use[m] = True
                if z_m < best_z:
                    best_z, best_m, best_pose = z_m, int(m), trial_pose.copy()
            if best_m < 0:
                break
            use[best_m] = False
            removed.append(int(problem.source[best_m]))
            z, pose = best_z, best_pose
        diagnostics = {"z": float(z), "removed": removed}
        if not math.isfinite(z):
            return Estimate.failure(
                "no subset of the measurements determines the pose", problem.n_measurements,
                diagnostics,
            )
        model = ErrorModel(delta_alpha_d=self.delta_alpha_d)
        return refine_estimate(problem, use, pose, False, self.max_iter, model, diagnostics)

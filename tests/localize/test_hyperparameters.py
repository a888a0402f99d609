"""Every hyperparameter of every built-in localizer is checked where it is written.

A bad value raises :class:`InvalidInputError` naming the class, the field and the problem at
construction (so a typo in a benchmark's contender fails before the run, not deep inside numpy
or numba on the first frame), and again on ``localize`` when it was changed after construction.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from helpers import ideal_frame

from azgym import InvalidInputError
from azgym.localize.loo import LeaveOneOut
from azgym.localize.lsq import LeastSquares
from azgym.localize.mex import Mex
from azgym.localize.ransac import Ransac
from azgym.localize.triplet import Triplet

BAD_PARAMETERS = [
    (Ransac, {"pr_hit": 2}, "Ransac.pr_hit must be in (0, 1)"),
    (Ransac, {"pr_hit": 1.0}, "Ransac.pr_hit"),
    (Ransac, {"p_star": 0.0}, "Ransac.p_star"),
    (Ransac, {"min_inlier_fraction": 1.5}, "Ransac.min_inlier_fraction"),
    (Ransac, {"max_exhaustive": 0}, "Ransac.max_exhaustive"),
    (Ransac, {"max_exhaustive": 10.5}, "Ransac.max_exhaustive must be an integer"),
    (Ransac, {"delta_alpha_d": -0.01}, "Ransac.delta_alpha_d"),
    (Ransac, {"delta_alpha_d": math.nan}, "Ransac.delta_alpha_d must be a finite number"),
    (Ransac, {"degeneracy_tol": 2.0}, "Ransac.degeneracy_tol"),
    (Ransac, {"max_iter": 0}, "Ransac.max_iter"),
    (Ransac, {"max_iter": True}, "Ransac.max_iter must be an integer"),
    (Ransac, {"coverage": "no"}, "Ransac.coverage must be True or False, got 'no'"),
    (Ransac, {"weighted": 1}, "Ransac.weighted must be True or False"),
    (Ransac, {"random_state": "abc"}, "Ransac.random_state must be an integer >= 0, got 'abc'"),
    (Ransac, {"random_state": -1}, "Ransac.random_state must be an integer >= 0, got -1"),
    (Ransac, {"random_state": 1.5}, "Ransac.random_state must be an integer"),
    (Mex, {"step": -1}, "Mex.step"),
    (Mex, {"step": 0}, "Mex.step"),
    (Mex, {"step": "1cm"}, "Mex.step must be a finite number"),
    (Mex, {"n_candidates": 0}, "Mex.n_candidates"),
    (Mex, {"coarse_step": 0.005}, "Mex.coarse_step"),
    (Mex, {"coarse_step": 0.015}, "Mex.coarse_step must be a multiple of step"),
    (Mex, {"coarse_step": 20.0}, "Mex.coarse_step must be at most 1000 steps"),
    (Mex, {"bounds": 5.0}, "Mex.bounds must be (x_min, y_min, x_max, y_max)"),
    (Mex, {"bounds": (0.0, 0.0, 1.0)}, "Mex.bounds must be (x_min, y_min, x_max, y_max)"),
    (Mex, {"bounds": (0.0, math.nan, 1.0, 1.0)}, "Mex.bounds must be a finite number"),
    (Mex, {"bounds": (0.0, 0.0, math.inf, 1.0)}, "Mex.bounds must be a finite number"),
    (Mex, {"bounds": (0.0, "0", 1.0, 1.0)}, "Mex.bounds must be a finite number"),
    (Mex, {"bounds": (1.0, 0.0, 0.0, 1.0)}, "Mex.bounds has max < min"),
    (Mex, {"bounds": (0.0, 1.0, 1.0, 0.0)}, "Mex.bounds has max < min"),
    (Mex, {"bounds": (-1e300, -1e300, 1e300, 1e300)},
     "Mex.step=0.01 is below the floating-point resolution of the grid over bounds"),
    (Mex, {"bounds": (0.0, 0.0, 1e3, 1e3), "step": 1e-3},
     "would have 1e+12 points to evaluate, more than 1e+08"),
    (LeaveOneOut, {"k_min": 2}, "LeaveOneOut.k_min"),
    (LeaveOneOut, {"k_min": 3}, "LeaveOneOut.k_min"),
    (LeaveOneOut, {"k_min": 4.0}, "LeaveOneOut.k_min must be an integer"),
    (LeaveOneOut, {"r_max": -1}, "LeaveOneOut.r_max"),
    (LeaveOneOut, {"z_max": -1e-3}, "LeaveOneOut.z_max"),
    (LeaveOneOut, {"z_max": math.inf}, "LeaveOneOut.z_max must be a finite number"),
    (LeaveOneOut, {"delta_alpha_d": 2.0}, "LeaveOneOut.delta_alpha_d"),
    (LeaveOneOut, {"max_iter": 0}, "LeaveOneOut.max_iter"),
    (LeastSquares, {"max_iter": 0}, "LeastSquares.max_iter"),
    (LeastSquares, {"delta_alpha_d": 2.0}, "LeastSquares.delta_alpha_d"),
    (LeastSquares, {"weighted": "yes"}, "LeastSquares.weighted must be True or False"),
    (LeastSquares, {"coverage": None}, "LeastSquares.coverage must be True or False"),
    (Triplet, {"degeneracy_tol": -1e-9}, "Triplet.degeneracy_tol"),
    (Triplet, {"degeneracy_tol": 1.5}, "Triplet.degeneracy_tol"),
]
CASE_IDS = [f"{cls.__name__}-{params}" for cls, params, _ in BAD_PARAMETERS]


@pytest.mark.parametrize(("cls", "params", "message"), BAD_PARAMETERS, ids=CASE_IDS)
def test_bad_hyperparameters_raise_at_construction(cls, params, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        cls(**params)


@pytest.mark.parametrize(("cls", "params", "message"), BAD_PARAMETERS, ids=CASE_IDS)
def test_hyperparameters_changed_after_construction_are_checked_again(cls, params, message,
                                                                      paper_beacons):
    localizer = cls(bounds=(-1.0, -1.0, 1.0, 1.0)) if cls is Mex else cls()
    for key, value in params.items():
        setattr(localizer, key, value)
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        localizer.localize(ideal_frame(0.0, 0.0, 0.0, paper_beacons), paper_beacons)


@pytest.mark.parametrize("random_state", [None, 0, 7, np.int64(3), np.random.default_rng(1)])
def test_every_documented_random_state_is_accepted(random_state):
    assert Ransac(random_state=random_state).triplets(40).shape == (64, 3)


def test_good_values_at_the_edges_of_their_ranges_are_accepted(paper_beacons):
    frame = ideal_frame(0.5, -0.5, 0.3, paper_beacons)
    for localizer in (Ransac(pr_hit=0.5, p_star=1.0, min_inlier_fraction=1.0, degeneracy_tol=0.0,
                             coverage=np.bool_(False), weighted=True),
                      LeaveOneOut(k_min=4, r_max=0, z_max=0.0, delta_alpha_d=0.0),
                      LeastSquares(weighted=True, coverage=False, max_iter=1000),
                      Triplet(degeneracy_tol=0.0),
                      Mex(step=0.5, coarse_step=1.0, bounds=np.array([-2.0, -2.0, 2.0, 2.0]))):
        assert localizer.localize(frame, paper_beacons).ok, localizer

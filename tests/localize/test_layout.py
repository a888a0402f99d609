"""The packed arrays' named slots: every reader and writer of a slot uses the same name."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import ideal_frame

from azgym.core import Measurements
from azgym.localize import _kernels as K
from azgym.localize import base, ransac
from azgym.localize._levenberg_marquardt import refine
from azgym.localize.base import Problem
from azgym.localize.lsq import algebraic_start


def slots(module, prefix: str) -> dict[str, int]:
    """The module's integer constants named ``prefix...``, without the array's ``..._SIZE``."""
    return {name: value for name, value in vars(module).items()
            if name.startswith(prefix) and not name.endswith("_SIZE") and isinstance(value, int)}


def assert_layout(named: dict[str, int], size: int) -> None:
    """The slots number the array's entries 0 .. size − 1, each exactly once."""
    assert sorted(named.values()) == list(range(size)), named


def test_problem_rows_fill_the_packed_arrays(paper_beacons):
    float_rows = {name: row for name, row in slots(base, "ROW_").items()
                  if name not in ("ROW_SOURCE", "ROW_BEACON_INDEX")}
    assert_layout(float_rows, base.FLOAT_ROWS)
    assert_layout({"ROW_SOURCE": base.ROW_SOURCE, "ROW_BEACON_INDEX": base.ROW_BEACON_INDEX},
                  base.INT_ROWS)
    frame = ideal_frame(1.0, -2.0, 0.3, paper_beacons)
    # Unknown ids in the middle, so source and beacon_index differ from 0 .. K − 1.
    frame = Measurements(np.insert(frame.ids, [2, 5], [901, 902]),
                         np.insert(frame.azimuth, [2, 5], [0.1, 0.2]))
    problem = Problem.from_frame(frame, paper_beacons)
    k = len(paper_beacons)
    assert problem.floats.shape == (base.FLOAT_ROWS, k)
    assert problem.ints.shape == (base.INT_ROWS, k)
    known = ~np.isin(frame.ids, [901, 902])
    rows = paper_beacons.index_of(frame.ids[known])
    np.testing.assert_array_equal(problem.source, np.flatnonzero(known))
    np.testing.assert_array_equal(problem.beacon_index, rows)
    np.testing.assert_array_equal(problem.azimuth, frame.azimuth[known])
    np.testing.assert_array_equal(problem.cos_az, np.cos(frame.azimuth[known]))
    np.testing.assert_array_equal(problem.sin_az, np.sin(frame.azimuth[known]))
    np.testing.assert_array_equal(problem.bx, paper_beacons.xy[rows, 0])
    np.testing.assert_array_equal(problem.by, paper_beacons.xy[rows, 1])
    np.testing.assert_array_equal(problem.width, paper_beacons.width[rows])


def test_refine_writes_every_slot_of_its_output(paper_beacons):
    assert_layout(slots(K, "POSE_"), K.POSE_SIZE)
    assert_layout(slots(K, "POSE_") | slots(K, "REFINED_"), K.REFINED_SIZE)
    problem = Problem.from_frame(ideal_frame(1.0, -2.0, 0.3, paper_beacons), paper_beacons)
    use = np.ones(problem.size, dtype=np.bool_)
    out = np.full(K.REFINED_SIZE, np.nan)
    refine(problem.bx, problem.by, problem.cos_az, problem.sin_az, np.ones(problem.size), use,
           1.2, -1.7, math.cos(0.25), math.sin(0.25), 50, out, np.empty((3, 3)))
    assert np.isfinite(out).all()
    assert out[K.POSE_X] == pytest.approx(1.0, abs=1e-9)
    assert out[K.POSE_Y] == pytest.approx(-2.0, abs=1e-9)
    assert math.atan2(out[K.POSE_SIN], out[K.POSE_COS]) == pytest.approx(0.3, abs=1e-9)
    assert out[K.REFINED_COST] < 1e-20
    assert out[K.REFINED_STATUS] == K.CONVERGED
    assert 1 <= out[K.REFINED_ITERATIONS] < 50


def test_algebraic_start_writes_a_pose_array(paper_beacons):
    problem = Problem.from_frame(ideal_frame(-3.0, 4.0, -2.0, paper_beacons), paper_beacons)
    pose = np.full(K.POSE_SIZE, np.nan)
    assert algebraic_start(problem.bx, problem.by, problem.cos_az, problem.sin_az,
                           problem.beacon_index, np.ones(problem.size, dtype=np.bool_), pose)
    assert (pose[K.POSE_X], pose[K.POSE_Y]) == pytest.approx((-3.0, 4.0), abs=1e-9)
    assert math.atan2(pose[K.POSE_SIN], pose[K.POSE_COS]) == pytest.approx(-2.0, abs=1e-9)


def test_ransac_settings_and_output_slots(paper_beacons):
    assert_layout(slots(ransac, "SETTING_"), ransac.N_SETTINGS)
    assert_layout(slots(K, "POSE_") | slots(K, "REFINED_") | slots(ransac, "OUT_"),
                  ransac.OUT_SIZE)
    localizer = ransac.Ransac(delta_alpha_d=0.01, coverage=False, degeneracy_tol=1e-7,
                              weighted=True, max_iter=17)
    frame = ideal_frame(2.0, 1.0, 1.0, paper_beacons)
    estimate = localizer.localize(frame, paper_beacons)
    settings = localizer._settings
    assert settings.shape == (ransac.N_SETTINGS,)
    assert settings[ransac.SETTING_DELTA_D] == 0.01
    assert settings[ransac.SETTING_COVERAGE] == 0.0
    assert settings[ransac.SETTING_DEGENERACY_TOL] == 1e-7
    assert settings[ransac.SETTING_WEIGHTED] == 1.0
    assert settings[ransac.SETTING_MAX_ITER] == 17

    problem = Problem.from_frame(frame, paper_beacons)
    triplets = localizer.triplets(problem.size)
    out = np.full(ransac.OUT_SIZE, np.nan)
    mask = np.zeros(len(frame), dtype=np.bool_)
    ransac.solve_from_triplets(problem.floats, problem.ints, triplets, settings, out, mask,
                               np.empty((3, 3)))
    assert np.isfinite(out).all()
    assert out[ransac.OUT_SUPPORT] == len(paper_beacons) == estimate.n_inliers
    assert out[ransac.OUT_VALID_TRIPLETS] == estimate.diagnostics["n_valid_triplets"]
    assert out[ransac.OUT_TRIPLET_MEAN_SQ] == estimate.diagnostics["triplet_mean_sq_error"]
    assert (out[K.POSE_X], out[K.POSE_Y]) == (estimate.x, estimate.y)
    assert out[K.REFINED_COST] == estimate.diagnostics["cost"]

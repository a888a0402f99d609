"""Property: on noise-free data a built-in localizer answers the true pose, or says it cannot.

Random beacon layouts (3 to 8 beacons, sizes from half a metre to a kilometre, anywhere within a
kilometre of the origin) and random camera poses, inside or outside the beacons' hull; among them
the degenerate cases drawn on purpose: every beacon on one line, or the camera on (or within a
hair of) the circle through three beacons, the "danger circle". For every localizer:

- ``ok=True`` ⇒ the true pose: position within POSITION_TOL of the layout's size, heading within
  HEADING_TOL; mex within its grid tolerance (:func:`mex_tolerance`);
- ``ok=False`` ⇒ a reason and a NaN pose, never an exception.

A localizer that always refused would pass that, so :func:`test_generic_scenes_are_solved` checks
that generic scenes are solved. The examples are the same on every run (the ``repeatable``
hypothesis profile of conftest.py: ``derandomize=True``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import beacon_map, ideal_frame, pose_error_of
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from azgym import BeaconMap, Estimate
from azgym.localize.learned.ng_ransac import NgRansac
from azgym.localize.loo import LeaveOneOut
from azgym.localize.lsq import LeastSquares
from azgym.localize.mex import Mex
from azgym.localize.ransac import Ransac
from azgym.localize.triplet import Triplet

POSITION_TOL = 1e-6
"""Largest position error of an ``ok`` answer, relative to the scene's size (the diameter of the
beacons and the camera)."""
HEADING_TOL = 1e-6
"""Largest heading error of an ``ok`` answer [rad]."""
MIN_SEPARATION = 1e-3
"""Beacons are this far apart, and the camera this far from each, relative to the layout's size:
a camera on a beacon is a hostile case of its own (tests/localize/test_hostile.py)."""
MEX_CELLS = 40
"""mex's grid step is the layout's size over this: a grid of about 40 × 40 points."""

MEX_QUADRATIC_STEPS = 8
"""Grid steps over which :func:`mex_tolerance`'s quadratic model of the cost is trusted."""
LOCALIZERS = {
    "ransac": Ransac(), "ransac-weighted": Ransac(weighted=True), "loo": LeaveOneOut(),
    "lsq": LeastSquares(), "lsq-weighted": LeastSquares(weighted=True), "triplet": Triplet(),
    "ng-ransac": NgRansac(),
}
"""Every built-in whose answers are exact on noise-free data. ``learned`` is not among them: it
answers its regression wherever the refinement cannot run (its covariance then says how far to
trust it), so an ``ok`` answer of a degenerate scene may be decimetres off."""


def circumcircle(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Centre and radius of the circle through three points; None if they are collinear."""
    d = 2.0 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    if abs(d) < 1e-9:
        return None
    ux = (a @ a * (b[1] - c[1]) + b @ b * (c[1] - a[1]) + c @ c * (a[1] - b[1])) / d
    uy = (a @ a * (c[0] - b[0]) + b @ b * (a[0] - c[0]) + c @ c * (b[0] - a[0])) / d
    centre = np.array([ux, uy])
    return centre, float(np.hypot(*(a - centre)))


@st.composite
def scenes(draw: st.DrawFn, max_beacons: int = 8) -> tuple[BeaconMap, tuple[float, float, float],
                                                           float]:
    """(beacons, true pose, scene size): a layout of diameter 1, scaled and shifted.

    The camera is drawn within 1.5 of the origin in the layout's first coordinates (within about
    three diameters of it after they are normalised). The scene's size is the diameter of the
    beacons and the camera together: rounding and the refinement's convergence test act on the
    distances in the scene, so a camera far from a small layout gets a tolerance to match.
    """
    n = draw(st.integers(3, max_beacons))
    unit = st.floats(-1.0, 1.0, allow_nan=False)
    xy = np.array(draw(st.lists(st.tuples(unit, unit), min_size=n, max_size=n)))
    kind = draw(st.sampled_from(["generic", "collinear", "danger-circle"]))
    if kind == "collinear":  # every beacon on the line through the first two
        t = np.array(draw(st.lists(unit, min_size=n, max_size=n)))
        xy = xy[0] + np.outer(t, xy[1] - xy[0])
    camera = np.array(draw(st.tuples(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5))))
    if kind == "danger-circle":  # the camera on the circle of three beacons, or a hair off it
        circle = circumcircle(*xy[:3])
        assume(circle is not None)
        centre, radius = circle
        angle = draw(st.floats(-math.pi, math.pi))
        offset = draw(st.sampled_from([0.0, 1e-9, 1e-6, 1e-3]))
        camera = centre + radius * (1.0 + offset) * np.array([math.cos(angle), math.sin(angle)])
    assume(np.isfinite(camera).all())
    gaps = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1))[np.triu_indices(n, 1)]
    assume(gaps.min() > 0.0 and gaps.min() >= MIN_SEPARATION * gaps.max())
    assume(np.hypot(*(xy - camera).T).min() >= MIN_SEPARATION * gaps.max())
    # To a layout of diameter 1, centred: the scale drawn next is then the layout's size.
    centre = 0.5 * (xy.min(axis=0) + xy.max(axis=0))
    xy, camera = (xy - centre) / gaps.max(), (camera - centre) / gaps.max()
    scale = draw(st.sampled_from([0.5, 3.0, 20.0, 400.0]))
    shift = np.array(draw(st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3))))
    heading = draw(st.floats(-math.pi, math.pi))
    x, y = camera * scale + shift
    points = np.vstack([xy, camera])
    extent = float(np.hypot(*(points[:, None] - points[None]).transpose(2, 0, 1)).max())
    return beacon_map(xy * scale + shift), (float(x), float(y), heading), extent * scale


def assert_true_pose_or_refusal(estimate: Estimate, pose: tuple[float, float, float],
                                position_tol: float, heading_tol: float, name: str = "") -> None:
    """ok ⇒ within the tolerances; not ok ⇒ a reason and a NaN pose (``name``: whose answer)."""
    if not estimate.ok:
        assert estimate.reason, name
        assert math.isnan(estimate.x) and math.isnan(estimate.y), name
        return
    position_error, heading_error = pose_error_of(estimate, *pose)
    assert position_error <= position_tol, (name, position_error, position_tol,
                                            estimate.diagnostics)
    assert heading_error <= heading_tol, (name, heading_error, heading_tol, estimate.diagnostics)


def assert_each_localizer_true_or_refusing(scene: tuple[BeaconMap, tuple[float, float, float],
                                                        float]) -> None:
    """Every localizer of LOCALIZERS on the scene's noise-free frame: the true pose or a refusal.

    One scene serves them all: drawing it costs far more than their answers.
    """
    beacons, pose, size = scene
    for name, localizer in LOCALIZERS.items():
        estimate = localizer.localize(ideal_frame(*pose, beacons), beacons)
        assert_true_pose_or_refusal(estimate, pose, POSITION_TOL * size, HEADING_TOL, name)


@settings(max_examples=150, deadline=None)
@given(scene=scenes())
def test_ok_means_the_true_pose(scene):
    assert_each_localizer_true_or_refusing(scene)


@pytest.mark.slow
@settings(max_examples=2000, deadline=None)
@given(scene=scenes(max_beacons=14))
def test_ok_means_the_true_pose_many_examples(scene):
    assert_each_localizer_true_or_refusing(scene)


def mex_tolerance(beacons: BeaconMap, pose: tuple[float, float, float],
                  step: float) -> tuple[float, float]:
    """How far mex's grid answer may lie from a noise-free truth: (position [m], heading [rad]).

    Near the truth mex's cost E_ref (eq. 34) is the quadratic form f(p) = (p − t)ᵀ A (p − t),
    A = J_xyᵀ (I − 11ᵀ/n) J_xy / n (the heading eliminated; J_xy are the residuals' position
    gradients). The grid's argmin q costs no more than the grid point nearest the truth, less
    than λ_max · step² / 2 away in cost, and costs at least λ_min |q − t|²; so
    |q − t| <= step · sqrt(κ / 2), κ = λ_max / λ_min. The margin of 1.5 covers the cost's
    curvature beyond the quadratic over a few steps. The heading, φ' of eq. 29 at q, moves by at
    most |∂φ'/∂p| <= 1/D_min per metre of position.
    """
    x, y, _ = pose
    dx, dy = beacons.xy[:, 0] - x, beacons.xy[:, 1] - y
    d2 = dx * dx + dy * dy
    jacobian = np.c_[-dy / d2, dx / d2]
    centred = jacobian - jacobian.mean(axis=0)
    eigenvalues = np.linalg.eigvalsh(centred.T @ centred)
    if eigenvalues[0] <= 1e-12 * eigenvalues[1]:
        return math.inf, math.inf
    position = 1.5 * step * math.sqrt(eigenvalues[1] / eigenvalues[0] / 2.0)
    return position, position / math.sqrt(d2.min()) + 1e-9


@settings(max_examples=60, deadline=None)
@given(scene=scenes(max_beacons=6), coarse=st.booleans())
def test_mex_ok_means_the_grid_point_of_the_true_pose(scene, coarse):
    beacons, pose, size = scene
    step = size / MEX_CELLS
    # The map's extent grown by the scene's size holds the camera: its grid point is searched.
    mex = Mex(step=step, coarse_step=4 * step if coarse else None, margin=size)
    estimate = mex.localize(ideal_frame(*pose, beacons), beacons)
    position_tol, heading_tol = mex_tolerance(beacons, pose, step)
    # The bound is a quadratic model of the cost around the truth: it holds over a few grid
    # steps, not over a flat valley tens of steps long (three beacons a quarter of the scene
    # from the camera: bound 16 steps, answer 21 steps off).
    assume(position_tol <= MEX_QUADRATIC_STEPS * step)
    assert_true_pose_or_refusal(estimate, pose, position_tol, heading_tol)


def generic_scene(rng: np.random.Generator) -> tuple[BeaconMap, tuple[float, float, float]]:
    """Five to eight beacons round a 20 m room, one a sector, the camera inside, 1 m from each."""
    while True:
        n = rng.integers(5, 9)
        angles = (np.arange(n) + rng.uniform(0.0, 1.0, n)) * 2.0 * math.pi / n
        xy = 10.0 * np.c_[np.cos(angles), np.sin(angles)] * rng.uniform(0.7, 1.0, (angles.size, 1))
        x, y = rng.uniform(-6.0, 6.0, 2)
        if np.hypot(xy[:, 0] - x, xy[:, 1] - y).min() >= 1.0:
            return beacon_map(xy), (float(x), float(y), float(rng.uniform(-math.pi, math.pi)))


@pytest.mark.parametrize("name", [*LOCALIZERS, "mex"])
def test_generic_scenes_are_solved(name):
    # The refusals above must be for the degenerate cases: generic scenes are answered.
    localizer = Mex(step=0.5) if name == "mex" else LOCALIZERS[name]
    rng = np.random.default_rng(12)
    scenes_ = [generic_scene(rng) for _ in range(40)]
    solved = [localizer.localize(ideal_frame(*pose, beacons), beacons).ok
              for beacons, pose in scenes_]
    assert np.mean(solved) >= 0.95

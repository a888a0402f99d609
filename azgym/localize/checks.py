"""``check_localizer``: the conformance checks every localizer, built-in or plug-in, should pass.

Like scikit-learn's estimator checks: run it in your test suite, and a failure names the check and
what went wrong. The scenes are small (a 6 m × 6 m room) so that even an exhaustive grid search
passes in seconds.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from azgym.core import (
    BeaconMap,
    Estimate,
    Measurements,
    Pose,
    estimated_pose,
    pose_error,
    wrap_scalar,
)
from azgym.errors import AzgymError, LocalizerCheckError
from azgym.localize.base import Localizer
from azgym.localize.registry import SupportsLocalize
from azgym.sensing.synthetic import ideal_azimuths

__all__ = ["check_localizer"]


def _room(rotation: float = 0.0, shift: tuple[float, float] = (0.0, 0.0)) -> BeaconMap:
    """Eight beacons on the walls of a 6 m × 6 m room, optionally rotated and shifted."""
    xy = np.array([[3.0, -1.5], [3.0, 1.5], [1.2, 3.0], [-1.6, 3.0], [-3.0, 1.0],
                   [-3.0, -2.0], [-1.0, -3.0], [2.0, -3.0]])
    c, s = math.cos(rotation), math.sin(rotation)
    xy = xy @ np.array([[c, s], [-s, c]]) + np.asarray(shift)
    return BeaconMap(np.arange(10, 18), np.c_[xy, np.full(8, 2.5)], width=0.03)


def _frame(beacons: BeaconMap, pose: Pose) -> Measurements:
    azimuth, _ = ideal_azimuths(*pose, beacons)
    return Measurements(beacons.ids, azimuth)


def _expect(condition: bool, check: str, detail: str) -> None:
    if not condition:
        raise LocalizerCheckError(f"check_localizer: {check}: {detail}")


def check_localizer(
    localizer: SupportsLocalize,
    *,
    position_tol: float = 0.01,
    heading_tol: float = 0.01,
    verbose: bool = True,
) -> None:
    """Run every conformance check on ``localizer``; raise on the first failure.

    Checks: the result type and inlier mask shape; noise-free recovery of known poses within
    ``position_tol`` [m] and ``heading_tol`` [rad]; invariance to permuting the measurements and
    to rotating and translating the whole scene; determinism; ids not in the map are never
    inliers; fewer than three usable measurements give ``ok=False`` with a reason and a NaN pose
    (not an exception); for subclasses of :class:`Localizer`, arguments of the wrong type raise an
    azgym error. When every check passes, prints what was checked (unless ``verbose`` is false).

    Raises:
        LocalizerCheckError: Naming the failed check.
    """
    beacons = _room()
    poses = [(0.4, -0.7, 0.3), (-1.5, 1.2, -2.5), (1.9, 1.6, math.pi)]
    for pose in poses:
        _check_recovery(localizer, beacons, pose, position_tol, heading_tol)
    pose = poses[0]
    frame = _frame(beacons, pose)
    _check_determinism_and_permutation(localizer, beacons, frame, position_tol)
    _check_scene_invariance(localizer, pose, position_tol, heading_tol)
    _check_unusable_measurements(localizer, beacons, frame)
    checked = [f"noise-free recovery of {len(poses)} poses (within {position_tol:g} m and "
               f"{heading_tol:g} rad), the Estimate and its inlier mask", "determinism",
               "permutation invariance", "rotation/translation invariance",
               "ids not in the map never inliers", "too few measurements give ok=False"]
    if isinstance(localizer, Localizer):
        wrong: Any = (frame.ids, frame.azimuth)  # not a Measurements, on purpose
        _expect_raises(lambda: localizer.localize(wrong, beacons), "wrong argument type")
        checked.append("a wrong argument type raises an azgym error")
    if verbose:
        print(f"check_localizer: {type(localizer).__name__} passed all {len(checked)} checks:"
              + "".join(f"\n  passed: {check}" for check in checked))


def _check_recovery(
    localizer: SupportsLocalize, beacons: BeaconMap, pose: Pose, position_tol: float,
    heading_tol: float,
) -> None:
    """An Estimate with a boolean inlier mask over the frame, and the pose, from ideal azimuths."""
    estimate = localizer.localize(_frame(beacons, pose), beacons)
    _expect(isinstance(estimate, Estimate), "returns an Estimate",
            f"got {type(estimate).__name__}")
    inliers = np.asarray(estimate.inliers)
    _expect(inliers.shape == (len(beacons),) and inliers.dtype == bool, "inlier mask",
            f"expected bool array of shape ({len(beacons)},), got {inliers.dtype} "
            f"{inliers.shape}")
    _expect(isinstance(estimate.ok, (bool, np.bool_)), "ok is a bool",
            f"got {estimate.ok!r}")
    _expect(estimate.ok, "noise-free recovery", f"failed at pose {pose}: {estimate.reason}")
    _expect(estimated_pose(estimate) is not None, "ok=True comes with a finite pose",
            f"got ({estimate.x}, {estimate.y}, {estimate.heading})")
    position_error, heading_error = pose_error(estimate.pose, pose)
    _expect(position_error <= position_tol and heading_error <= heading_tol,
            "noise-free recovery",
            f"pose {pose}: position error {position_error:.3g} m (tol {position_tol}), "
            f"heading error {heading_error:.3g} rad (tol {heading_tol})")


def _check_determinism_and_permutation(
    localizer: SupportsLocalize, beacons: BeaconMap, frame: Measurements, position_tol: float,
) -> None:
    """The same frame twice gives the same answer; permuted measurements permute the inliers."""
    first = localizer.localize(frame, beacons)
    again = localizer.localize(frame, beacons)
    _expect((first.x, first.y, first.heading) == (again.x, again.y, again.heading)
            and np.array_equal(first.inliers, again.inliers), "determinism",
            "two calls on the same frame gave different answers")

    order = np.random.default_rng(0).permutation(len(beacons))
    permuted = localizer.localize(Measurements(frame.ids[order], frame.azimuth[order]), beacons)
    _expect(math.hypot(permuted.x - first.x, permuted.y - first.y) <= position_tol
            and np.array_equal(np.asarray(permuted.inliers), np.asarray(first.inliers)[order]),
            "permutation invariance", "permuting the measurements changed the answer")


def _check_unusable_measurements(
    localizer: SupportsLocalize, beacons: BeaconMap, frame: Measurements,
) -> None:
    """An id not in the map is never an inlier; fewer than three usable measurements fail."""
    ghost_ids = np.append(frame.ids, 999)
    ghost = localizer.localize(Measurements(ghost_ids, np.append(frame.azimuth, 0.5)), beacons)
    _expect(ghost.ok and not bool(np.asarray(ghost.inliers)[-1]), "unknown ids",
            "a measurement whose id is not in the map was used (or broke the estimate)")

    for count in (0, 2):
        few = localizer.localize(Measurements(frame.ids[:count], frame.azimuth[:count]), beacons)
        _expect(not few.ok and bool(few.reason) and math.isnan(few.x),
                "too few measurements",
                f"{count} measurements gave ok={few.ok}, reason={few.reason!r}, x={few.x}")


def _check_scene_invariance(
    localizer: SupportsLocalize, pose: Pose, position_tol: float, heading_tol: float,
) -> None:
    """The whole scene rotated and shifted: the estimate moves with it."""
    rotation, shift = 0.7, (5.0, -3.0)
    moved = _room(rotation, shift)
    c, s = math.cos(rotation), math.sin(rotation)
    moved_pose = (c * pose[0] - s * pose[1] + shift[0], s * pose[0] + c * pose[1] + shift[1],
                  wrap_scalar(pose[2] + rotation))
    estimate = localizer.localize(_frame(moved, moved_pose), moved)
    position_error, heading_error = pose_error(estimate.pose, moved_pose)
    _expect(estimate.ok and position_error <= position_tol and heading_error <= heading_tol,
            "rotation/translation invariance",
            f"rotated and shifted scene: position error {position_error:.3g} m, heading "
            f"error {heading_error:.3g} rad")


def _expect_raises(call: Callable[[], object], check: str) -> None:
    try:
        call()
    except AzgymError:
        return
    except Exception as exc:  # noqa: BLE001 - any other exception is the failure we report
        raise LocalizerCheckError(
            f"check_localizer: {check}: raised {type(exc).__name__} ({exc}), expected an "
            "azgym error (AzgymError subclass)"
        ) from exc
    raise LocalizerCheckError(f"check_localizer: {check}: no error was raised")

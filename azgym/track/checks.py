"""``check_tracker``: the conformance checks every tracker, built-in or plug-in, should pass.

Like :func:`azgym.check_localizer` for localizers: run it in your test suite, and a failure names
the check and what went wrong. The tracker drives the first 8 s of a warehouse route, as the
benchmark feeds it: ``reset`` with the route's start pose, then ``predict`` and ``update`` per
frame.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np

from azgym.core import Estimate, estimated_pose, pose_error
from azgym.errors import AzgymError, TrackerCheckError
from azgym.track.base import Tracker

__all__ = ["TrackerCheckError", "check_tracker"]

ROUTE_SECONDS = 8.0
"""How much of the route the checks drive."""


def _expect(condition: bool, check: str, detail: str) -> None:
    if not condition:
        raise TrackerCheckError(f"check_tracker: {check}: {detail}")


@cache
def _route() -> tuple[Any, tuple[Any, ...]]:
    """warehouse-small and the first ROUTE_SECONDS of its first route (seed 0)."""
    from azgym.site import load_scenario
    from azgym.world.drive import simulate

    scenario = load_scenario("warehouse-small")
    frames = []
    for frame in simulate(scenario, scenario.routes[0], seed=0):
        if frame.time > ROUTE_SECONDS:
            break
        frames.append(frame)
    return scenario, tuple(frames)


def _drive(tracker: Any, seed: int = 0) -> list[tuple[float, float, float] | None]:
    """Reset at the route's start pose and feed every frame; each frame's pose (or None)."""
    scenario, frames = _route()
    tracker.reset(seed, frames[0].pose)
    poses = []
    for k, frame in enumerate(frames):
        tracker.predict(frame.motion)
        estimate = tracker.update(frame.measurements, scenario.beacons)
        _expect(isinstance(estimate, Estimate), "returns an Estimate",
                f"frame {k} gave a {type(estimate).__name__}")
        try:
            poses.append(estimated_pose(estimate))
        except AzgymError as exc:
            raise TrackerCheckError(f"check_tracker: a well-formed Estimate: frame {k}: {exc}"
                                    ) from None
    return poses


def check_tracker(tracker: Any, *, median_tol: float = 0.2, verbose: bool = True) -> None:
    """Run every conformance check on ``tracker``; raise on the first failure.

    Checks: every frame gets an Estimate whose ``ok`` is a bool and whose pose is finite when
    ok; from the known start pose it follows the route, answering at least half the frames with
    a median position error within ``median_tol`` [m]; the same seed replays the same estimates,
    after ``reset`` and in a fresh copy; for subclasses of :class:`Tracker`, a frame before
    ``reset`` and motion out of order raise an azgym error. When every check passes, prints what
    was checked (unless ``verbose`` is false).

    Raises:
        TrackerCheckError: Naming the failed check.
    """
    fresh, unused = copy.deepcopy(tracker), copy.deepcopy(tracker)
    poses = _drive(tracker)
    _, frames = _route()
    errors = [pose_error(pose, frame.pose)[0] for pose, frame in zip(poses, frames, strict=True)
              if pose is not None]
    _expect(len(errors) >= len(frames) / 2, "follows a route from its start pose",
            f"answered {len(errors)} of {len(frames)} frames")
    median = float(np.median(errors))
    _expect(median <= median_tol, "follows a route from its start pose",
            f"median position error {median:.3f} m > {median_tol:g} m")
    _expect(_drive(tracker) == poses, "reset forgets", "a second drive after reset differs")
    _expect(_drive(fresh) == poses, "determinism", "a fresh copy's drive differs")
    checked = [f"an Estimate every frame; followed {len(frames)} frames of a route (median "
               f"error {100 * median:.1f} cm)", "reset forgets", "determinism"]
    if isinstance(tracker, Tracker):
        scenario, frames = _route()
        _expect_raises(lambda: unused.update(frames[0].measurements, scenario.beacons),
                       "a frame before reset")
        tracker.reset(0, frames[0].pose)
        tracker.predict(frames[1].motion)
        _expect_raises(lambda: tracker.predict(frames[0].motion), "motion out of order")
        checked += ["a frame before reset raises an azgym error",
                    "motion out of order raises an azgym error"]
    if verbose:
        print(f"check_tracker: {type(tracker).__name__} passed all {len(checked)} checks:"
              + "".join(f"\n  passed: {check}" for check in checked))


def _expect_raises(call: Callable[[], object], check: str) -> None:
    try:
        call()
    except AzgymError:
        return
    raise TrackerCheckError(f"check_tracker: {check}: no azgym error was raised")


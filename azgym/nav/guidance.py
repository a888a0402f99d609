"""What the navigator is shown each control step: the path ahead, the localizer's health, itself.

An AGV's controller is handed the next stretch of its planned path in its own frame, by the pose
its localizer estimates, and knows how much it can trust that pose. The observation (a vector
in [−1, 1]) is, in order (:func:`fields`):

* ``localized``: 1 when this step's frame gave a pose the navigator accepted, else 0;
* ``fix_age``: seconds since the last accepted pose, over :data:`FIX_AGE_SCALE` (clipped at
  1; 1 before the first);
* ``support``: measurements that pose agrees with, over :data:`SUPPORT_SCALE` (for
  ``truth``, 1);
* ``ahead_forward_k``, ``ahead_left_k`` for k = 1, 2, 3: the planned path's points
  :data:`ARCS` metres beyond the estimated pose's projection onto it, in the body frame of the
  *estimated* pose, over :data:`AHEAD_SCALE`; zeros before the first pose;
* ``remaining``: the path's length beyond that projection, over :data:`REMAINING_SCALE`;
* ``speed``, ``steer``: the forklift's own, as shares of their limits (its drive knows them);
* ``range_k``: ``n_rays`` range readings around the body, over the sensor's range.

The path is planned once from the start spot (:mod:`azgym.nav.planner`) and followed, as an
AGV commits to its route: each pose is projected onto it near the last projection. When the
estimate is more than :data:`REPLAN_DISTANCE` off the path (a detour, a bump, a wrong pose), the
path is planned again from the estimate. Replanning every step instead would flip between two
routes of nearly equal cost wherever they part.

The pose is the navigator's (:mod:`azgym.nav.pose_keeper`): the localizer's answers, gated for
jumps and dead-reckoned between them; ``fix_age`` says how long it has been dead-reckoned.
"""

from __future__ import annotations

import numpy as np

from azgym.core import FloatArray
from azgym.nav._descent import follow
from azgym.nav._observation import (
    AHEAD_SCALE,
    ARCS,
    FIX_AGE_SCALE,
    REMAINING_SCALE,
    SUPPORT_SCALE,
    fill_observation,
)
from azgym.nav.planner import Planner

__all__ = ["AHEAD_SCALE", "FIX_AGE_SCALE", "Guidance", "REMAINING_SCALE", "SUPPORT_SCALE", "fields"]

REPLAN_DISTANCE = 1.5
"""An estimate this far from the path [m] has the path planned again from it."""
FOLLOW_BACK, FOLLOW_AHEAD = 1.0, 4.0
"""How far behind and ahead of the last projection the next one is looked for [m]."""
HEALTH_FIELDS = ("localized", "fix_age", "support")
PATH_FIELDS = tuple(f"ahead_{axis}_{k}" for k in range(1, len(ARCS) + 1)
                    for axis in ("forward", "left")) + ("remaining",)
DRIVE_FIELDS = ("speed", "steer")


def fields(n_rays: int) -> tuple[str, ...]:
    """The names of the observation's entries, in order."""
    return (HEALTH_FIELDS + PATH_FIELDS + DRIVE_FIELDS
            + tuple(f"range_{k}" for k in range(n_rays)))


class Guidance:
    """Builds the observation (module docstring) of one environment.

    Args:
        planner: The floor's planner.
        segments: The occluder table the range sensor sees.
        n_rays: Range readings.
        ray_range: Their maximum [m].
    """

    def __init__(self, planner: Planner, segments: FloatArray, n_rays: int,
                 ray_range: float) -> None:
        self.planner = planner
        self.segments = segments
        self.n_rays = n_rays
        self.ray_range = ray_range
        self.size = len(fields(n_rays))
        self._ahead = np.empty((len(ARCS), 2))
        self._rays = np.empty(n_rays)
        self.goal = 0
        self.path = np.zeros((1, 2))
        self._along = np.zeros(1)
        self._segment = 0

    def start(self, goal: int, x: float, y: float) -> None:
        """Plan the path from the start (x, y) to spot ``goal``: a new episode."""
        self.goal = goal
        self._plan(x, y)

    def _plan(self, x: float, y: float) -> None:
        self.path, self._along = self.planner.plan(self.goal, x, y)
        self._segment = 0

    def observe(self, estimate: tuple[float, float, float] | None, fix_age: float,
                support: float, localized: bool, speed_share: float, steer_share: float,
                true_pose: tuple[float, float, float]) -> np.ndarray:
        """The observation, given the estimated body pose (None before the first) and the rest.

        Args:
            estimate: The estimated pose of the body's reference point, or None.
            fix_age: Seconds since that estimate was made.
            support: How many measurements agree with it.
            localized: Whether this step's frame gave it.
            speed_share: Speed over its limit.
            steer_share: Steering angle over full lock.
            true_pose: The body's true pose, where the range sensor is.
        """
        observation = np.empty(self.size, dtype=np.float32)
        segment, arc = 0, 0.0
        ex = ey = heading = 0.0
        if estimate is not None:
            ex, ey, heading = estimate
            segment, arc, distance = follow(self.path, self._along, ex, ey, self._segment,
                                            FOLLOW_BACK, FOLLOW_AHEAD)
            if distance > REPLAN_DISTANCE:
                self._plan(ex, ey)
                segment, arc = 0, 0.0
            self._segment = segment
        x, y, true_heading = true_pose
        fill_observation(observation, self.path, self._along, segment, float(arc),
                         estimate is not None, float(ex), float(ey), float(heading),
                         float(fix_age), float(support), bool(localized), float(speed_share),
                         float(steer_share), float(x), float(y), float(true_heading),
                         self.segments, float(self.ray_range), self._rays, self._ahead)
        return observation

"""The navigator's observation filled in one compiled call, each control step.

:class:`~azgym.nav.guidance.Guidance` decides where the estimated pose lies on the planned path
(and plans again when it is off); :func:`fill_observation` then writes every entry, in the order
and scales :mod:`azgym.nav.guidance` documents: the localizer's health, the path's points ahead in
the estimated body frame, the drive, and the range readings it takes itself.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit
from azgym.nav._descent import points_at
from azgym.sensing.geometry.occluders import ray_ranges

__all__ = ["AHEAD_SCALE", "ARCS", "FIX_AGE_SCALE", "REMAINING_SCALE", "SUPPORT_SCALE",
           "fill_observation"]

ARCS = np.array([1.5, 3.0, 5.0])
"""Arc lengths along the planned path of the points shown [m]."""
AHEAD_SCALE = 5.0
"""Body-frame offsets of the points ahead are divided by this [m]."""
FIX_AGE_SCALE = 2.0
"""Seconds since the last pose are divided by this (and clipped at 1)."""
SUPPORT_SCALE = 8
"""Measurements that agree with the pose are divided by this (and clipped at 1)."""
REMAINING_SCALE = 50.0
"""The path's remaining length is divided by this [m] (and clipped at 1)."""


@jit
def fill_observation(out, path, along, segment, arc, known, ex, ey, heading, fix_age, support,
                     localized, speed_share, steer_share, x, y, true_heading, segments, ray_range,
                     rays, ahead):
    """Write the observation into ``out`` (float32, laid out as ``guidance.fields``).

    Args:
        out: The observation.
        path: The planned path's points, (P, 2) [m].
        along: Their arc lengths along it, (P,) [m].
        segment: The segment the estimate projects onto.
        arc: The projection's arc length [m].
        known: Whether there is an estimate yet; without one the path's entries are 0.
        ex: The estimate's east coordinate [m].
        ey: Its north coordinate [m].
        heading: Its heading [rad].
        fix_age: Seconds since the estimate was made.
        support: Measurements that agree with it.
        localized: Whether this step's frame gave it.
        speed_share: The drive's speed over its limit.
        steer_share: Its steering angle over full lock.
        x: The body's true east coordinate, where the range readings are taken [m].
        y: Its true north coordinate [m].
        true_heading: Its true heading [rad].
        segments: The occluder table the range sensor sees.
        ray_range: The range readings' maximum [m].
        rays: Scratch: one range per reading.
        ahead: Scratch: the points ahead, (len(ARCS), 2).

    A value v "clipped at 1" is v when v < 1 and 1 otherwise (so also for NaN), as Python's
    ``min(1.0, v)``; clipped to [−1, 1] likewise from both sides.
    """
    out[0] = 1.0 if localized else 0.0
    n_arcs = ARCS.size
    if known:
        out[1] = _at_most_one(fix_age / FIX_AGE_SCALE)
        out[2] = _at_most_one(support / SUPPORT_SCALE)
        points_at(path, along, segment, arc + ARCS, ahead)
        c, s = math.cos(heading), math.sin(heading)
        for k in range(n_arcs):
            dx, dy = ahead[k, 0] - ex, ahead[k, 1] - ey
            out[3 + 2 * k] = _clip((c * dx + s * dy) / AHEAD_SCALE)
            out[4 + 2 * k] = _clip((-s * dx + c * dy) / AHEAD_SCALE)
        out[3 + 2 * n_arcs] = _at_most_one((along[-1] - arc) / REMAINING_SCALE)
    else:
        out[1] = 1.0
        out[2] = 0.0
        for k in range(3, 4 + 2 * n_arcs):
            out[k] = 0.0
    drive = 4 + 2 * n_arcs
    out[drive] = _clip(speed_share)
    out[drive + 1] = _clip(steer_share)
    ray_ranges(x, y, true_heading, segments, rays.size, ray_range, rays)
    for r in range(rays.size):
        out[drive + 2 + r] = rays[r] / ray_range


@jit(inline="always")
def _at_most_one(value):
    return value if value < 1.0 else 1.0


@jit(inline="always")
def _clip(value):
    inner = _at_most_one(value)
    return inner if inner > -1.0 else -1.0

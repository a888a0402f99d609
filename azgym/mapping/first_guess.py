"""One id's first guess from its rays and the observability rule; each azimuth's noise.

The rule (docs/mapping.md, "First guesses and observability"): an id is observable when it was
seen at least :data:`~azgym.localize.bearings.MIN_RAYS` times, its rays spread at least
:data:`~azgym.localize.bearings.MIN_SPREAD`, and those that agree on a point (a reweighted
intersection) do too. Each detection's standard deviation is eq. 1-3's at the guess's distance.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.localize.bearings import MIN_RAYS, MIN_SPREAD, intersect_robustly, spread
from azgym.mapping.problem import Prior, Settings
from azgym.site.error_model import ErrorModel

__all__ = ["DEFAULT_WIDTH", "anchor_positions", "azimuth_sigmas", "first_guess", "seen",
           "widths"]

DEFAULT_WIDTH = 0.03
"""Width of a beacon the prior map does not hold [m] (docs/logs.md's default)."""

def first_guess(poses: FloatArray, azimuths: FloatArray) -> tuple[FloatArray, str]:
    """One id's guess from its rays, or NaN and why it is unobservable."""
    directions = poses[:, 2] + azimuths
    if len(directions) < MIN_RAYS:
        return np.full(2, np.nan), f"{seen(len(directions))}, fewer than {MIN_RAYS}"
    angle = spread(directions)
    if angle < MIN_SPREAD:
        return np.full(2, np.nan), _narrow(angle)
    point, weights = intersect_robustly(poses[:, :2], directions)
    agreeing = weights > 0.5
    if not np.isfinite(point).all() or agreeing.sum() < MIN_RAYS:
        return np.full(2, np.nan), (f"its rays do not meet: {int(agreeing.sum())} of "
                                    f"{len(directions)} agree on a point")
    angle = spread(directions[agreeing])
    if angle < MIN_SPREAD:
        return np.full(2, np.nan), _narrow(angle) + " among the rays that agree"
    return point, ""


def seen(detections: int) -> str:
    """How many times an id was detected, in words."""
    return f"seen {detections} time{'s' * (detections != 1)}"


def _narrow(angle: float) -> str:
    """The reason of a beacon whose rays spread too little."""
    return (f"its rays spread {math.degrees(angle):.1f}°, less than "
            f"{math.degrees(MIN_SPREAD):.0f}° (too narrow a baseline)")


def anchor_positions(prior: Prior) -> dict[int, FloatArray]:
    """Each anchor's map position (x, y)."""
    if prior.beacons is None:
        return {}
    index = {int(i): k for k, i in enumerate(prior.beacons.ids.tolist())}
    return {a: prior.beacons.xyz[index[a], :2].copy() for a in prior.anchors}


def widths(prior: Prior, ids: IntArray) -> FloatArray:
    """Each id's width: the prior map's, else :data:`DEFAULT_WIDTH`."""
    widths = np.full(len(ids), DEFAULT_WIDTH)
    if prior.beacons is not None:
        for b, beacon in enumerate(ids.tolist()):
            index = np.flatnonzero(prior.beacons.ids == beacon)
            if index.size:
                widths[b] = prior.beacons.width[index[0]]
    return widths


def azimuth_sigmas(settings: Settings, poses: FloatArray, points: FloatArray,
            widths: FloatArray) -> FloatArray:
    """Each detection's azimuth standard deviation: eq. 1-3 at the first guess's distance."""
    distance = np.hypot(*(points - poses[:, :2]).T)
    model = ErrorModel(settings.delta_alpha_d, settings.coverage)
    return np.sqrt(model.variance(np.maximum(distance, 0.1), widths) + settings.extra_sigma**2)

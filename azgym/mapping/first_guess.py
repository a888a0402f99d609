"""One id's first guess from its rays and the observability rule; each azimuth's noise.

The rule (docs/mapping.md, "First guesses and observability"): an id is observable when it was
seen at least :data:`~azgym.localize.bearings.MIN_RAYS` times, its rays spread at least
:data:`~azgym.localize.bearings.MIN_SPREAD`, and those that agree on a point (a reweighted
intersection, :func:`agreeing`) do too. A beacon a site's map holds is guessed at its map
position when more of its rays agree with that. Each detection's standard deviation is eq. 1-3's
at the guess's distance.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.localize.bearings import (
    MIN_RAYS,
    MIN_SPREAD,
    agreeing,
    intersect_robustly,
    meeting_point,
    spread,
)
from azgym.mapping.problem import Prior, Settings
from azgym.site.error_model import ErrorModel

__all__ = ["DEFAULT_WIDTH", "MIN_AGREEING", "MIN_RANGE", "anchor_positions",
           "azimuth_residuals", "azimuth_sigmas", "azimuth_variances", "first_guess", "seen",
           "too_few", "unmet", "widths"]

DEFAULT_WIDTH = 0.03
"""Width of a beacon the prior map does not hold [m] (docs/logs.md's default)."""
MIN_RANGE = 0.1
"""Least distance the azimuth noise is taken at [m] (:func:`azimuth_variances`)."""
CONSENSUS_RAYS = 16
"""Rays whose pairs' meeting points a beacon the map holds is also guessed at (:func:`first_guess`:
the one most of its rays agree with), when its map position is not."""
MIN_AGREEING = 0.5
"""Least share of an id's detections the solved graph must agree with (and at least
:data:`~azgym.localize.bearings.MIN_RAYS` of them): among a beacon's detections, ghosts and
misread ones are the few; an id whose azimuths are scattered (a misread id seen here and there)
has a handful that pass near some point by chance, and is no beacon. (The first guess, from
dead-reckoned poses that drift, cannot ask as much of a point it finds; it asks it of a map
position, :func:`first_guess`.)"""


def first_guess(poses: FloatArray, azimuths: FloatArray,
                held: FloatArray | None = None) -> tuple[FloatArray, str]:
    """One id's guess from its rays, or NaN and why it is unobservable.

    A beacon a site's map holds at ``held`` (x, y) is guessed there when at least
    :data:`MIN_AGREEING` of its rays agree with it (:func:`agreeing`); else at whichever of
    the intersection, the best meeting point of two rays (:func:`_consensus`) and the map
    position more rays agree with (the first on a tie). Mirror images meet at a point of their
    own, which the reweighting may fall to, and a stray ray crossing a narrow bundle draws the
    intersection far along it: either way off a beacon the map has right or a moved one.
    """
    directions = poses[:, 2] + azimuths
    if reason := too_few(len(directions)):
        return np.full(2, np.nan), reason
    angle = spread(directions)
    if angle < MIN_SPREAD:
        return np.full(2, np.nan), _narrow(angle)
    point, _ = intersect_robustly(poses[:, :2], directions)
    agree = agreeing(poses[:, :2], directions, point)
    if held is not None:
        at_map = agreeing(poses[:, :2], directions, held)
        if at_map.sum() >= MIN_AGREEING * len(directions):
            point, agree = held, at_map
        else:
            for other in (_consensus(poses, directions), held):
                at_other = agreeing(poses[:, :2], directions, other)
                if at_other.sum() > agree.sum():
                    point, agree = other, at_other
    if reason := unmet(directions, point, agree):
        return np.full(2, np.nan), reason
    return point, ""


def too_few(detections: int) -> str:
    """Why an id seen ``detections`` times is unobservable: too few rays; '' when not."""
    if detections < MIN_RAYS:
        return f"{seen(detections)}, fewer than {MIN_RAYS}"
    return ""


def unmet(directions: FloatArray, point: FloatArray, agree: np.ndarray) -> str:
    """Why rays along ``directions`` do not place ``point``, or '' when they do.

    They do when it is finite and those that agree with it (``agree``, :func:`agreeing`) are
    at least :data:`~azgym.localize.bearings.MIN_RAYS` and spread at least
    :data:`~azgym.localize.bearings.MIN_SPREAD`.
    """
    if not np.isfinite(point).all() or agree.sum() < MIN_RAYS:
        return f"its rays do not meet: {int(agree.sum())} of {len(directions)} agree on a point"
    angle = spread(directions[agree])
    if angle < MIN_SPREAD:
        return _narrow(angle) + " among the rays that agree"
    return ""


def _consensus(poses: FloatArray, directions: FloatArray) -> FloatArray:
    """The point the most rays agree with among where pairs of them meet, refined on those.

    The pairs of :data:`CONSENSUS_RAYS` rays spaced evenly through the detections (all of them,
    when fewer); NaN when no pair meets.
    """
    picks = np.unique(np.linspace(0, len(directions) - 1,
                                  min(len(directions), CONSENSUS_RAYS)).round().astype(np.int64))
    best, most = np.full(2, np.nan), np.zeros(len(directions), dtype=bool)
    for i, j in itertools.combinations(picks.tolist(), 2):
        point = meeting_point(poses[[i, j], :2], directions[[i, j]], np.ones(2))
        agree = agreeing(poses[:, :2], directions, point)
        if agree.sum() > most.sum():
            best, most = point, agree
    if most.sum() < MIN_RAYS:
        return best
    return meeting_point(poses[most, :2], directions[most], np.ones(int(most.sum())))


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


def azimuth_residuals(poses: FloatArray, points: FloatArray, azimuths: FloatArray) -> FloatArray:
    """Each azimuth measured from ``poses`` (K, 3) minus the one ``points`` (K, 2) give, wrapped.

    The bearing of a point from a camera pose (x, y, φ) is atan2(y_b − y, x_b − x) − φ [rad].
    """
    predicted = np.arctan2(points[:, 1] - poses[:, 1], points[:, 0] - poses[:, 0]) - poses[:, 2]
    return np.asarray(np.remainder(azimuths - predicted + math.pi, 2.0 * math.pi) - math.pi)


def azimuth_variances(settings: Settings, distance: FloatArray,
                      widths: FloatArray | float) -> FloatArray:
    """Each detection's azimuth variance [rad²]: eq. 1-3's at ``distance`` plus extra_sigma's.

    ``distance`` [m] is taken at :data:`MIN_RANGE` at least.
    """
    model = ErrorModel(settings.delta_alpha_d, settings.coverage)
    return model.variance(np.maximum(distance, MIN_RANGE), widths) + settings.extra_sigma**2


def azimuth_sigmas(settings: Settings, poses: FloatArray, points: FloatArray,
                   widths: FloatArray) -> FloatArray:
    """Each detection's azimuth standard deviation: eq. 1-3 at the first guess's distance."""
    return np.sqrt(azimuth_variances(settings, np.hypot(*(points - poses[:, :2]).T), widths))

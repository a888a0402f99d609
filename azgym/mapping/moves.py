"""The move test: whether a beacon's surveyed position contradicts its map position.

A beacon moved when its offset from the map is at least :data:`MIN_MOVE` long and at least
:data:`MOVE_CHI2` in squared Mahalanobis distance (:func:`contradicts`): the survey judges each
map-held beacon so, on its position without its own map prior (:mod:`azgym.mapping.survey`),
and :func:`moved` judges positions the map did not pull (the ``rays`` mapper's).
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import BeaconMap, FloatArray, IntArray

__all__ = ["MIN_MOVE", "MOVE_CHI2", "contradicts", "moved"]

MIN_MOVE = 0.10
"""Least distance between a beacon's prior and surveyed positions to call it moved [m]."""
MOVE_CHI2 = 13.8155
"""... and the least squared Mahalanobis distance (χ², 2 degrees of freedom, 0.999): both must
hold, so that neither a tiny but certain shift nor a large but uncertain one counts."""


def moved(ids: IntArray, xy: FloatArray, covariances: FloatArray, observable: np.ndarray,
          prior: BeaconMap, anchors: set[int] | None = None) -> tuple[int, ...]:
    """The surveyed beacons whose prior position a survey free of the prior contradicts.

    For positions the prior did not pull (the rays', :func:`~azgym.mapping.rays.survey_by_rays`):
    each surveyed beacon of ``prior`` against its prior position under its covariance
    (:func:`contradicts`). Anchors are held, never tested.

    Args:
        ids: Every id (N,).
        xy: (N, 2) their surveyed positions [m].
        covariances: (N, 2, 2) their covariances [m²].
        observable: (N,) whether each was surveyed.
        prior: The map.
        anchors: Ids held at their map positions.
    """
    found = []
    held = anchors or set()
    for b in np.flatnonzero(observable).tolist():
        beacon = int(ids[b])
        index = np.flatnonzero(prior.ids == beacon)
        if beacon in held or not index.size:
            continue
        if contradicts(xy[b] - prior.xyz[index[0], :2], covariances[b]):
            found.append(beacon)
    return tuple(found)


def contradicts(offset: FloatArray, covariance: FloatArray) -> bool:
    """Whether a beacon's ``offset`` from its map position, of that ``covariance``, is a move.

    At least :data:`MIN_MOVE` long, and its squared Mahalanobis distance at least
    :data:`MOVE_CHI2`: both must hold, so that neither a tiny but certain shift nor a large but
    uncertain one counts.
    """
    distance2 = float(offset @ np.linalg.solve(covariance, offset))
    return math.hypot(*offset) >= MIN_MOVE and distance2 >= MOVE_CHI2

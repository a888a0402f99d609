"""A suspect beacon's rays for map repair: kept in a bounded store, met by the most sightings.

:mod:`azgym.track.repair` keeps each suspect's rays here, packed one per row (the ``COLUMN_*``
constants): the camera's position, the bearing from it, the bearing's variance, the position's
covariance, the heading's variance, and which sighting (frame) of the beacon the ray is of. The
geometry is :mod:`azgym.localize.bearings`'.

**One beacon, one ray a sighting.** A beacon is measured at most once a frame (the tracker's
gate keeps one detection of a beacon); a second detection with its id is a ghost or a misread.
The point rays meet is scored by the sightings with a ray through it, and the rays it gathers
are at most one a sighting (the one that misses it least): a mirror ghost beside the beacon in
every frame neither outvotes it nor is counted with it.

**The track's own error is shared.** A ray starts where the track put the camera and points
along the track's heading. The azimuth's error is new each frame, but the track's position and
heading errors drift: rays taken over a few seconds share them. A common shift δ of every
origin moves the rays' meeting point by δ; a common turn δφ of every bearing turns each ray
about its origin and moves the point by J δφ, with J = A⁻¹ Σ_k w_k r_k n_k (A = Σ w_k n_k n_kᵀ
the rays' information, r_k the point's range along ray k, n_k its normal). So the point's
covariance is the rays' own, A⁻¹, which shrinks as rays are added, plus what they share,
Σ̄ + J σ̄φ² Jᵀ (the rays' mean position covariance and heading variance), which does not.

**No one ray decides.** One stray ray across many parallel ones fixes a point on their line as
tightly as a true crossing: nothing checks it. A position is as certain as it is without its
most informative sighting (:func:`worst_std`): it must be fixed by at least two crossings.
"""

from __future__ import annotations

import numpy as np

from azgym.core import FloatArray
from azgym.localize.bearings import crossings, meet, pair_spread, ray_misses, spread

__all__ = ["CANDIDATES", "COLUMN_HEADING_VARIANCE", "COLUMN_SIGHTING", "KEPT_SHARE", "MAX_RAYS",
           "RayStore", "consensus", "intersect", "locate", "near", "origin_covariance", "pack",
           "scatter", "worst_std"]

MAX_RAYS = 400
"""Rays kept per beacon (the latest): bounds the memory and the least squares."""
KEPT_SHARE = 0.8
"""Smallest share of a suspect's sightings whose rays must meet its new position (a ghost's
detections, a second ray in a sighting, do not count against it)."""
CANDIDATES = 24
"""Pairs of rays whose crossings are tried as a suspect's new position, at most."""
COLUMN_HEADING_VARIANCE = 7
"""Packed column: the track's heading variance when the ray was taken [rad²]."""
COLUMN_SIGHTING = 8
"""Packed column: the ray's sighting, counted from 0 (rays of one frame share it)."""


class RayStore:
    """A beacon's latest :data:`MAX_RAYS` rays, packed (module docstring, :func:`pack`).

    A ring buffer that grows by doubling: a beacon seen a few times holds a few rays.
    """

    WIDTH = 9

    def __init__(self) -> None:
        self._buffer = np.empty((4, self.WIDTH))
        self.added = 0
        """Rays ever added (the buffer holds the latest ``min(added, MAX_RAYS)``)."""

    def __len__(self) -> int:
        return min(self.added, MAX_RAYS)

    def add(self, rays: FloatArray) -> None:
        """Append packed rays (n, :attr:`WIDTH`), dropping the oldest beyond :data:`MAX_RAYS`."""
        for ray in rays[-MAX_RAYS:]:
            if self.added >= len(self._buffer) and len(self._buffer) < MAX_RAYS:
                grown = np.empty((min(2 * len(self._buffer), MAX_RAYS), self.WIDTH))
                grown[:self.added] = self._buffer
                self._buffer = grown
            self._buffer[self.added % len(self._buffer)] = ray
            self.added += 1

    def latest(self) -> FloatArray:
        """The rays held, oldest first (K, :attr:`WIDTH`)."""
        if self.added <= len(self._buffer):
            return self._buffer[:self.added].copy()
        start = self.added % len(self._buffer)
        return np.concatenate((self._buffer[start:], self._buffer[:start]))


def pack(origin: FloatArray, bearings: FloatArray, variance: float, position: FloatArray,
         heading_variance: float, sighting: int) -> FloatArray:
    """One sighting's rays, packed (n, :attr:`RayStore.WIDTH`).

    Args:
        origin: The camera's position (2,) [m].
        bearings: Each detection's world bearing (n,) [rad].
        variance: A bearing's variance, the heading's included [rad²].
        position: The camera position's covariance (2, 2) [m²].
        heading_variance: The heading's variance [rad²].
        sighting: The sighting's number.
    """
    rays = np.empty((bearings.size, RayStore.WIDTH))
    rays[:] = (origin[0], origin[1], 0.0, variance, position[0, 0], position[0, 1],
               position[1, 1], heading_variance, sighting)
    rays[:, 2] = bearings
    return rays


def locate(rays: FloatArray, span: float, threshold: float, max_std: float,
           box: tuple[FloatArray, FloatArray], placed: FloatArray | None = None
           ) -> tuple[FloatArray, FloatArray, float, int] | None:
    """Where a suspect's rays put it, or None while they do not say (module docstring).

    The rays taken are those, one a sighting, of the point the most sightings meet
    (:func:`consensus`), or those within the gate of where the beacon is ``placed`` already (a
    repaired beacon, refined). They must be at least :data:`KEPT_SHARE` of the sightings (and
    three), spread ``span`` [rad], meet ahead of every ray (by more than three standard
    deviations of its camera's position along it: rays from one standing camera, however they
    turn, meet at the camera) inside ``box`` (lowest, highest corner), and fix the point
    within ``max_std`` [m] without the most telling of them (:func:`worst_std`).

    Returns:
        The point (2,), its covariance (2, 2) (:func:`intersect`), its worst-axis standard
        deviation without its most telling ray, and the rays that met it.
    """
    kept = consensus(rays, span, threshold, box) if placed is None else \
        near(rays, placed, threshold)
    if kept.sum() < max(3, KEPT_SHARE * np.unique(rays[:, COLUMN_SIGHTING]).size):
        return None
    rays = rays[kept]
    if spread(rays[:, 2]) < span:
        return None
    met = intersect(rays)
    if met is None:
        return None
    point, covariance, _ = met
    directions = np.column_stack((np.cos(rays[:, 2]), np.sin(rays[:, 2])))
    ahead = np.einsum("kj,kj->k", directions, point - rays[:, :2])
    camera = np.einsum("ki,kij,kj->k", directions, origin_covariance(rays), directions)
    worst = worst_std(rays, point)
    if worst > max_std or (ahead <= 3.0 * np.sqrt(camera)).any() \
            or (point < box[0]).any() or (point > box[1]).any():
        return None
    return point, covariance, worst, len(rays)


def consensus(rays: FloatArray, span: float, threshold: float,
              box: tuple[FloatArray, FloatArray]) -> np.ndarray:
    """The rays, one a sighting, that meet within the gate the point the most sightings meet.

    A mirror ghost's rays meet at its image, and a track's first rays may be off: crossings of
    pairs of rays are tried, ray k (:data:`CANDIDATES` of them, spread over the store) with
    ray k + K/2 and with the ray of another sighting most across it, each scored by the
    sightings that have a ray within the gate of it. A pair whose rays spread less than half
    ``span`` (:func:`~azgym.localize.bearings.pair_spread`) crosses too uncertainly to be
    tried, and one that crosses outside ``box`` (lowest, highest corner) is not where a beacon
    can hang (a mirror's image is seen there, as often as the beacon or more).
    """
    half = len(rays) // 2
    sightings, bearings = rays[:, COLUMN_SIGHTING], rays[:, 2]
    firsts = np.arange(0, half, max(1, 2 * half // CANDIDATES))
    across = np.abs(np.sin(bearings[None, :] - bearings[firsts, None])) \
        * (sightings[None, :] != sightings[firsts, None])
    pairs = np.concatenate((np.column_stack((firsts, firsts + half)),
                            np.column_stack((firsts, across.argmax(axis=1)))))
    pairs = pairs[pair_spread(bearings[pairs[:, 0]], bearings[pairs[:, 1]]) >= 0.5 * span]
    points = crossings(rays[pairs[:, 0], :2], bearings[pairs[:, 0]], rays[pairs[:, 1], :2],
                       bearings[pairs[:, 1]])
    points = points[((points >= box[0]) & (points <= box[1])).all(axis=1)]
    covariance = origin_covariance(rays)
    best, most = np.full(len(rays), np.inf), 0
    for point in points:
        miss2 = ray_misses(point, rays[:, :2], bearings, rays[:, 3], covariance) ** 2
        agreeing = np.unique(sightings[miss2 < threshold]).size
        if agreeing > most:
            best, most = miss2, agreeing
    return _one_a_sighting(best, sightings, threshold)


def near(rays: FloatArray, point: FloatArray, threshold: float) -> np.ndarray:
    """The rays, one a sighting, that pass within the gate of ``point``."""
    return _one_a_sighting(ray_misses(point, rays[:, :2], rays[:, 2], rays[:, 3],
                                      origin_covariance(rays)) ** 2, rays[:, COLUMN_SIGHTING],
                           threshold)


def _one_a_sighting(miss2: FloatArray, sightings: FloatArray, threshold: float) -> np.ndarray:
    """The rays within ``threshold`` (squared misses), of each sighting the least missing one."""
    passing = np.flatnonzero(miss2 < threshold)
    order = passing[np.lexsort((miss2[passing], sightings[passing]))]
    first = np.ones(order.size, dtype=bool)
    first[1:] = sightings[order[1:]] != sightings[order[:-1]]
    kept = np.zeros(miss2.size, dtype=bool)
    kept[order[first]] = True
    return kept


def origin_covariance(rays: FloatArray) -> FloatArray:
    """The camera positions' covariances (K, 2, 2) of packed rays."""
    return np.stack((rays[:, 4:6], rays[:, 5:7]), axis=1)


def intersect(rays: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """Where packed rays meet, its covariance, and each ray's miss (module docstring).

    :func:`~azgym.localize.bearings.meet`'s point and misses (None where the weighed rays meet
    at no single point); its covariance widened by the rays' scatter (:func:`scatter`), plus
    the track's shared error.
    """
    met = meet(rays[:, :2], rays[:, 2], rays[:, 3], origin_covariance(rays))
    if met is None:
        return None
    point, covariance, misses = met
    shared = _shared(rays, point, np.asarray(np.linalg.inv(covariance), np.float64))
    return point, covariance * scatter(misses) + shared, misses


def scatter(misses: FloatArray) -> float:
    """How much wider rays scatter than their variances say: Σ miss² / (K − 2), at least 1.

    Each miss over its standard deviation is a unit normal when the variances are right, and
    the point takes two degrees of freedom; a larger mean square (rays from a track whose error
    drifts beyond its covariance) widens the point's covariance by as much (one ray, or two:
    1).
    """
    freedom = misses.size - 2
    return max(1.0, float(np.sum(np.square(misses))) / freedom) if freedom > 0 else 1.0


def worst_std(rays: FloatArray, point: FloatArray) -> float:
    """The point's standard deviation along its worst axis without its most telling ray [m].

    The rays' information A less each ray's own, inverted and widened by the rays'
    :func:`scatter`, plus the shared error (module docstring); the largest over the rays
    (infinite when one ray alone fixes an axis).
    """
    normals, weights, _ = _weighed(rays, point)
    information = (normals * weights[:, None]).T @ normals
    shared = _shared(rays, point, information)
    misses = np.einsum("kj,kj->k", normals, point - rays[:, :2]) * np.sqrt(weights)
    own = weights[:, None, None] * normals[:, :, None] * normals[:, None, :]
    left = information[None] - own
    det = left[:, 0, 0] * left[:, 1, 1] - left[:, 0, 1] * left[:, 1, 0]
    if (det <= 1e-12 * np.linalg.det(information)).any():
        return float("inf")
    inverse = np.stack((np.stack((left[:, 1, 1], -left[:, 0, 1]), axis=1),
                        np.stack((-left[:, 1, 0], left[:, 0, 0]), axis=1)), axis=1) \
        / det[:, None, None]
    return float(np.sqrt(np.linalg.eigvalsh(inverse * scatter(misses) + shared).max()))


def _weighed(rays: FloatArray, point: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each ray's normal (K, 2), its weight at ``point`` (K,) and the point's range along it."""
    bearings = rays[:, 2]
    normals = np.column_stack((-np.sin(bearings), np.cos(bearings)))
    offsets = point - rays[:, :2]
    covariance = origin_covariance(rays)
    variance = np.sum(np.square(offsets), axis=1) * rays[:, 3] \
        + np.einsum("ki,kij,kj->k", normals, covariance, normals)
    ranges = offsets[:, 0] * np.cos(bearings) + offsets[:, 1] * np.sin(bearings)
    return normals, 1.0 / variance, ranges


def _shared(rays: FloatArray, point: FloatArray, information: FloatArray) -> FloatArray:
    """The covariance the rays' shared position and heading errors give the point (2, 2)."""
    normals, weights, ranges = _weighed(rays, point)
    turn = np.linalg.solve(information, (weights * ranges) @ normals)
    position = origin_covariance(rays).mean(axis=0)
    return position + float(rays[:, COLUMN_HEADING_VARIANCE].mean()) * np.outer(turn, turn)

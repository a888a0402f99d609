"""A suspect beacon's rays for map repair: kept in a bounded store, met by the most of them.

:mod:`azgym.track.repair` keeps each suspect's rays here, packed one per row as (x, y,
bearing, variance, σxx, σxy, σyy): the camera's position, the bearing from it, the bearing's
variance and the position's covariance. The geometry is :mod:`azgym.localize.bearings`'.
"""

from __future__ import annotations

import numpy as np

from azgym.core import FloatArray
from azgym.localize.bearings import intersect_rays, ray_misses, spread

__all__ = ["CANDIDATES", "MAX_RAYS", "RayStore", "consensus", "intersect", "origin_covariance"]

MAX_RAYS = 400
"""Rays kept per beacon (the latest): bounds the memory and the least squares."""
CANDIDATES = 24
"""Pairs of rays whose crossings are tried as a suspect's new position, at most."""


class RayStore:
    """A beacon's latest :data:`MAX_RAYS` rays, packed (x, y, bearing, variance, σxx, σxy, σyy).

    A ring buffer that grows by doubling: a beacon seen a few times holds a few rays.
    """

    WIDTH = 7

    def __init__(self) -> None:
        self._buffer = np.empty((4, self.WIDTH))
        self.added = 0
        """Rays ever added (the buffer holds the latest ``min(added, MAX_RAYS)``)."""

    def __len__(self) -> int:
        return min(self.added, MAX_RAYS)

    def add(self, rays: FloatArray) -> None:
        """Append rays (n, 7), dropping the oldest beyond :data:`MAX_RAYS`."""
        for ray in rays[-MAX_RAYS:]:
            if self.added >= len(self._buffer) and len(self._buffer) < MAX_RAYS:
                grown = np.empty((min(2 * len(self._buffer), MAX_RAYS), self.WIDTH))
                grown[:self.added] = self._buffer
                self._buffer = grown
            self._buffer[self.added % len(self._buffer)] = ray
            self.added += 1

    def latest(self) -> FloatArray:
        """The rays held, oldest first (K, 7)."""
        if self.added <= len(self._buffer):
            return self._buffer[:self.added].copy()
        start = self.added % len(self._buffer)
        return np.concatenate((self._buffer[start:], self._buffer[:start]))


def consensus(rays: FloatArray, span: float, threshold: float) -> np.ndarray:
    """The rays that meet, within the gate, the point most of them meet.

    A mirror ghost's rays meet at its image, and a track's first rays may be off: each ray
    k is paired with ray k + K/2, the two's crossing scored by the rays it gathers, and the
    best one kept. A pair whose rays spread (:func:`~azgym.localize.bearings.spread`) less than
    half ``span`` crosses too uncertainly to be tried.
    """
    half = len(rays) // 2
    best = np.zeros(len(rays), dtype=bool)
    for k in range(0, half, max(1, half // CANDIDATES)):
        pair = rays[[k, k + half]]
        if spread(pair[:, 2]) < 0.5 * span:
            continue
        point, _, _ = intersect(pair)
        kept = ray_misses(point, rays[:, :2], rays[:, 2], rays[:, 3],
                          origin_covariance(rays)) ** 2 < threshold
        if kept.sum() > best.sum():
            best = kept
    return best


def origin_covariance(rays: FloatArray) -> FloatArray:
    """The camera positions' covariances (K, 2, 2) of packed rays."""
    return np.stack((rays[:, 4:6], rays[:, 5:7]), axis=1)


def intersect(rays: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:func:`intersect_rays` on packed rays (x, y, bearing, variance, σxx, σxy, σyy)."""
    return intersect_rays(rays[:, :2], rays[:, 2], rays[:, 3], origin_covariance(rays))

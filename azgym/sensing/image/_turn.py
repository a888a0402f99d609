"""The blob tracker's common turn, compiled (:mod:`~azgym.sensing.image.blob_tracker`).

Every frame the tracker pairs each track with each blob at a similar radius and looks for the
densest cluster of their azimuth shifts; as a dozen numpy calls on a frame's few dozen pairs it
cost about 150 µs, a fifth of a blinking camera's frame. One loop here, the same answer bit for
bit (the same differences, order, window counts and median; the order by the sensor's insertion
sort, which compiles in milliseconds where numba's ``np.sort`` takes seconds), in a module of its
own so that the kernel cache depends on nothing else.
"""

from __future__ import annotations

import numpy as np

from azgym.jit import jit, wrap_compiled
from azgym.sensing.geometry.ordering import stable_order

__all__ = ["common_turn"]


@jit
def common_turn(azimuth, radius, own_azimuth, own_radius, last_turn, gate_px, max_change,
                window, support_needed):
    """The frame's common azimuth shift, or ``last_turn`` when no cluster has the support.

    Args:
        azimuth: The blobs' azimuths about the principal point [rad], (B,).
        radius: Their distances from it [px], (B,).
        own_azimuth: Each track's azimuth moved by its own drift only [rad], (T,).
        own_radius: Its radius likewise [px], (T,).
        last_turn: The last frame's common turn [rad].
        gate_px: Largest radius difference of a track-to-blob pair [px].
        max_change: Largest shift from the last turn a pair may have [rad].
        window: Width of a cluster of shifts [rad].
        support_needed: Shifts a cluster needs.

    Returns:
        ``last_turn`` plus the median shift of the densest window of shifts (the window nearest
        the last turn among the densest), each pair's shift beyond ``last_turn`` wrapped to
        (−π, π] and at most ``max_change``.
    """
    shifts = np.empty(own_azimuth.size * azimuth.size)
    count = 0
    for t in range(own_azimuth.size):
        for b in range(azimuth.size):
            if abs(radius[b] - own_radius[t]) <= gate_px:
                shift = wrap_compiled(azimuth[b] - own_azimuth[t] - last_turn)
                if abs(shift) <= max_change:
                    shifts[count] = shift
                    count += 1
    if count < support_needed:
        return last_turn
    order = stable_order(shifts, count)
    candidates = np.empty(count)
    for k in range(count):
        candidates[k] = shifts[order[k]]
    most, best, nearest = 0, 0, np.inf
    end = 0  # past the last shift within the window from candidates[k]
    for k in range(count):  # the densest window, the first of those nearest the last turn
        while end < count and candidates[end] <= candidates[k] + window:
            end += 1
        support = end - k
        distance = abs(candidates[k] + 0.5 * window)
        if support > most or (support == most and distance < nearest):
            most, best, nearest = support, k, distance
    if most < support_needed:
        return last_turn
    middle = best + most // 2
    if most % 2:
        return last_turn + candidates[middle]
    return last_turn + (candidates[middle - 1] + candidates[middle]) / 2.0

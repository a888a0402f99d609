"""What fixes the map frame: a drive's known start pose, or the anchors it observes.

A mapper's answer is in the frame of the anchors (surveyed beacons) and of the known start
poses; with neither a start pose nor two anchors that frame is free, and the drive is refused by
name (:func:`require_fixed`). A drive without a known start is turned and shifted onto the map
by a rigid fit of where its rays put the anchors it observes onto their map positions: at least
two of them, else refused by name (:func:`require_anchors`). :func:`placed` places the survey's
dead-reckoned drives so (:func:`rigid`, Kabsch's fit).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.errors import InvalidInputError
from azgym.mapping.first_guess import first_guess
from azgym.mapping.problem import Drive, Prior

__all__ = ["carried", "placed", "require_anchors", "require_fixed", "rigid"]


def require_fixed(drives: Sequence[Drive], prior: Prior) -> None:
    """Refuse drives whose map frame is free: no known start pose and fewer than two anchors.

    Raises:
        InvalidInputError: None of ``drives`` has a start pose and ``prior`` has fewer than two
            anchors.
    """
    if len(prior.anchors) < 2 and all(d.start is None for d in drives):
        raise InvalidInputError(
            f"the map frame is free: give the start pose or at least two anchors (surveyed "
            f"beacons), got {len(prior.anchors)} anchor{'' if len(prior.anchors) == 1 else 's'}"
            " and no start pose")


def placed(drive: Drive, poses: FloatArray, anchors: dict[int, FloatArray], ids: IntArray,
           local_rows: IntArray, beacon_of: IntArray, azimuths: FloatArray,
           count: int) -> FloatArray:
    """A drive without a start, moved onto the map by the anchors it observes (rigid fit).

    Args:
        drive: The drive (its name, for a refusal).
        poses: (``count``, 3) its dead-reckoned poses.
        anchors: Each anchor's map position (x, y).
        ids: Every id detected.
        local_rows: Each detection's pose index within the drive (outside [0, ``count``): another
            drive's).
        beacon_of: Each detection's id index.
        azimuths: Each detection's azimuth [rad].
        count: The drive's frames.

    Raises:
        InvalidInputError: Its rays place fewer than two anchors (:func:`require_anchors`).
    """
    inside = (local_rows >= 0) & (local_rows < count)
    seen, wanted = [], []
    for beacon, position in anchors.items():
        match = np.flatnonzero(ids == beacon)
        if not match.size:
            continue
        rows = np.flatnonzero(inside & (beacon_of == match[0]))
        if not rows.size:
            continue
        guess, _ = first_guess(poses[local_rows[rows]], azimuths[rows])
        if np.isfinite(guess).all():
            seen.append(guess)
            wanted.append(position)
    require_anchors(drive, len(seen))
    return carried(poses, *rigid(np.array(seen), np.array(wanted)))


def carried(poses: FloatArray, turn: FloatArray, shift: FloatArray) -> FloatArray:
    """Poses (K, 3) turned by ``turn`` (2, 2) and shifted by ``shift`` (2,), headings wrapped."""
    placed = poses.copy()
    placed[:, :2] = poses[:, :2] @ turn.T + shift
    placed[:, 2] = np.remainder(poses[:, 2] + math.atan2(turn[1, 0], turn[0, 0]) + math.pi,
                                2.0 * math.pi) - math.pi
    return placed


def require_anchors(drive: Drive, observed: int) -> None:
    """Refuse a drive without a start pose whose rays place fewer than two of its anchors.

    Raises:
        InvalidInputError: ``observed`` (the anchors placed) is under two.
    """
    if observed < 2:
        raise InvalidInputError(
            f"{drive.name} has no known start pose and observes {observed} anchor"
            f"{'' if observed == 1 else 's'} from a wide enough baseline; it needs its start "
            "pose or at least two observed anchors to be placed on the map")


def rigid(source: FloatArray, target: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The rotation and shift that best carry ``source`` points onto ``target`` (Kabsch)."""
    a, b = source - source.mean(axis=0), target - target.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    turn = vt.T @ np.diag([1.0, d]) @ u.T
    return turn, target.mean(axis=0) - source.mean(axis=0) @ turn.T

"""The blob tracker: blinking beacons followed across frames and their ids decoded.

On the image a blinking beacon (:mod:`azgym.sensing.image.blink_code`) is a blob that comes and
goes. :class:`BlobTracker` follows the blobs from frame to frame (in polar coordinates about the
principal point, where the forklift's turning is a common shift of every azimuth, estimated each
frame; assigned by the Hungarian method within gates), records each track's lit/dark history and
decodes it. A track has an id only once it has read a complete, valid codeword, and loses it when
its latest codeword fails. Misidentifications then come from what really breaks codes: missed
detections, tracks that swap between close blobs, noise blobs and lights that blink nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from azgym.core import FloatArray, IntArray, wrap_scalar
from azgym.errors import InvalidInputError
from azgym.sensing.image._turn import common_turn
from azgym.sensing.image.blink_code import MAX_DARK_RUN, BlinkCode

__all__ = ["NEW_TRACK_GATES", "BlobTracker"]

MERGE_SHARE = 0.8
"""A blob is taken for several close beacons' merged light when its area is at least this share
of their blobs' areas alone (areas fluctuate by about ±20 % with noise at the threshold)."""
SETTLED_SIGHTINGS = 3
"""Frames a track must have had a blob in to count as settled: only a settled track lends its
drift to a new neighbour or joins a merged blob (noise makes short-lived specks of a few
pixels, whose tracks would otherwise spread their drift and turn every blob beside them into a
merger)."""
NEW_TRACK_GATES = 3.0
"""A track whose drift is not yet measured takes blobs this many gates from its prediction: its
own motion is still unknown."""
NEIGHBOUR_GATES = 6.0
"""A new track borrows the drift of the nearest settled track within this many gates on the
image (close blobs are at similar bearings and distances and drift alike)."""
DRIFT_GAIN = 0.5
"""Share of a track's surprise (its blob's distance from the prediction) that goes into its drift
once the drift is measured: the beta of its alpha-beta filter."""
AREA_GAIN = 0.5
"""Share of a new blob area that goes into the track's remembered area (exponential smoothing)."""
TURN_WINDOW = 0.02
"""Width of the window in which track-to-blob azimuth shifts count as one common turn [rad]:
about 4 px at the horizon."""
TURN_SUPPORT = 2
"""Shifts a common turn needs inside its window; with fewer, the last frame's turn stays."""


@dataclass
class _Track:
    azimuth: float  # predicted for the current frame [rad]
    radius: float  # [px]
    parallax_rate: float  # own azimuth change per frame beyond the common turn [rad]
    radius_rate: float  # [px per frame]
    history: list[int] = field(default_factory=list)
    missed: int = 0
    seen: int = 1  # frames with a blob; from 2 on, the drift is measured
    beacon_id: int = -1
    phase: int = -1  # with an id: where in its codeword the coming frame is
    area: float = 0.0  # the blob's area when it was alone [px]; 0: not known
    prior: bool = False  # whether the drift started from a neighbour's

    @property
    def has_drift(self) -> bool:
        """Whether the drift is known: measured from a second sighting, or a neighbour's."""
        return self.seen >= 2 or self.prior


def _follow(track: _Track, azimuth: float, radius: float, area: float | None) -> None:
    """Move a track onto the blob it took, with an alpha-beta update of its drift.

    ``DRIFT_GAIN`` of the surprise goes into the drift, and all of it when the drift is first
    measured (the second sighting of a track without a neighbour's drift). The gap counts the
    dark frames since the last sighting, over which the surprise built up.
    """
    azimuth, radius = float(azimuth), float(radius)
    gap = track.missed + 1
    beta = DRIFT_GAIN if track.has_drift else 1.0
    track.parallax_rate += beta * wrap_scalar(azimuth - track.azimuth) / gap
    track.radius_rate += beta * (radius - track.radius) / gap
    track.azimuth, track.radius = azimuth, radius
    track.seen += 1
    if area is not None:
        track.area += AREA_GAIN * (area - track.area) if track.area else area


def _assign(margin: FloatArray, inside: np.ndarray) -> tuple[IntArray, IntArray]:
    """Tracks and blobs paired so that the pairs' total margin inside their gates is largest.

    A track may be dark (blinking) and a blob may be new, so no pair is forced: each pair gains
    its gate minus its distance, and the pairing with the largest total gain wins. Two middling
    pairs then do not beat one close pair and a new track, which a plain rectangular assignment
    of distances (pairing as many blobs as it can) would choose.

    Args:
        margin: Track-to-blob distance minus the track's gate, shape (T, B) [px].
        inside: Where the margin is <= 0: the pairs allowed.

    Returns:
        The paired (track, blob) indices.
    """
    # imported here: 0.15 s that every command importing the suites would pay
    from scipy.optimize import linear_sum_assignment

    rows, cols = linear_sum_assignment(np.where(inside, margin, 0.0))
    keep = inside[rows, cols]
    return rows[keep], cols[keep]


class BlobTracker:
    """Blobs followed across frames and their blinking decoded into ids.

    Each frame, every track is moved by the common turn (every azimuth shifts by the same angle
    when the forklift turns) and by its own drift (parallax of the forklift's travel). The
    common turn is estimated first, as the densest cluster of azimuth shifts between tracks and
    blobs at similar radii; without it a 10 Hz camera loses every track in a brisk turn (20 px a
    frame). Blobs are then assigned to the moved tracks by the Hungarian method, for the largest
    total margin inside the gates, so no pair is forced. Far beacons down a long aisle sit a few
    pixels apart near the horizon, and three rules keep their tracks apart:

    * a track with an id knows its code and takes no blob in a frame where its beacon is dark;
    * a blob as large as the blobs of several tracks together, lit at once and merged on the
      image, lights all of them (and has no id: its centroid is no one beacon's);
    * a new track starts with the drift of a settled neighbour on the image, which drifts alike.

    Args:
        code: The beacons' code.
        principal_point: (c_x, c_y) of the camera [px]: the centre of the polar prediction.
        gate_px: Largest distance between a track's predicted position and a blob it takes [px].
        max_missed: Dark frames in a row after which a track is dropped (the code has at most
            two; one more tolerates a missed detection).
        max_turn_change: Largest change of the common turn from one frame to the next [rad].
    """

    def __init__(self, code: BlinkCode, principal_point: tuple[float, float],
                 gate_px: float = 8.0, max_missed: int = 3,
                 max_turn_change: float = 0.1) -> None:
        if not gate_px > 0 or max_missed < MAX_DARK_RUN or not 0 < max_turn_change < math.pi:
            raise InvalidInputError(
                f"gate_px must be > 0, max_missed >= {MAX_DARK_RUN} and max_turn_change in "
                f"(0, pi), got {gate_px}, {max_missed}, {max_turn_change}")
        self.code = code
        self.centre = principal_point
        self.gate_px = gate_px
        self.max_missed = max_missed
        self.max_turn_change = max_turn_change
        self._tracks: list[_Track] = []
        self._turn = 0.0  # the last frame's common azimuth shift [rad]
        self._codewords: dict[int, np.ndarray] = {}

    def reset(self) -> None:
        """Forget every track (a new episode)."""
        self._tracks = []
        self._turn = 0.0

    @property
    def track_count(self) -> int:
        """Tracks alive now."""
        return len(self._tracks)

    def _common_turn(self, azimuth: FloatArray, radius: FloatArray) -> float:
        """The frame's common azimuth shift: the densest cluster of track-to-blob shifts.

        Shifts are searched within ``max_turn_change`` of the last frame's turn (a forklift's
        turn rate changes smoothly); a cluster needs ``TURN_SUPPORT`` shifts within
        ``TURN_WINDOW``, else the last turn stays.
        """
        tracks = self._tracks
        if not tracks or not len(azimuth):
            return self._turn
        own_azimuth = np.array([t.azimuth + t.parallax_rate for t in tracks])
        own_radius = np.array([t.radius + t.radius_rate for t in tracks])
        return float(common_turn(azimuth, radius, own_azimuth, own_radius, float(self._turn),
                                 float(self.gate_px), float(self.max_turn_change), TURN_WINDOW,
                                 TURN_SUPPORT))

    def update(self, pixels: FloatArray, areas: FloatArray | None = None) -> IntArray:
        """Take one frame's blob centres (N, 2) [px]; return each blob's decoded id, shape (N,).

        A blob's id is its track's: -1 until the track reads a valid codeword, and again after
        a corrupt one.

        Args:
            pixels: Blob centroids (u, v) [px].
            areas: Blob areas [px], shape (N,). With them, a blob that holds the light of
                several close beacons (lit together, merged on the image) lights all of their
                tracks; without them, a track left without a blob reads that frame as dark and
                its code breaks.
        """
        points = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        if areas is not None:
            areas = np.asarray(areas, dtype=np.float64).reshape(-1)
            if areas.shape != (len(points),):
                raise InvalidInputError(f"areas: one per blob ({len(points)}), got shape "
                                        f"{areas.shape}")
        cx, cy = self.centre
        u, v = points.T  # pixel columns and rows
        azimuth = np.arctan2(v - cy, u - cx)
        radius = np.hypot(u - cx, v - cy)
        self._turn = self._common_turn(azimuth, radius)
        for track in self._tracks:  # move every track to where it should be now
            track.azimuth += self._turn + track.parallax_rate
            track.radius += track.radius_rate
        assignment, taken, merged = self._pair(points, areas)
        # A merged blob's centroid mixes lights: its tracks coast on their predictions.
        for b in np.flatnonzero((assignment >= 0) & ~merged):
            _follow(self._tracks[assignment[b]], azimuth[b], radius[b],
                    None if areas is None else areas[b])
        for track, lit in zip(self._tracks, taken.tolist(), strict=True):
            track.missed = 0 if lit else track.missed + 1
            track.history.append(1 if lit else 0)
        assignment = self._drop_lost(assignment)
        self._start_tracks(assignment, azimuth, radius, areas)
        self._decode()
        ids = np.array([self._tracks[t].beacon_id for t in assignment], dtype=np.int64)
        ids[merged] = -1  # several beacons' light, at none's azimuth
        return ids

    def _pair(self, points: FloatArray,
              areas: FloatArray | None) -> tuple[IntArray, np.ndarray, np.ndarray]:
        """The blobs' tracks: (each blob's track or -1, each track's "lit", each blob's "merged").

        Each track is paired with at most one blob inside its gate (:func:`_assign`); with
        ``areas``, tracks left without a blob may then join a merged blob
        (:meth:`_join_merged`).
        """
        tracks = self._tracks
        assignment = np.full(len(points), -1, dtype=np.int64)
        taken = np.zeros(len(tracks), dtype=bool)
        merged = np.zeros(len(points), dtype=bool)
        if not tracks or not len(points):
            return assignment, taken, merged
        cx, cy = self.centre
        predicted_azimuth = np.array([t.azimuth for t in tracks])
        predicted_radius = np.array([t.radius for t in tracks])
        px = cx + predicted_radius * np.cos(predicted_azimuth)
        py = cy + predicted_radius * np.sin(predicted_azimuth)
        u, v = points.T  # pixel columns and rows
        cost = np.hypot(px[:, None] - u[None, :], py[:, None] - v[None, :])
        margin = cost - np.array([self._gate(t) for t in tracks])[:, None]
        inside = margin <= 0.0  # each track pairs only with blobs inside its gate
        rows, cols = _assign(margin, inside)
        assignment[cols] = rows
        taken[rows] = True
        if areas is not None:
            self._join_merged(areas, assignment, inside & ~taken[:, None], cost, taken, merged)
        return assignment, taken, merged

    def _drop_lost(self, assignment: IntArray) -> IntArray:
        """Drop the tracks dark for more than ``max_missed`` frames; renumber ``assignment``."""
        tracks = self._tracks
        survivors = [t for t in range(len(tracks)) if tracks[t].missed <= self.max_missed]
        renumber = np.full(len(tracks) + 1, -1, dtype=np.int64)
        renumber[survivors] = np.arange(len(survivors))
        self._tracks = [tracks[t] for t in survivors]
        return renumber[assignment]  # -1 stays -1 (index -1 of renumber is -1)

    def _start_tracks(self, assignment: IntArray, azimuth: FloatArray, radius: FloatArray,
                      areas: FloatArray | None) -> None:
        """Start a track on every blob no track took (``assignment`` -1, set in place).

        A new track starts with the drift of a settled neighbour (:meth:`_local_flow`), if any.
        """
        new = np.flatnonzero(assignment < 0)
        if not len(new):
            return
        settled = [t for t in self._tracks if t.seen >= SETTLED_SIGHTINGS and t.missed == 0]
        for b in new:
            assignment[b] = len(self._tracks)
            flow = self._local_flow(settled, azimuth[b], radius[b])
            self._tracks.append(_Track(float(azimuth[b]), float(radius[b]), *(flow or (0.0, 0.0)),
                                       [1], area=0.0 if areas is None else float(areas[b]),
                                       prior=flow is not None))

    def _decode(self) -> None:
        """Read the codeword that ends now on every track; keep the phase of those with an id."""
        period = self.code.period
        for track in self._tracks:
            if len(track.history) > period:
                del track.history[:-period]
            decoded = self.code.decode(track.history)
            if decoded is not None:
                track.beacon_id = decoded
                track.phase = 0 if decoded >= 0 else -1  # a codeword starts next frame
            elif track.phase >= 0:
                track.phase = (track.phase + 1) % period

    def _gate(self, track: _Track) -> float:
        """How far from its prediction a track takes a blob [px]; -1: it takes none.

        A track with an id knows its code, so in a frame where its beacon is dark any blob
        at its place is another light (a neighbour, a beacon just come into view).
        """
        if track.phase >= 0 and not self._codeword(track.beacon_id)[track.phase]:
            return -1.0
        if not track.has_drift:  # its motion is not yet predicted: a wider gate
            return NEW_TRACK_GATES * self.gate_px
        return self.gate_px

    def _codeword(self, beacon_id: int) -> np.ndarray:
        """The lit frames of one codeword of ``beacon_id`` (cached)."""
        if beacon_id not in self._codewords:
            self._codewords[beacon_id] = self.code.frames(beacon_id)
        return self._codewords[beacon_id]

    def _local_flow(self, settled: list[_Track], azimuth: float,
                    radius: float) -> tuple[float, float] | None:
        """A new track's first drift: the nearest settled track's within ``NEIGHBOUR_GATES``.

        An upward fisheye maps a light's azimuth and elevation to the image, and beacons hang at
        similar heights, so blobs that are close on the image are at similar bearings and
        distances and drift alike as the forklift travels.
        """
        best, nearest = None, (NEIGHBOUR_GATES * self.gate_px) ** 2
        for track in settled:
            du = track.radius * math.cos(track.azimuth) - radius * math.cos(azimuth)
            dv = track.radius * math.sin(track.azimuth) - radius * math.sin(azimuth)
            if du * du + dv * dv < nearest:
                best, nearest = (track.parallax_rate, track.radius_rate), du * du + dv * dv
        return best

    def _join_merged(self, areas: FloatArray, assignment: IntArray, free: np.ndarray,
                     cost: FloatArray, taken: np.ndarray, merged: np.ndarray) -> None:
        """Light the tracks whose beacons merged into another track's blob (in place).

        Two beacons a few pixels apart that are lit together make one blob, at their
        flux-weighted centre and about as large as their two blobs together. A track left
        without a blob whose gate holds such a blob is lit too: the blob's area must be at
        least ``MERGE_SHARE`` of the areas its tracks had alone, and the track must have been
        seen alone ``SETTLED_SIGHTINGS`` times. Checked nearest first, so a blob can hold three or
        more beacons.

        Args:
            areas: Each blob's area [px].
            assignment: Each blob's track, -1 for none.
            free: (T, B): the track took no blob and the blob is inside its gate.
            cost: (T, B) track-to-blob distances [px].
            taken: Each track's "lit this frame", updated.
            merged: Each blob's "merged", updated.
        """
        for b in np.flatnonzero((assignment >= 0) & free.any(axis=0)):
            claimed = self._tracks[assignment[b]].area
            if not claimed:
                continue
            candidates = np.flatnonzero(free[:, b])
            for t in candidates[np.argsort(cost[candidates, b])]:
                track = self._tracks[t]
                if (taken[t] or track.seen < SETTLED_SIGHTINGS
                        or areas[b] < MERGE_SHARE * (claimed + track.area)):
                    continue
                claimed += track.area
                taken[t] = merged[b] = True

"""``survey``: every beacon's position from drives, as bearing-only SLAM (docs/mapping.md).

1. Odometry: each drive's relative camera poses, their covariances and their derivatives with
   respect to the turn rate's bias and the odometry's scale error
   (:mod:`azgym.mapping.odometry`), dead-reckoned from its known start, or from the origin. A
   drive without a known start is placed by the anchors it observes (at least two: a rigid fit
   of their guesses onto their map positions).
2. The drives solved frame by frame (:func:`_swept`, :class:`~azgym.mapping.sweep.Sweep`), from
   which the first guesses: each id's rays from the poses, intersected
   (:func:`~azgym.localize.bearings.intersect_robustly`); an id whose rays do not spread enough
   (:func:`~azgym.localize.bearings.spread`) or are too few is unobservable, its detections
   left out. With the site's map as the prior, an id it does not hold (a misread id) is not
   surveyed, only counted (:attr:`~azgym.mapping.problem.Prior.ids`).
3. The factor graph (:mod:`azgym.mapping.graph`), solved; a beacon whose azimuths then mostly
   disagree with it (robust outliers: fewer than :data:`MIN_AGREEING` of them agree), or whose
   agreeing rays no longer spread enough, is reported unobservable too, and left out of the
   graph whose marginals give the others' covariances.
4. With a prior map, each surveyed beacon's move is tested (:func:`moved`).

The map frame is fixed by a known start pose or by at least two anchors; anything less leaves it
free, and is refused by name.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from azgym.core import BeaconMap, FloatArray, IntArray
from azgym.errors import InvalidInputError
from azgym.localize.bearings import MIN_RAYS, MIN_SPREAD, spread
from azgym.mapping.first_guess import (
    DEFAULT_WIDTH,
    anchor_positions,
    azimuth_sigmas,
    first_guess,
    seen,
    widths,
)
from azgym.mapping.graph import Graph, skeleton, solve
from azgym.mapping.graph import covariances as graph_covariances
from azgym.mapping.odometry import compose, relative_poses
from azgym.mapping.problem import Drive, Prior, Settings, drive_list
from azgym.mapping.sweep import Sweep

__all__ = ["DEFAULT_WIDTH", "MAX_STRAIN", "MIN_AGREEING", "MIN_MOVE", "MOVE_CHI2", "Survey",
           "moved", "survey"]

MIN_AGREEING = 0.5
"""Least share of an id's detections the solved graph must agree with (and at least
:data:`~azgym.localize.bearings.MIN_RAYS` of them): among a beacon's detections, ghosts and
misread ones are the few; an id whose azimuths are scattered (a misread id seen here and there)
has a handful that pass near some point by chance, and is no beacon. (The first guess, from
dead-reckoned poses that drift, cannot ask as much.)"""
SWEEP_FRAMES = 10
"""Frames the sweep (:func:`_swept`) adds at a time."""
MAX_STRAIN = 1.0
"""Most the mean squared residual of the agreeing azimuths may reach, in their modelled variance,
for the survey to place beacons. The error model bounds the azimuth noise (uniform errors; a
consistent solve leaves 0.2-0.6 of it); a solve that strains the azimuths beyond it has bent
the map to fit a motion model that understates its noise (a robot's odometry taken for a
forklift's: 1.2-1.6, and its beacons decimetres off), so none is placed."""
MIN_MOVE = 0.10
"""Least distance between a beacon's prior and surveyed positions to call it moved [m]."""
MOVE_CHI2 = 13.8155
"""... and the least squared Mahalanobis distance (χ², 2 degrees of freedom, 0.999): both must
hold, so that neither a tiny but certain shift nor a large but uncertain one counts."""


@dataclass(frozen=True, eq=False)
class Survey:
    """A survey's answer.

    Attributes:
        ids: Every id detected (N,), sorted.
        xy: (N, 2) surveyed positions [m]; NaN for an unobservable beacon.
        covariances: (N, 2, 2) their covariances [m²]; NaN likewise.
        observable: (N,) whether each was surveyed.
        reasons: (N,) why not ('' when it was).
        rays: (N,) detections of each id; ``outliers`` (N,) those the robust loss set aside.
        anchors: Ids held at their map positions.
        moved: Ids whose prior position the survey contradicts (:func:`moved`).
        poses: Per drive, the camera poses (K, 3) solved.
        outliers: Detections set aside by the robust loss, in all.
        iterations: Levenberg-Marquardt's iterations.
    """

    ids: IntArray
    xy: FloatArray
    covariances: FloatArray
    observable: np.ndarray
    reasons: tuple[str, ...]
    rays: IntArray
    outlier_rays: IntArray
    anchors: tuple[int, ...]
    moved: tuple[int, ...]
    poses: tuple[FloatArray, ...]
    outliers: int
    iterations: int

    def beacon_map(self, prior: BeaconMap | None = None) -> BeaconMap:
        """The observable beacons as a map (z and width from ``prior`` where it has them)."""
        keep = np.flatnonzero(self.observable)
        z = np.zeros(keep.size)
        width = np.full(keep.size, DEFAULT_WIDTH)
        if prior is not None:
            for n, k in enumerate(keep.tolist()):
                index = np.flatnonzero(prior.ids == self.ids[k])
                if index.size:
                    z[n], width[n] = prior.xyz[index[0], 2], prior.width[index[0]]
        return BeaconMap(self.ids[keep], np.column_stack([self.xy[keep], z]), width)


def survey(drives: Drive | Sequence[Drive], prior: Prior | None = None,
           settings: Settings | None = None) -> Survey:
    """Survey the beacons seen along ``drives`` (module docstring).

    Raises:
        InvalidInputError: No frames; the map frame not fixed (no known start pose and fewer
            than two anchors); a drive without a start that observes fewer than two anchors.
        DependencyNotInstalled: gtsam is missing.
    """
    drives = drive_list(drives)
    prior = Prior() if prior is None else prior
    settings = Settings() if settings is None else settings
    if not drives or not any(d.frames for d in drives):
        raise InvalidInputError("the survey got no frames")
    if len(prior.anchors) < 2 and all(d.start is None for d in drives):
        raise InvalidInputError(
            f"the map frame is free: give the start pose or at least two anchors (surveyed "
            f"beacons), got {len(prior.anchors)} anchor{'' if len(prior.anchors) == 1 else 's'}"
            " and no start pose")
    odometry = [relative_poses(d, settings) for d in drives]
    reckoned = [compose(np.zeros(3) if d.start is None else np.array(d.start), o.moves)
                for d, o in zip(drives, odometry, strict=True)]
    ids, pose_rows, beacon_of, azimuths = _detections(drives)
    offsets = np.cumsum([0, *(len(d.frames) for d in drives)])
    anchors = anchor_positions(prior)
    for n, drive in enumerate(drives):
        if drive.start is None:
            reckoned[n] = _placed(drive, reckoned[n], anchors, ids, pose_rows - offsets[n],
                                  beacon_of, azimuths, offsets[n + 1] - offsets[n])
    first = skeleton(drives, offsets, odometry, np.concatenate(reckoned), settings)
    poses = _swept(first, settings, prior, ids, pose_rows, beacon_of, azimuths)
    guesses, reasons = _first_guesses(poses, prior, ids, pose_rows, beacon_of, azimuths)
    return _solved(dataclasses.replace(first, poses=poses), offsets, prior, settings, ids,
                   pose_rows, beacon_of, azimuths, guesses, reasons)


def _detections(drives: list[Drive]) -> tuple[IntArray, IntArray, IntArray, FloatArray]:
    """Every id (sorted) and each detection's global pose index, id index and azimuth."""
    pose_rows, id_values, azimuths = [], [], []
    base = 0
    for drive in drives:
        for k, frame in enumerate(drive.frames):
            m = frame.measurements
            pose_rows.append(np.full(len(m), base + k))
            id_values.append(m.ids)
            azimuths.append(m.azimuth)
        base += len(drive.frames)
    all_ids = np.concatenate(id_values) if id_values else np.zeros(0, np.int64)
    ids, beacon_of = np.unique(all_ids, return_inverse=True)
    return (ids, np.concatenate(pose_rows).astype(np.int64) if pose_rows else
            np.zeros(0, np.int64), beacon_of.astype(np.int64),
            np.concatenate(azimuths) if azimuths else np.zeros(0))


def _first_guesses(poses: FloatArray, prior: Prior, ids: IntArray, pose_rows: IntArray,
                   beacon_of: IntArray, azimuths: FloatArray) -> tuple[FloatArray, list[str]]:
    """Each id's first guess from ``poses`` (NaN: unobservable, with the reason)."""
    anchors = anchor_positions(prior)
    guesses = np.full((len(ids), 2), np.nan)
    reasons = [""] * len(ids)
    known = prior.ids
    for b, beacon in enumerate(ids.tolist()):
        rows = np.flatnonzero(beacon_of == b)
        if beacon in anchors:
            guesses[b] = anchors[beacon]
            continue
        if known is not None and beacon not in known:
            reasons[b] = f"not in the prior map: {seen(rows.size)}"
            continue
        guesses[b], reasons[b] = first_guess(poses[pose_rows[rows]], azimuths[rows])
    return guesses, reasons


def _swept(base: Graph, settings: Settings, prior: Prior, ids: IntArray,
           pose_rows: IntArray, beacon_of: IntArray, azimuths: FloatArray) -> FloatArray:
    """Every camera pose solved frame by frame (:class:`~azgym.mapping.graph.Sweep`).

    :data:`SWEEP_FRAMES` frames at a time: their poses from the odometry, their detections of
    beacons already placed, then each beacon not yet placed whose rays from the estimated poses
    now give a first guess (:func:`first_guess`) placed there with all its detections so far.
    Anchors are placed from the start; an id the prior map lacks never is.
    """
    anchors = anchor_positions(prior)
    index = {int(i): b for b, i in enumerate(ids.tolist())}
    sweep = Sweep(base, settings, {index[a]: xy for a, xy in anchors.items() if a in index})
    known = prior.ids
    hopeless = {b for b, i in enumerate(ids.tolist()) if known is not None and i not in known}
    where = np.full((len(ids), 2), np.nan)
    for b in sweep.placed:
        where[b] = anchors[int(ids[b])]
    width = widths(prior, ids)
    order = np.argsort(pose_rows, kind="stable")
    edges = [*range(0, len(base.poses), SWEEP_FRAMES), len(base.poses)]
    bounds = np.searchsorted(pose_rows[order], edges)
    for end, first, stop in zip(edges[1:], bounds[:-1], bounds[1:], strict=True):
        chunk = order[first:stop]
        sweep.extend(end)
        placed = np.array([beacon_of[r] in sweep.placed for r in chunk], dtype=bool)
        _observe(sweep, settings, chunk[placed], pose_rows, beacon_of, azimuths, where, width)
        seen_so_far = order[:stop]
        for b in sorted(set(beacon_of[chunk[~placed]].tolist()) - hopeless):
            rows = seen_so_far[beacon_of[seen_so_far] == b]
            guess, _ = first_guess(sweep.poses[pose_rows[rows]], azimuths[rows])
            if np.isfinite(guess).all():
                sweep.place(b, guess)
                where[b] = guess
                _observe(sweep, settings, rows, pose_rows, beacon_of, azimuths, where, width)
        sweep.update()
    return sweep.estimate()


def _observe(sweep: Sweep, settings: Settings, rows: IntArray, pose_rows: IntArray,
             beacon_of: IntArray, azimuths: FloatArray, where: FloatArray,
             width: FloatArray) -> None:
    """The detections ``rows`` (of placed beacons) added to the sweep."""
    beacons = beacon_of[rows]
    sigmas = azimuth_sigmas(settings, sweep.poses[pose_rows[rows]], where[beacons],
                            width[beacons])
    for pose, beacon, azimuth, sigma in zip(pose_rows[rows].tolist(), beacons.tolist(),
                                            azimuths[rows].tolist(), sigmas.tolist(),
                                            strict=True):
        sweep.observe(pose, beacon, azimuth, sigma)


def _placed(drive: Drive, poses: FloatArray, anchors: dict[int, FloatArray], ids: IntArray,
            local_rows: IntArray, beacon_of: IntArray, azimuths: FloatArray,
            count: int) -> FloatArray:
    """A drive without a start, moved onto the map by the anchors it observes (rigid fit)."""
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
    if len(seen) < 2:
        raise InvalidInputError(
            f"{drive.name} has no known start pose and observes {len(seen)} anchor"
            f"{'' if len(seen) == 1 else 's'} from a wide enough baseline; it needs its start "
            "pose or at least two observed anchors to be placed on the map")
    turn, shift = _rigid(np.array(seen), np.array(wanted))
    placed = poses.copy()
    placed[:, :2] = poses[:, :2] @ turn.T + shift
    placed[:, 2] = np.remainder(poses[:, 2] + math.atan2(turn[1, 0], turn[0, 0]) + math.pi,
                                2.0 * math.pi) - math.pi
    return placed


def _rigid(source: FloatArray, target: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The rotation and shift that best carry ``source`` points onto ``target`` (Kabsch)."""
    a, b = source - source.mean(axis=0), target - target.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    turn = vt.T @ np.diag([1.0, d]) @ u.T
    return turn, target.mean(axis=0) - source.mean(axis=0) @ turn.T


def _solved(base: Graph, offsets: IntArray, prior: Prior, settings: Settings, ids: IntArray,
            pose_rows: IntArray, beacon_of: IntArray, azimuths: FloatArray,
            guesses: FloatArray, reasons: list[str]) -> Survey:
    """The graph of the observable beacons, solved, and the answer."""
    used: np.ndarray = np.asarray(np.isfinite(guesses).all(axis=1))
    column = np.cumsum(used) - 1
    keep = used[beacon_of]
    sigmas = azimuth_sigmas(settings, base.poses[pose_rows[keep]], guesses[beacon_of[keep]],
                     widths(prior, ids)[beacon_of[keep]])
    anchor_ids = set(prior.anchors)
    graph = dataclasses.replace(
        base, beacons=guesses[used],
        anchors=np.array([column[b] for b, i in enumerate(ids.tolist())
                          if used[b] and i in anchor_ids], dtype=np.int64),
        rows=np.column_stack([pose_rows[keep], column[beacon_of[keep]]]).astype(np.int64),
        azimuths=azimuths[keep], sigmas=sigmas)
    solution = solve(graph, settings)
    outlying = np.abs(solution.residuals) > settings.loss_scale * sigmas
    xy = np.full((len(ids), 2), np.nan)
    xy[used] = solution.beacons
    rays = np.bincount(beacon_of, minlength=len(ids))
    outlier_rays = np.bincount(beacon_of[keep][outlying], minlength=len(ids))
    observable = used & ~np.isin(ids, list(anchor_ids))
    strain = _strain(solution.residuals[~outlying] / sigmas[~outlying])
    for b in np.flatnonzero(observable).tolist():
        mine = np.flatnonzero(beacon_of[keep] == b)
        good = mine[~outlying[mine]]
        directions = solution.poses[graph.rows[good, 0], 2] + graph.azimuths[good]
        if strain:
            reasons[b] = strain
        elif good.size < max(MIN_RAYS, MIN_AGREEING * mine.size) \
                or spread(directions) < MIN_SPREAD:
            reasons[b] = (f"its azimuths disagree: {outlier_rays[b]} of {mine.size} set aside "
                          "as outliers, the rest too few or too narrow a baseline")
        observable[b] = not reasons[b]
    observable |= used & np.isin(ids, list(anchor_ids))
    xy[~observable] = np.nan
    covariances = np.full((len(ids), 2, 2), np.nan)
    covariances[used] = graph_covariances(graph, solution, settings, observable[used])
    result = Survey(ids=ids, xy=xy, covariances=covariances, observable=observable,
                    reasons=tuple(reasons), rays=rays, outlier_rays=outlier_rays,
                    anchors=tuple(sorted(anchor_ids)), moved=(),
                    poses=tuple(np.split(solution.poses, offsets[1:-1])),
                    outliers=int(outlying.sum()), iterations=solution.iterations)
    if prior.beacons is None:
        return result
    return Survey(**{**result.__dict__, "moved": moved(result, prior.beacons, anchor_ids)})


def _strain(agreeing: FloatArray) -> str:
    """Why no beacon is surveyed when the azimuths that agree strain (:data:`MAX_STRAIN`), or ''.

    ``agreeing``: their residuals over their standard deviations.
    """
    strain = float(np.mean(agreeing**2)) if agreeing.size else 0.0
    if strain <= MAX_STRAIN:
        return ""
    return (f"the azimuths strain against the motion: those that agree average {strain:.2f} "
            f"times their modelled variance (more than {MAX_STRAIN:.0f}), so the profile's "
            "motion or azimuth noise is understated and the solved map bent")


def moved(result: Survey, prior: BeaconMap, anchors: set[int] | None = None) -> tuple[int, ...]:
    """The surveyed beacons whose prior position the survey contradicts.

    A beacon moved when its surveyed position is at least :data:`MIN_MOVE` from its prior one
    and the squared Mahalanobis distance under its covariance is at least :data:`MOVE_CHI2`.
    Anchors are held, never tested.
    """
    found = []
    held = anchors or set()
    for b in np.flatnonzero(result.observable).tolist():
        beacon = int(result.ids[b])
        index = np.flatnonzero(prior.ids == beacon)
        if beacon in held or not index.size:
            continue
        offset = result.xy[b] - prior.xyz[index[0], :2]
        distance2 = float(offset @ np.linalg.solve(result.covariances[b], offset))
        if math.hypot(*offset) >= MIN_MOVE and distance2 >= MOVE_CHI2:
            found.append(beacon)
    return tuple(found)

"""``survey``: every beacon's position from drives, as bearing-only SLAM (docs/mapping.md).

1. Odometry: each drive's relative camera poses, their covariances and their derivatives with
   respect to the turn rate's bias and the odometry's scale error
   (:mod:`azgym.mapping.odometry`), dead-reckoned from its known start, or from the origin. A
   drive without a known start is placed by the anchors it observes (at least two: a rigid fit
   of their guesses onto their map positions, :func:`~azgym.mapping.map_frame.placed`).
2. The drives solved frame by frame (:func:`_swept`, :class:`~azgym.mapping.sweep.Sweep`; the
   anchors and the beacons a site's map holds, :attr:`~azgym.mapping.problem.Prior.mapped`,
   placed from the start at their map positions), from which the first guesses: each id's
   rays from the poses, intersected (:func:`~azgym.localize.bearings.intersect_robustly`; a
   held beacon's map position instead when its rays agree with it, :func:`first_guess`); an
   id whose rays do not spread enough (:func:`~azgym.localize.bearings.spread`) or are too few
   is unobservable, its detections left out. With the site's map as the prior, an id it does
   not hold (a misread id) is not surveyed, only counted
   (:attr:`~azgym.mapping.problem.Prior.ids`).
3. The factor graph (:mod:`azgym.mapping.graph`: a site's map's beacons held by it, behind the
   robust loss), solved; a beacon whose azimuths then mostly disagree with it (robust
   outliers: fewer than :data:`MIN_AGREEING` of them agree), or whose agreeing rays no longer
   spread enough, is reported unobservable too, and left out of the graph whose marginals give
   the others' covariances.
4. With a site's map, each surveyed beacon it holds is tested for a move on its position
   without its own map prior (:func:`_moves`, :func:`~azgym.mapping.moves.contradicts`); those
   found moved are freed of their priors and the graph solved again (at most
   :data:`MOVE_ROUNDS` solves).

The map frame is fixed by a known start pose or by at least two anchors; anything less leaves it
free, and is refused by name (:mod:`azgym.mapping.map_frame`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from azgym.core import BeaconMap, FloatArray, IntArray
from azgym.errors import InvalidInputError
from azgym.localize.bearings import MIN_RAYS, MIN_SPREAD, spread
from azgym.mapping.first_guess import (
    DEFAULT_WIDTH,
    MIN_AGREEING,
    anchor_positions,
    azimuth_sigmas,
    first_guess,
    seen,
    widths,
)
from azgym.mapping.graph import Graph, Solution, left_out, skeleton, solve
from azgym.mapping.graph import covariances as graph_covariances
from azgym.mapping.map_frame import placed, require_fixed
from azgym.mapping.moves import contradicts
from azgym.mapping.odometry import compose, relative_poses
from azgym.mapping.problem import Drive, Prior, Settings, drive_list
from azgym.mapping.sweep import Sweep

__all__ = ["MAX_STRAIN", "MOVE_ROUNDS", "Survey", "survey"]

SWEEP_FRAMES = 10
"""Frames the sweep (:func:`_swept`) adds at a time."""
MAX_STRAIN = 1.0
"""Most the mean squared residual of the agreeing azimuths may reach, in their modelled variance,
for the survey to place beacons. The error model bounds the azimuth noise (uniform errors; a
consistent solve leaves 0.2-0.6 of it); a solve that strains the azimuths beyond it has bent
the map to fit a motion model that understates its noise (a robot's odometry taken for a
forklift's: 1.2-1.6, and its beacons decimetres off), so none is placed."""
MOVE_ROUNDS = 3
"""Most solves of a survey with a site's map as the prior: each frees the beacons the one
before found moved of their map priors (:func:`_solved`)."""


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
        moved: Ids of a site's map whose map position the survey contradicts, each judged
            without its own map prior (:func:`_moves`).
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
    require_fixed(drives, prior)
    odometry = [relative_poses(d, settings) for d in drives]
    reckoned = [compose(np.zeros(3) if d.start is None else np.array(d.start), o.moves)
                for d, o in zip(drives, odometry, strict=True)]
    ids, pose_rows, beacon_of, azimuths = _detections(drives)
    offsets = np.cumsum([0, *(len(d.frames) for d in drives)])
    anchors = anchor_positions(prior)
    for n, drive in enumerate(drives):
        if drive.start is None:
            reckoned[n] = placed(drive, reckoned[n], anchors, ids, pose_rows - offsets[n],
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
    anchors, mapped = anchor_positions(prior), prior.mapped
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
        guesses[b], reasons[b] = first_guess(poses[pose_rows[rows]], azimuths[rows],
                                             mapped.get(beacon))
    return guesses, reasons


def _swept(base: Graph, settings: Settings, prior: Prior, ids: IntArray,
           pose_rows: IntArray, beacon_of: IntArray, azimuths: FloatArray) -> FloatArray:
    """Every camera pose solved frame by frame (:class:`~azgym.mapping.graph.Sweep`).

    :data:`SWEEP_FRAMES` frames at a time: their poses from the odometry, their detections of
    beacons already placed, then each beacon not yet placed whose rays from the estimated poses
    now give a first guess (:func:`first_guess`) placed there with all its detections so far.
    Anchors and the beacons a site's map holds are placed from the start, at their map
    positions; an id the prior map lacks never is.
    """
    anchors, mapped = anchor_positions(prior), prior.mapped
    index = {int(i): b for b, i in enumerate(ids.tolist())}
    sweep = Sweep(base, settings, {index[a]: xy for a, xy in anchors.items() if a in index},
                  {index[m]: xy for m, xy in mapped.items() if m in index})
    known = prior.ids
    hopeless = {b for b, i in enumerate(ids.tolist()) if known is not None and i not in known}
    where = np.full((len(ids), 2), np.nan)
    for b in sweep.placed:
        where[b] = {**anchors, **mapped}[int(ids[b])]
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


def _solved(base: Graph, offsets: IntArray, prior: Prior, settings: Settings, ids: IntArray,
            pose_rows: IntArray, beacon_of: IntArray, azimuths: FloatArray,
            guesses: FloatArray, reasons: list[str]) -> Survey:
    """The graph of the observable beacons, solved, and the answer.

    With a site's map as the prior, its beacons are held by it; a beacon the solve finds moved
    (:func:`_moves`) is freed of its map prior and the graph solved again (the others' test
    then free of its pull), at most :data:`MOVE_ROUNDS` solves in all.
    """
    used: np.ndarray = np.asarray(np.isfinite(guesses).all(axis=1))
    column = np.cumsum(used) - 1
    keep = used[beacon_of]
    sigmas = azimuth_sigmas(settings, base.poses[pose_rows[keep]], guesses[beacon_of[keep]],
                            widths(prior, ids)[beacon_of[keep]])
    anchor_ids, mapped = set(prior.anchors), prior.mapped
    held = np.array([b for b, i in enumerate(ids.tolist()) if used[b] and i in mapped],
                    dtype=np.int64)
    graph = dataclasses.replace(
        base, beacons=guesses[used],
        anchors=np.array([column[b] for b, i in enumerate(ids.tolist())
                          if used[b] and i in anchor_ids], dtype=np.int64),
        priors=column[held].astype(np.int64),
        prior_xy=np.array([mapped[int(ids[b])] for b in held]).reshape(-1, 2),
        rows=np.column_stack([pose_rows[keep], column[beacon_of[keep]]]).astype(np.int64),
        azimuths=azimuths[keep], sigmas=sigmas)
    freed = np.zeros(len(held), dtype=bool)
    for _ in range(MOVE_ROUNDS):
        holding = dataclasses.replace(graph, priors=graph.priors[~freed],
                                      prior_xy=graph.prior_xy[~freed])
        solution = solve(holding, settings)
        outlying = np.abs(solution.residuals) > settings.loss_scale * sigmas
        observable, found_reasons = _checked(holding, solution, outlying, ids, used, anchor_ids,
                                             beacon_of[keep], list(reasons))
        covariances = np.full((len(ids), 2, 2), np.nan)
        covariances[used] = graph_covariances(holding, solution, settings, observable[used])
        said = _moves(graph, holding, solution, settings, covariances[used], freed,
                      observable[held])
        if not (said & ~freed).any():
            break
        freed |= said
        graph = dataclasses.replace(graph, poses=solution.poses, beacons=solution.beacons)
    xy = np.full((len(ids), 2), np.nan)
    xy[observable] = solution.beacons[column[observable]]
    return Survey(ids=ids, xy=xy, covariances=covariances, observable=observable,
                  reasons=tuple(found_reasons), rays=np.bincount(beacon_of, minlength=len(ids)),
                  outlier_rays=np.bincount(beacon_of[keep][outlying], minlength=len(ids)),
                  anchors=tuple(sorted(anchor_ids)),
                  moved=tuple(sorted(int(ids[b]) for b in held[said].tolist())),
                  poses=tuple(np.split(solution.poses, offsets[1:-1])),
                  outliers=int(outlying.sum()), iterations=solution.iterations)


def _checked(graph: Graph, solution: Solution, outlying: np.ndarray, ids: IntArray,
             used: np.ndarray, anchors: set[int], beacon_of: IntArray,
             reasons: list[str]) -> tuple[np.ndarray, list[str]]:
    """Which beacons the solve keeps (anchors always), and why each other is not.

    A beacon (not an anchor) is not kept when the azimuths strain against the motion
    (:func:`_strain`: then none is), or when fewer than :data:`MIN_AGREEING` of its detections
    (or fewer than :data:`~azgym.localize.bearings.MIN_RAYS`) agree with it, or the agreeing
    ones spread too little.

    Args:
        graph: The graph solved.
        solution: Its solution.
        outlying: Which of its detections the robust loss set aside.
        ids: Every id.
        used: Which are in the graph.
        anchors: The anchors' ids.
        beacon_of: Each of the graph's detections' id index.
        reasons: Each id's reason so far ('' when none), updated and returned.
    """
    observable = used & ~np.isin(ids, list(anchors))
    strain = _strain(solution.residuals[~outlying] / graph.sigmas[~outlying])
    for b in np.flatnonzero(observable).tolist():
        mine = np.flatnonzero(beacon_of == b)
        good = mine[~outlying[mine]]
        directions = solution.poses[graph.rows[good, 0], 2] + graph.azimuths[good]
        if strain:
            reasons[b] = strain
        elif good.size < max(MIN_RAYS, MIN_AGREEING * mine.size) \
                or spread(directions) < MIN_SPREAD:
            reasons[b] = (f"its azimuths disagree: {int(outlying[mine].sum())} of {mine.size} "
                          "set aside as outliers, the rest too few or too narrow a baseline")
        observable[b] = not reasons[b]
    return observable | (used & np.isin(ids, list(anchors))), reasons


def _moves(graph: Graph, holding: Graph, solution: Solution, settings: Settings,
           covariances: FloatArray, freed: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """Which of the map-held beacons (``graph.priors``) moved, each judged without its prior.

    A beacon still held (``~freed``) is judged on where the rest of the graph puts it
    (:func:`~azgym.mapping.graph.left_out`), a freed one on its own solved position; either
    against its map position, under the two's covariances summed (the map's own, ``map_sigma``
    each way), by :func:`~azgym.mapping.moves.contradicts`. Only ``kept`` beacons (observable
    once solved) are.

    Args:
        graph: The graph with every map prior.
        holding: The one solved (the freed ones' priors left out).
        solution: Its solution.
        settings: The map's accuracy and the robust loss.
        covariances: (B, 2, 2) the beacons' marginal covariances at ``solution``.
        freed: Which of ``graph.priors`` were left out.
        kept: Which of them are observable.
    """
    positions = solution.beacons[graph.priors]
    spread_of = covariances[graph.priors]
    positions[~freed], spread_of[~freed] = left_out(holding, solution, settings, covariances)
    own = settings.map_sigma**2 * np.eye(2)
    return np.array([bool(k) and np.isfinite(c).all() and contradicts(p - m, c + own)
                     for p, m, c, k in zip(positions, graph.prior_xy, spread_of, kept,
                                           strict=True)], dtype=bool)


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

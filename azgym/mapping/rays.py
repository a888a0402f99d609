"""The beacons placed by their rays alone: dead reckoning, then each id's rays intersected.

The ``rays`` mapper's method, the survey's first guess made an answer (no factor graph):

1. **Dead reckoning**: the camera's poses from the drive's start by the trackers' own motion
   model (:class:`~azgym.track.unicycle.MotionSteps`, :func:`~azgym.track.unicycle.predict`),
   with the covariance that model carries (its turn-rate bias and odometry scale error held
   over the drive, so the drift they cause grows as it does). A drive without a start is
   reckoned from the origin and placed by its anchors (step 3).
2. **Each id's rays** (the camera's heading plus the azimuth, from its position) intersected
   robustly (:func:`~azgym.localize.bearings.intersect_robustly`); an id is placed when the rays
   agreeing with the point (:func:`~azgym.localize.bearings.agreeing`) are at least
   :data:`~azgym.localize.bearings.MIN_RAYS` and spread at least
   :data:`~azgym.localize.bearings.MIN_SPREAD` (the survey's observability rule,
   :func:`~azgym.mapping.first_guess.unmet`). Its
   position is those rays' weighted intersection (:func:`~azgym.localize.bearings.intersect_rays`,
   each azimuth weighed by eq. 1-3 at its range plus the pose's heading variance), and its
   covariance that intersection's plus the rays' shared pose error: dead reckoning's drift moves
   neighbouring poses together, so the mean covariance of the rays' poses is carried whole
   through the point (a shift moves it as much; a turn as the rays' meeting point turns). As in
   the survey, an id a site map lacks (a misread one) is not placed, and anchors are held.
3. **Anchors**: a drive without a start is turned and shifted so that its anchors' intersections
   fall on their map positions (at least two observed anchors: else refused by name, as the
   survey refuses, :mod:`azgym.mapping.map_frame`).
4. With a prior map, each placed beacon's move is the survey's test
   (:func:`azgym.mapping.moves.moved`).
"""

from __future__ import annotations

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.errors import InvalidInputError
from azgym.localize.bearings import intersect_rays, intersect_robustly, meeting_point
from azgym.mapping.first_guess import (
    MIN_RANGE,
    agreeing,
    anchor_positions,
    azimuth_variances,
    too_few,
    unmet,
    widths,
)
from azgym.mapping.graph import START_STD
from azgym.mapping.map_frame import carried, require_anchors, require_fixed, rigid
from azgym.mapping.moves import moved
from azgym.mapping.odometry import motion_steps
from azgym.mapping.problem import Drive, Prior, Settings
from azgym.mapping.survey import Survey
from azgym.track.unicycle import IBIAS, ISCALE, STATE_SIZE, predict

__all__ = ["dead_reckoned", "require_frames", "survey_by_rays"]

TURN_STEP = 1e-6
"""The heading step of the point's numerical derivative with respect to a shared turn [rad]."""


def survey_by_rays(drive: Drive, prior: Prior, settings: Settings) -> Survey:
    """Every id of ``drive`` placed by its rays (module docstring), as a :class:`Survey`.

    Raises:
        InvalidInputError: No frames; no start pose and fewer than two anchors; a drive without
            a start that observes fewer than two anchors from a wide enough baseline.
    """
    require_frames(drive)
    require_fixed([drive], prior)
    poses, pose_cov = dead_reckoned(drive, settings)
    ids, rows, frames, azimuths = _detections(drive)
    width = widths(prior, ids)
    xy = np.full((len(ids), 2), np.nan)
    cov = np.full((len(ids), 2, 2), np.nan)
    reasons = [""] * len(ids)
    known, anchors = prior.ids, set(prior.anchors)
    order = np.argsort(rows, kind="stable")
    groups = np.split(order, np.flatnonzero(np.diff(rows[order])) + 1) if rows.size else []
    for b, (beacon, mine) in enumerate(zip(ids.tolist(), groups, strict=True)):
        if known is not None and beacon not in known:
            reasons[b] = "not in the prior map (a misread id)"
            continue
        xy[b], cov[b], reasons[b] = _located(poses[frames[mine]], pose_cov[frames[mine]],
                                             azimuths[mine], float(width[b]), settings)
    if drive.start is None:
        poses, xy, cov = _placed(drive, anchor_positions(prior), ids, poses, xy, cov)
    held = np.isin(ids, list(anchors))
    xy[held], cov[held] = np.nan, np.nan
    observable = np.isfinite(xy).all(axis=1)
    for b in np.flatnonzero(held).tolist():
        reasons[b] = "an anchor: held at its map position"
    result = Survey(ids=ids, xy=xy, covariances=cov, observable=observable,
                    reasons=tuple(reasons), rays=np.bincount(rows, minlength=len(ids)),
                    outlier_rays=np.zeros(len(ids), np.int64), anchors=tuple(sorted(anchors)),
                    moved=(), poses=(poses,), outliers=0, iterations=0)
    if prior.beacons is None:
        return result
    return Survey(**{**result.__dict__,
                     "moved": moved(ids, xy, cov, observable, prior.beacons, anchors)})


def require_frames(drive: Drive) -> None:
    """Refuse a drive without frames, by name (every built-in mapper does).

    Raises:
        InvalidInputError: The drive has no frames.
    """
    if not drive.frames:
        raise InvalidInputError(f"{drive.name} has no frames: there is nothing to survey")


def dead_reckoned(drive: Drive, settings: Settings) -> tuple[FloatArray, FloatArray]:
    """The camera's dead-reckoned poses and their covariances (module docstring).

    Returns:
        (K, 3) each frame's pose from the drive's start (or the origin), and (K, 3, 3) its
        covariance by the trackers' motion model.
    """
    steps = motion_steps(settings)
    state = np.zeros(STATE_SIZE)
    cov = np.zeros((STATE_SIZE, STATE_SIZE))
    if drive.start is not None:
        state[:3] = drive.start
        cov[:3, :3] = np.diag(np.square(START_STD))
    cov[IBIAS, IBIAS] = settings.turn_rate_bias ** 2
    cov[ISCALE, ISCALE] = settings.noise.speed_scale ** 2
    poses = np.zeros((len(drive.frames), 3))
    covariances = np.zeros((len(drive.frames), 3, 3))
    for k, frame in enumerate(drive.frames):
        for step in steps.steps(frame.motion):
            predict(state, cov, step, settings.lever, settings.noise)
        poses[k], covariances[k] = state[:3], cov[:3, :3]
    return poses, covariances


def _detections(drive: Drive) -> tuple[IntArray, IntArray, IntArray, FloatArray]:
    """Every id detected (sorted), and each detection's id index, frame index and azimuth."""
    values = [frame.measurements.ids for frame in drive.frames]
    ids, rows = np.unique(np.concatenate(values), return_inverse=True)
    frames = np.repeat(np.arange(len(values)), [len(v) for v in values])
    azimuths = np.concatenate([frame.measurements.azimuth for frame in drive.frames])
    return ids.astype(np.int64), rows.astype(np.int64), frames, azimuths


def _located(poses: FloatArray, pose_cov: FloatArray, azimuths: FloatArray, width: float,
             settings: Settings) -> tuple[FloatArray, FloatArray, str]:
    """One id's point and covariance from its rays, or NaN and why it is unobservable."""
    nothing = np.full(2, np.nan), np.full((2, 2), np.nan)
    bearings = poses[:, 2] + azimuths
    if reason := too_few(len(bearings)):
        return *nothing, reason
    point, _ = intersect_robustly(poses[:, :2], bearings)
    agree = agreeing(poses[:, :2], bearings, point)
    if reason := unmet(bearings, point, agree):
        return *nothing, reason
    origins, bearings, shared = poses[agree, :2], bearings[agree], pose_cov[agree].mean(axis=0)
    distance = np.maximum(np.hypot(*(point - origins).T), MIN_RANGE)
    noise = azimuth_variances(settings, distance, width)
    point, cov, _ = intersect_rays(origins, bearings, noise, np.zeros((len(bearings), 2, 2)))
    weights = 1.0 / (np.square(distance) * noise)
    turned = (meeting_point(origins, bearings + TURN_STEP, weights)
              - meeting_point(origins, bearings - TURN_STEP, weights)) / (2.0 * TURN_STEP)
    jacobian = np.column_stack([np.eye(2), turned])
    cov = cov + jacobian @ shared @ jacobian.T
    return point, 0.5 * (cov + cov.T), ""


def _placed(drive: Drive, anchors: dict[int, FloatArray], ids: IntArray, poses: FloatArray,
            xy: FloatArray, cov: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A drive without a start, turned and shifted so that its anchors fall on the map."""
    local, wanted = [], []
    for anchor, position in anchors.items():
        found = np.flatnonzero(ids == anchor)
        if found.size and np.isfinite(xy[found[0]]).all():
            local.append(xy[found[0]])
            wanted.append(position)
    require_anchors(drive, len(local))
    rotation, offset = rigid(np.array(local), np.array(wanted))
    return (carried(poses, rotation, offset), xy @ rotation.T + offset,
            rotation @ cov @ rotation.T)

"""The figures a driven route shares with a real recording: what docs/robot.md states, measured.

:func:`route_figures` measures one driven route (the frames of
:func:`azgym.world.drive.simulate`) as one would measure a real recording: landmarks per frame,
the odometry's intervals, its heading drift over 1 s and its distance scale against the truth.
``python -m azgym.world.robot_figures [SCENARIO] [SEED]`` prints them for every route of a
scenario (default ``robot-arena``, seed 0).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from azgym.core import FloatArray
from azgym.site import Scenario, load_scenario
from azgym.world.drive import Frame, simulate

__all__ = ["RouteFigures", "odometry_heading", "route_figures"]

BUSY = (0.020, 0.050)
"""The intervals [s] a busy logger leaves between odometry samples (counted as a share)."""
GAP = 0.1
"""An interval longer than this [s] is a gap."""
DRIFT_WINDOW = 1.0
"""The window of the heading drift [s]."""


@dataclass(frozen=True)
class RouteFigures:
    """One route's figures (module docstring).

    Attributes:
        frames: Camera frames.
        seconds: The route's duration [s].
        landmarks_mean: Map landmarks detected per frame, mean over every frame.
        landmarks_mean_seen: The same over the frames that detect at least one.
        share_three: Share of frames with 3 or more map landmarks.
        share_none: Share of frames with none.
        unmapped_share: Share of detections whose codes are not in the map.
        max_bearing: The largest |measured azimuth| [rad].
        samples: Odometry samples.
        median_interval: Median interval between odometry stamps [s].
        busy_share: Share of intervals in ``BUSY``.
        gaps: Intervals longer than ``GAP``.
        repeated_share: Share of intervals of zero (a repeated stamp).
        drift_rms: RMS over 1 s windows of (odometry's heading change − true heading change)
            [rad].
        distance_ratio: Distance the odometry reads over the true distance of the turning axis.
    """

    frames: int
    seconds: float
    landmarks_mean: float
    landmarks_mean_seen: float
    share_three: float
    share_none: float
    unmapped_share: float
    max_bearing: float
    samples: int
    median_interval: float
    busy_share: float
    gaps: int
    repeated_share: float
    drift_rms: float
    distance_ratio: float


def odometry_heading(time: FloatArray, yaw_rate: FloatArray, at: FloatArray) -> FloatArray:
    """The heading change the odometry reads from its first stamp to each time of ``at`` [rad].

    Each sample holds until the next (a zero-order hold, as the trackers integrate it); the
    last holds on.
    """
    held = np.diff(time) * yaw_rate[:-1]
    cumulative = np.concatenate([[0.0], np.cumsum(held)])
    last = np.searchsorted(time, at, side="right") - 1
    return cumulative[last] + (at - time[last]) * yaw_rate[last]


def _axle(scenario: Scenario, poses: FloatArray) -> FloatArray:
    """The turning axis' positions (F, 2) under the camera poses (F, 3)."""
    ahead = scenario.vehicle.robot_camera_ahead
    return poses[:, :2] - ahead * np.column_stack([np.cos(poses[:, 2]), np.sin(poses[:, 2])])


def route_figures(scenario: Scenario, frames: Sequence[Frame]) -> RouteFigures:
    """Measure one driven route of a differential-drive scenario (:class:`RouteFigures`)."""
    mapped = [np.isin(f.measurements.ids, scenario.beacons.ids) for f in frames]
    counts = np.array([int(m.sum()) for m in mapped])
    detections = sum(m.size for m in mapped)
    time = np.concatenate([f.odometry.time for f in frames])
    speed = np.concatenate([f.odometry.speed for f in frames])
    yaw_rate = np.concatenate([f.odometry.yaw_rate for f in frames])
    intervals = np.diff(time)
    poses = np.array([f.pose for f in frames])
    frame_time = np.array([f.time for f in frames])
    # Frames one window apart, both after the first odometry stamp.
    step = max(1, round(DRIFT_WINDOW / float(np.median(np.diff(frame_time)))))
    usable = np.flatnonzero(frame_time >= time[0])
    start, end = usable[:-step], usable[step:]
    read = odometry_heading(time, yaw_rate, frame_time)
    true = np.unwrap(poses[:, 2])
    drift = (read[end] - read[start]) - (true[end] - true[start])
    axle = _axle(scenario, poses)
    travelled = float(np.hypot(*np.diff(axle[usable], axis=0).T).sum())
    read_distance = float(np.sum(np.diff(time) * speed[:-1]))
    return RouteFigures(
        frames=len(frames), seconds=float(frame_time[-1] - frame_time[0]),
        landmarks_mean=float(counts.mean()),
        landmarks_mean_seen=float(counts[counts > 0].mean()) if (counts > 0).any() else 0.0,
        share_three=float(np.mean(counts >= 3)), share_none=float(np.mean(counts == 0)),
        unmapped_share=1.0 - float(counts.sum()) / max(detections, 1),
        max_bearing=max((float(np.abs(f.measurements.azimuth).max()) for f in frames
                         if len(f.measurements)), default=0.0),
        samples=int(time.size), median_interval=float(np.median(intervals)),
        busy_share=float(np.mean((intervals >= BUSY[0]) & (intervals <= BUSY[1]))),
        gaps=int(np.count_nonzero(intervals > GAP)),
        repeated_share=float(np.mean(intervals == 0.0)),
        drift_rms=float(np.sqrt(np.mean(drift ** 2))),
        distance_ratio=read_distance / travelled)


def main(argv: Sequence[str]) -> int:
    """Print every route's figures: ``[SCENARIO] [SEED]``."""
    scenario = load_scenario(argv[0] if argv else "robot-arena")
    seed = int(argv[1]) if len(argv) > 1 else 0
    print(f"{'route':<10} {'min':>5} {'lm/fr':>6} {'seen':>5} {'>=3':>5} {'none':>5} "
          f"{'unmap':>5} {'|az|':>5} {'med ms':>6} {'20-50':>5} {'gaps':>4} {'rep':>5} "
          f"{'deg/s':>5} {'dist':>5}")
    for k, route in enumerate(scenario.routes):
        f = route_figures(scenario, list(simulate(scenario, route, seed=seed + k)))
        print(f"{route.name:<10} {f.seconds / 60:5.1f} {f.landmarks_mean:6.2f} "
              f"{f.landmarks_mean_seen:5.2f} {f.share_three:5.3f} {f.share_none:5.3f} "
              f"{f.unmapped_share:5.3f} {f.max_bearing:5.3f} {1000 * f.median_interval:6.1f} "
              f"{f.busy_share:5.3f} {f.gaps:4d} {f.repeated_share:5.3f} "
              f"{math.degrees(f.drift_rms):5.2f} {f.distance_ratio:5.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

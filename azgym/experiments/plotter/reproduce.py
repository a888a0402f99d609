"""Plotter's simulation reproduced (Dang et al. 2015, Sec. V-A, Fig. 5(c)): TKF, LPKF, naive.

100 runs of one 10-second lap of the 0.22 m square (:mod:`~azgym.experiments.plotter.trail`),
each with its own noise and phone heading. Each run is tracked three ways: ``tkf`` and ``lpkf``
(:mod:`azgym.track.inertial_kalman`, started at the known start pose, the camera at the IMU), and
the naive accumulation of accelerations of the paper's eq. 2-3 (turned into the world frame by the
orientation sensor, never corrected). The errors of every camera frame of every run are pooled,
as the paper's cumulative distribution pools them; the naive method is also run for four laps,
to compare with the paper's "10 m in 40 s".
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from azgym.core import BeaconMap
from azgym.errors import InvalidInputError
from azgym.experiments.plotter.trail import CAMERA_HZ, LAP, beacon_ring, imu_samples, trail_state
from azgym.progress import Progress, counter
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples
from azgym.sensing.synthetic import noisy_measurements
from azgym.site.error_model import ErrorModel
from azgym.track.base import make_tracker

__all__ = ["METHODS", "reproduce_plotter"]

PAPER = {"lpkf_p90": 0.026, "naive_at_40s": 10.0}
"""The paper's figures: LPKF's 90 % error bound [m] (Fig. 5(c)), the naive error after 40 s [m]."""
METHODS = ("tkf", "lpkf", "naive")
NAIVE_LAPS = 4


def reproduce_plotter(seed: int = 0, runs: int = 100, progress: Progress | None = None
                      ) -> dict[str, Any]:
    """Run the reproduction; return each method's pooled errors and their percentiles.

    ``progress`` hears the count of runs done.

    Returns:
        ``errors`` (method → per-frame position errors [m], every run pooled), ``p50``/``p90``
        (method → percentile [m]), ``naive_at_40s`` (the naive error after four laps, median
        over runs [m]), ``paper`` (the paper's figures) and the run's settings.
    """
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise InvalidInputError(f"runs must be a whole number >= 1, got {runs!r}")
    beacons = beacon_ring()
    errors: dict[str, list[float]] = {method: [] for method in METHODS}
    naive_end = []
    with counter(progress, "plotter", runs, "runs") as count:
        for done, stream in enumerate(np.random.SeedSequence(seed).spawn(runs), 1):
            imu_rng, camera_rng, heading_rng = (np.random.default_rng(s)
                                                for s in stream.spawn(3))
            heading = float(heading_rng.uniform(-math.pi, math.pi))
            samples = imu_samples(NAIVE_LAPS * LAP, heading, imu_rng)
            frames = _camera_frames(heading, beacons, camera_rng)
            for name in ("tkf", "lpkf"):
                errors[name] += _track(name, frames, samples, beacons, heading)
            naive = _naive_positions(samples)
            errors["naive"] += [_error(naive, samples.time, t) for t, *_ in frames]
            naive_end.append(_error(naive, samples.time, NAIVE_LAPS * LAP))
            count(done)
    pooled = {name: np.array(values) for name, values in errors.items()}
    return {
        "seed": seed, "runs": runs, "lap_s": LAP, "camera_hz": CAMERA_HZ,
        "errors": pooled,
        "p50": {name: float(np.percentile(v, 50)) for name, v in pooled.items()},
        "p90": {name: float(np.percentile(v, 90)) for name, v in pooled.items()},
        "naive_at_40s": float(np.median(naive_end)),
        "paper": dict(PAPER),
    }


def _camera_frames(heading: float, beacons: BeaconMap, rng: np.random.Generator
                   ) -> list[tuple[float, Any]]:
    """Each camera frame of a lap: its time and the azimuths it measured."""
    frames = []
    for k in range(int(LAP * CAMERA_HZ) + 1):
        time = k / CAMERA_HZ
        x, y = trail_state(time).position
        frames.append((time, noisy_measurements(x, y, heading, beacons, ErrorModel(), rng)))
    return frames


def _track(name: str, frames: list[tuple[float, Any]], samples: ImuSamples, beacons: BeaconMap,
           heading: float) -> list[float]:
    """One tracker's position error at every frame (NaN where it gave no pose)."""
    tracker = make_tracker(name, camera_from_imu=0.0)
    tracker.reset(initial=(0.0, 0.0, heading))
    no_odometry = OdometrySamples(np.zeros(0), np.zeros(0), np.zeros(0))
    errors, previous = [], -math.inf
    for time, measurements in frames:
        span = (samples.time > previous) & (samples.time <= time)
        previous = time
        tracker.predict(Motion(time, no_odometry, ImuSamples(
            samples.time[span], samples.yaw_rate[span], samples.accel[span],
            samples.heading[span])))
        estimate = tracker.update(measurements, beacons)
        truth = trail_state(time).position
        errors.append(math.hypot(estimate.x - truth[0], estimate.y - truth[1])
                      if estimate.ok else math.nan)
    return errors


def _naive_positions(samples: ImuSamples) -> np.ndarray:
    """Eq. 2-3: accelerations turned to the world by the orientation sensor, summed twice.

    Each reading holds until the next (as in the trackers); the phone starts at rest at the
    origin. Returns the position at each sample time, shape (K, 2).
    """
    c, s = np.cos(samples.heading), np.sin(samples.heading)
    ax, ay = samples.accel[:, 0], samples.accel[:, 1]
    world = np.column_stack([c * ax - s * ay, s * ax + c * ay])
    dt = np.diff(samples.time, prepend=0.0)[:, None]
    held = np.vstack([np.zeros((1, 2)), world[:-1]])  # the reading before each span
    velocity = np.cumsum(held * dt, axis=0)
    position = np.cumsum((velocity - held * dt) * dt + 0.5 * held * dt * dt, axis=0)
    return position


def _error(positions: np.ndarray, times: np.ndarray, time: float) -> float:
    """Position error of the naive track at ``time`` (its last sample by then)."""
    k = int(np.searchsorted(times, time + 1e-9)) - 1
    estimate = positions[k] if k >= 0 else np.zeros(2)
    truth = trail_state(time).position
    return float(math.hypot(*(estimate - truth)))

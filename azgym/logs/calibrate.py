"""Calibrate a profile from a log with truth: ``azgym calibrate LOG --out PROFILE.toml``.

Each fit prints its value, a 95 % interval, the samples it used and how it was made:

* **Azimuth noise** (eq. 1-3: Δα_d and ``coverage``) and **field of view**, from each
  detection's residual against the true pose and the map (:mod:`azgym.logs.calibrate_sensor`,
  whose docstring gives each rule).
* **Motion** (:mod:`azgym.logs.calibrate_motion`): the speed factor, speed noise and scale walk
  from the odometry's speed against the true distance along the heading; the turn rate's white
  noise and bias walk from the odometry's ``yaw_rate`` (or the IMU's) against the true heading.
* **camera_ahead**: a camera ahead of the turning axis slides sideways by camera_ahead ·
  2 sin(Δφ / 2) in a frame interval turning by Δφ; least squares over the intervals (outlying
  ones dropped as for the motion fits), with a block-bootstrap interval as above. Not fitted
  when the slide the turn leaves unexplained exceeds :data:`MAX_SLIP` of the forward motion
  (snapshots far apart in time, noisy truth).

A frame whose time stamp repeated the one before (moved on by the reader,
:func:`azgym.logs.clocks.nudged`) has no known time: the intervals on either side of it are not
used. A speed factor beyond :data:`UNIT_FACTOR` either way is a unit mistake, not a fit, and is
not written. A log of one bootstrap block (under 5 s) gives its bootstrap fits no interval.

A fit needs what the log holds: no odometry, no speed fits; a log whose truth has no heading
gets the speed fits from the path length between frames (which takes the camera to sit on the
turning axis: a camera off it travels further in turns, and the factor reads high), and no
azimuth, turn-rate or camera fits. Each one left out is said, with why. The profile written is
the fits over the log's own profile (its manifest's sections); a vehicle kind the manifest does
not give is read from the odometry: a turn rate makes a differential drive, a steering angle a
forklift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from azgym import arguments
from azgym.core import FloatArray, wrap_angle
from azgym.errors import InvalidInputError
from azgym.logs.calibrate_motion import GROSS, fit_walk, integrate, not_gross
from azgym.logs.calibrate_sensor import MIN_DETECTIONS, block_interval, fit_azimuth
from azgym.logs.clocks import nudged
from azgym.logs.read import Log
from azgym.metrics import bootstrap_blocks
from azgym.profile import (
    DIFFERENTIAL_DRIVE,
    FORKLIFT,
    MotionProfile,
    Profile,
    SensorProfile,
    profile_toml,
)

__all__ = ["MAX_SLIP", "TURN_RATE_SOURCES", "UNIT_FACTOR", "Calibration", "Fit", "calibrate"]

TURN_RATE_SOURCES = ("auto", "odometry", "imu")
"""Where the turn rate is fitted from: ``auto`` takes the odometry's ``yaw_rate`` when it reports
one, else the IMU's."""
MOTION_METHOD = "max. likelihood, Kalman filter; profile-likelihood interval"
"""How the motion fits are made, as the table says it."""
SENSOR_FIELDS = ("sensor.delta_alpha_d", "sensor.coverage", "sensor.field_of_view")
"""The fields the detections give."""
MAX_SLIP = 0.25
"""camera_ahead is not fitted when what the turn leaves of the sideways slide (RMS) exceeds this
share of the forward distance (RMS): the frames do not move like one vehicle's arcs."""
UNIT_FACTOR = 2.0
"""A speed factor beyond this either way is not written: wear and tyres change an odometry's
scale by a few per cent, while times in milliseconds, or speeds in km/h or mm/s, change it by
1000, 3.6 or 1000."""
NO_INTERVAL = "; no interval: the log is one bootstrap block (under 5 s)"
"""The method's note of a bootstrap fit without an interval (:func:`block_interval`)."""


@dataclass(frozen=True)
class Fit:
    """One fitted parameter.

    Attributes:
        name: The profile's ``section.field`` it sets, or a name in brackets for a value the
            profile has no field for (printed, not written).
        value: The fit [the field's unit].
        interval: The 95 % interval, or None (a choice, not an estimate; or an estimate the
            log is too short to bound, as ``method`` says).
        samples: How many samples (detections, frame intervals) it used.
        method: How it was made, in a few words.
    """

    name: str
    value: float | bool
    interval: tuple[float, float] | None
    samples: int
    method: str


@dataclass(frozen=True, eq=False)
class Calibration:
    """What :func:`calibrate` found.

    Attributes:
        log_name: The log's dataset name.
        fits: Every fit, in the table's order.
        skipped: (parameter, why) of every parameter not fitted.
        base: The log's own profile (its manifest's), which the fits override.
        residuals: The residuals drawn (:func:`azgym.cli.calibrate.draw_residuals`): "azimuth"
            (distance [m], residual [rad], inlier), "speed" and "turn" (time [s], residual
            over its white noise's scale), "camera" (2 sin(Δφ/2), sideways slide [m]).
        notes: Counts worth knowing (detections left out, intervals used).
    """

    log_name: str
    fits: tuple[Fit, ...]
    skipped: tuple[tuple[str, str], ...]
    base: Profile
    residuals: dict[str, tuple[FloatArray, ...]] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def profile(self) -> Profile:
        """The fitted fields over the log's own profile."""
        sections: dict[str, dict[str, Any]] = {"vehicle": {}, "sensor": {}, "motion": {}}
        for fit in self.fits:
            if not fit.name.startswith("("):
                section, key = fit.name.split(".")
                sections[section][key] = fit.value
        vehicle = replace(self.base.vehicle, **sections["vehicle"])
        return Profile(vehicle, SensorProfile(**sections["sensor"]),
                       MotionProfile(**sections["motion"])).over(self.base)

    def table(self) -> str:
        """The fits as a table, then what was not fitted and why."""
        rows = [("parameter", "value", "95 % interval", "samples", "method")]
        for fit in self.fits:
            interval = "—" if fit.interval is None else \
                f"[{_number(fit.interval[0])}, {_number(fit.interval[1])}]"
            rows.append((fit.name, _number(fit.value), interval, str(fit.samples), fit.method))
        widths = [max(len(row[c]) for row in rows) for c in range(4)]
        lines = ["  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=False))
                 + "  " + row[4] for row in rows]
        lines += [f"not fitted: {name}: {why}" for name, why in self.skipped]
        fitted = {fit.name for fit in self.fits}
        lines += [f"from the log, not fitted: {section}.{key} = {_number(value)}"
                  for section, values in profile_toml(self.profile()).items()
                  for key, value in values.items() if f"{section}.{key}" not in fitted]
        return "\n".join([*lines, *self.notes])


def _number(value: float | bool | str) -> str:
    """A value as the table shows it: 4 significant digits, TOML's booleans, text quoted."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, str) else f"{value:.4g}"


@dataclass(frozen=True, eq=False)
class _Intervals:
    """The frame intervals a motion fit may use: consecutive frames of a sequence, no kidnap."""

    start: FloatArray
    end: FloatArray
    usable: np.ndarray
    forward: FloatArray
    turn: FloatArray
    side: FloatArray
    blocks: np.ndarray


def calibrate(log: Log, *, turn_rate: str = "auto", seed: int = 0) -> Calibration:
    """Fit a profile to a log with truth (module docstring).

    Args:
        log: The log (:func:`azgym.logs.read_log`).
        turn_rate: One of :data:`TURN_RATE_SOURCES`.
        seed: The bootstrap's seed (the same seed, the same intervals).

    Raises:
        InvalidInputError: The log has no truth, ``turn_rate`` is none of
            :data:`TURN_RATE_SOURCES`, or ``seed`` is no seed.
    """
    seed = arguments.seed("seed", seed)
    if turn_rate not in TURN_RATE_SOURCES:
        raise InvalidInputError(f"turn_rate: must be one of {', '.join(TURN_RATE_SOURCES)}, "
                                f"got {turn_rate!r}")
    if not log.has_truth:
        raise InvalidInputError(f"log {log.manifest.name!r}: frames.csv has no truth (x, y): "
                                "calibrating needs the true poses")
    frames = log.frames
    with_heading = log.has_heading and bool(np.isfinite(frames["heading"]).all())
    heading = frames["heading"] if with_heading else np.full(len(frames["time"]), np.nan)
    intervals = _intervals(log, heading)
    rng = np.random.default_rng(seed)
    fits: list[Fit] = []
    skipped: list[tuple[str, str]] = []
    residuals: dict[str, tuple[FloatArray, ...]] = {}
    notes: list[str] = []
    no_heading = "the truth has no heading"
    if with_heading:
        fits += _sensor(log, rng, skipped, residuals, notes)
        _camera_ahead(intervals, rng, fits, skipped, residuals)
    else:
        skipped += [(name, no_heading) for name in (*SENSOR_FIELDS, "vehicle.camera_ahead")]
    _speed(log, intervals, with_heading, fits, skipped, residuals)
    if with_heading:
        _turn_rate(log, intervals, turn_rate, fits, skipped, residuals)
    else:
        skipped += [(name, no_heading) for name in ("motion.turn_rate_noise", "motion.bias_walk")]
    skipped += [("motion.speed_scale", "one log shows one start of the scale error, not its "
                 "spread"), ("motion.heading_walk, motion.position_walk", "model errors of a "
                 "tracker, not of the sensors")]
    base = log.manifest.profile
    if base.vehicle.kind is None and log.odometry is not None:
        yaw = log.odometry.values.get("yaw_rate")
        kind = DIFFERENTIAL_DRIVE if yaw is not None and np.isfinite(yaw).any() else FORKLIFT
        base = replace(base, vehicle=replace(base.vehicle, kind=kind))
    notes.append(f"frame intervals: {int(intervals.usable.sum())} usable of "
                 f"{intervals.usable.size} (consecutive frames of a sequence, no kidnap)")
    return Calibration(log.manifest.name, tuple(fits), tuple(skipped), base, residuals,
                       tuple(notes))


def _sensor(log: Log, rng: np.random.Generator, skipped: list[tuple[str, str]],
            residuals: dict, notes: list[str]) -> list[Fit]:
    """The azimuth noise and field of view as fits."""
    fit = fit_azimuth(log, bootstrap_blocks(log.frames["sequence"], log.frames["time"]), rng)
    if fit is None:
        skipped += [(name, f"fewer than {MIN_DETECTIONS} detections of beacons in the map")
                    for name in SENSOR_FIELDS]
        return []
    residuals["azimuth"] = fit.residuals
    notes.append(fit.note)
    fov = fit.field_of_view
    return [Fit("sensor.delta_alpha_d", fit.delta_alpha_d, fit.delta_interval, fit.inliers,
                "eq. 3's variance, quasi-likelihood on eq. 25's inliers; block bootstrap"
                + ("" if fit.delta_interval else NO_INTERVAL)),
            Fit("sensor.coverage", fit.coverage, None, fit.inliers,
                f"Gaussian quasi-likelihood, coverage − none: {fit.coverage_gain:+.1f}"),
            Fit("sensor.field_of_view", fov[0], fov[1:], fit.inliers,
                "2 × largest |azimuth| of the inliers (2π past 150°)")]


def _intervals(log: Log, heading: FloatArray) -> _Intervals:
    """Each interval between consecutive frames: its true motion in the frame of its heading.

    An interval is usable between consecutive frames of a sequence, with no kidnap, and with
    neither end a frame whose time stamp repeated the one before (:func:`nudged`).
    """
    frames = log.frames
    time, x, y = frames["time"], frames["x"], frames["y"]
    sequence, event = np.asarray(frames["sequence"]), np.asarray(frames["event"])
    moved = nudged(time)
    usable = (sequence[1:] == sequence[:-1]) & (event[1:] != "kidnap") & ~moved[1:] & ~moved[:-1]
    dx, dy = np.diff(x), np.diff(y)
    turn = wrap_angle(np.diff(heading))
    middle = heading[:-1] + 0.5 * turn
    along = dx * np.cos(middle) + dy * np.sin(middle)
    half = 0.5 * turn
    arc = np.where(np.abs(half) > 1e-9, half / np.where(half == 0, 1.0, np.sin(half)), 1.0)
    forward = np.where(np.isfinite(middle), along * arc, np.hypot(dx, dy))
    side = -dx * np.sin(middle) + dy * np.cos(middle)
    blocks = bootstrap_blocks(list(sequence[:-1]), time[:-1])
    return _Intervals(time[:-1], time[1:], usable, forward, turn, side, blocks)


def _first(used: np.ndarray, intervals: _Intervals) -> np.ndarray:
    """Whether each used interval starts a stretch (the first used one of its sequence)."""
    order = np.flatnonzero(used)
    breaks = np.ones(order.size, dtype=bool)
    if order.size > 1:
        joined = intervals.usable[order[0]:order[-1] + 1]
        segment = np.cumsum(~joined)[order - order[0]]  # a new segment after each unusable one
        breaks[1:] = segment[1:] != segment[:-1]
    return breaks


def _walk_seconds(used: np.ndarray, first: np.ndarray, intervals: _Intervals) -> FloatArray:
    """Seconds the walk ran before each used interval's end: since the last used one's end."""
    end = intervals.end[used]
    start = intervals.start[used]
    return np.where(first, end - start, end - np.concatenate([[start[0]], end[:-1]]))


def _speed(log: Log, intervals: _Intervals, with_heading: bool, fits: list[Fit],
           skipped: list[tuple[str, str]], residuals: dict) -> None:
    """Speed factor, speed noise and scale walk from the odometry's speed."""
    names = ("motion.speed_factor", "motion.speed_noise", "motion.scale_walk")
    if log.odometry is None:
        skipped += [(name, "the log has no odometry") for name in names]
        return
    frames = log.frames["time"]
    read = integrate(frames, log.odometry["time"], log.odometry["speed"])
    used = intervals.usable & read.covered & (read.squares > 0)
    gross = int(used.sum())
    used[used] &= not_gross(read.total[used], intervals.forward[used], read.squares[used])
    gross -= int(used.sum())
    if used.sum() < 10 or not np.any(intervals.forward[used] != 0):
        skipped += [(name, "fewer than 10 frame intervals with odometry while moving")
                    for name in names]
        return
    first = _first(used, intervals)  # the read distance: the true one times the read scale
    fit = fit_walk(read.total[used], intervals.forward[used], read.squares[used],
                   _walk_seconds(used, first, intervals), first)
    scale, low, high = fit.start
    if not 1.0 / UNIT_FACTOR <= 1.0 / scale <= UNIT_FACTOR:
        skipped += [(name, f"the odometry reads {scale:.4g} × the true distance: another unit "
                     "(times in ms? speed in km/h or mm/s?)") for name in names]
        return
    how = "" if with_heading else " (no heading: path length, camera taken on the turning axis)"
    method = f"{MOTION_METHOD}{_dropped(gross)}{how}"
    fits += [Fit(names[0], 1.0 / scale, (1.0 / high, 1.0 / low), fit.samples, method),
             Fit(names[1], fit.white[0], fit.white[1:], fit.samples,
                 method + "; per sample, in read units"),
             Fit(names[2], fit.walk[0], fit.walk[1:], fit.samples, method)]
    error = read.total[used] - scale * intervals.forward[used]
    residuals["speed"] = (intervals.end[used], error / np.sqrt(read.squares[used]))


def _turn_rate(log: Log, intervals: _Intervals, source: str, fits: list[Fit],
               skipped: list[tuple[str, str]], residuals: dict) -> None:
    """Turn-rate noise and bias walk from the odometry's or the IMU's yaw rate."""
    names = ("motion.turn_rate_noise", "motion.bias_walk")
    odometry_rate = None if log.odometry is None else log.odometry.values.get("yaw_rate")
    has_odometry = odometry_rate is not None and bool(np.isfinite(odometry_rate).any())
    if source == "auto":
        source = "odometry" if has_odometry else "imu"
    stream = (log.odometry if has_odometry else None) if source == "odometry" else log.imu
    if stream is None:
        why = "the odometry reports no yaw_rate" if source == "odometry" else \
            "the log has no IMU and no odometry" if log.odometry is None else \
            "the log has no IMU and its odometry reports no turn rate"
        skipped += [(name, why) for name in names]
        return
    read = integrate(log.frames["time"], stream["time"], stream["yaw_rate"])
    used = intervals.usable & read.covered & (read.squares > 0)
    gross = int(used.sum())
    used[used] &= not_gross(intervals.turn[used] - read.total[used], -read.seconds[used],
                            read.squares[used])
    gross -= int(used.sum())
    if used.sum() < 10:
        skipped += [(name, f"fewer than 10 frame intervals with {source} samples")
                    for name in names]
        return
    first = _first(used, intervals)
    fit = fit_walk(intervals.turn[used] - read.total[used], -read.seconds[used],
                   read.squares[used], _walk_seconds(used, first, intervals), first)
    method = f"{source} yaw_rate; {MOTION_METHOD}{_dropped(gross)}"
    fits += [Fit(names[0], fit.white[0], fit.white[1:], fit.samples, method),
             Fit(names[1], fit.walk[0], fit.walk[1:], fit.samples, method),
             Fit("(turn-rate bias at the start) [rad/s]", fit.start[0], fit.start[1:],
                 fit.samples, method)]
    error = intervals.turn[used] - read.total[used] + fit.start[0] * read.seconds[used]
    residuals["turn"] = (intervals.end[used], error / np.sqrt(read.squares[used]))


def _dropped(gross: int) -> str:
    """The method's note of intervals dropped as outliers (:func:`not_gross`), if any."""
    return f"; {gross} outlying interval{'s' if gross > 1 else ''} dropped (> {GROSS:g} " \
        "robust σ)" if gross else ""


def _camera_ahead(intervals: _Intervals, rng: np.random.Generator, fits: list[Fit],
                  skipped: list[tuple[str, str]], residuals: dict) -> None:
    """The camera's offset ahead of the turning axis: sideways slide against the turn."""
    used = intervals.usable & np.isfinite(intervals.turn)
    gross = int(used.sum())
    used[used] &= not_gross(intervals.side[used], 2.0 * np.sin(0.5 * intervals.turn[used]),
                            np.ones(gross))
    gross -= int(used.sum())
    chord = 2.0 * np.sin(0.5 * intervals.turn[used])
    side = intervals.side[used]
    if used.sum() < 10:
        skipped.append(("vehicle.camera_ahead", "fewer than 10 usable frame intervals"))
        return
    if np.abs(chord).max() < 1e-4:
        skipped.append(("vehicle.camera_ahead", "the truth hardly turns"))
        return
    value = float(side @ chord / (chord @ chord))
    slip = math.sqrt(float(np.mean((side - value * chord) ** 2))
                     / max(float(np.mean(intervals.forward[used] ** 2)), 1e-300))
    if slip > MAX_SLIP:
        skipped.append(("vehicle.camera_ahead", f"the truth slides sideways {slip:.0%} as far "
                        "as it moves ahead, which no turn explains: frames too far apart to be "
                        "one arc, or truth too noisy"))
        return
    blocks = np.unique(intervals.blocks[used], return_inverse=True)[1]
    cross = np.bincount(blocks, weights=side * chord)
    square = np.bincount(blocks, weights=chord * chord)
    interval = block_interval(lambda pick: cross[pick].sum(-1) / square[pick].sum(-1),
                              cross.size, value, rng)
    fits.append(Fit("vehicle.camera_ahead", value, interval, int(used.sum()),
                    "least squares of sideways slide on 2 sin(Δφ/2); block bootstrap"
                    + _dropped(gross) + ("" if interval else NO_INTERVAL)))
    residuals["camera"] = (chord, side)
